"""Netgen and NGSolve in several Python threads: fsistab's mesh builds and operator assemblies take
turns (``fsistab.mesh.NGSOLVE_LOCK``). Without the lock both tests crash the process: two threads
reading and curving meshes, and an assembly in NGSolve's task manager beside mesh builds (checked by
replacing the lock with a null context)."""

import threading

import numpy as np

from fsistab.bodies import Cylinder
from fsistab.mesh import build_mesh, mesh_spec
from fsistab.operators import fluid_operators


def _in_threads(*targets):
    errors = []

    def run(target):
        try:
            target()
        except Exception as exc:  # reported below, with the thread's error
            errors.append(exc)

    threads = [threading.Thread(target=run, args=(target,)) for target in targets]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not errors, errors


def test_two_threads_building_meshes_take_turns(tmp_path):
    """Each thread generates the mesh in its own cache, then reads it back 150 times."""
    spec = mesh_spec(Cylinder(), "coarse", 40)
    expected = build_mesh(spec, tmp_path / "first").nv
    counts = []

    def builds(cache):
        counts.append(sum(build_mesh(spec, cache).nv == expected for _ in range(150)))

    _in_threads(lambda: builds(tmp_path / "one"), lambda: builds(tmp_path / "two"))
    assert counts == [150, 150]


def test_operators_assembled_beside_mesh_builds_equal_those_alone(tmp_path, plate_2900, plate_operators):
    spec = mesh_spec(Cylinder(), "coarse", 40)
    build_mesh(spec, tmp_path)
    assembled, done = [], threading.Event()

    def assemble():
        try:
            assembled.extend(fluid_operators(plate_2900) for _ in range(10))
        finally:
            done.set()

    def builds():
        while not done.is_set():
            build_mesh(spec, tmp_path)

    _in_threads(assemble, builds)
    assert len(assembled) == 10
    for fluid in assembled:
        for name in ("jff", "mff", "mff_near", "load_f"):
            assert (getattr(fluid, name) != getattr(plate_operators, name)).nnz == 0, name
        for name in ("jfs", "mfs", "load_s", "loads0"):
            assert np.array_equal(getattr(fluid, name), getattr(plate_operators, name)), name
