"""VTK files for ParaView: fields on the mesh (modes, sensitivity maps), one writer for all.

Each file is ``path`` with ``.vtu`` appended (unless it ends so: a name with dots, such as
alpha0 = 2.5, keeps them), written atomically (:func:`fsistab.store.atomic_path`), the mesh
elements not subdivided.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np


def write_vtk(mesh, fields: Mapping[str, object], path: Path) -> Path:
    """The NGSolve coefficient functions ``fields`` (name → field) on ``mesh`` as one VTK file."""
    from ngsolve import VTKOutput

    from fsistab.store import atomic_path

    path = Path(path)
    target = path if path.suffix == ".vtu" else path.with_name(path.name + ".vtu")
    with atomic_path(target, ".vtu") as tmp:
        # VTKOutput appends ".vtu" to the name it is given: give it the temporary without it
        stem = str(tmp.with_suffix(""))
        VTKOutput(mesh, coefs=list(fields.values()), names=list(fields), filename=stem, subdivision=1).Do()
    return target


def mode_fields(steady, fluid_index, modes: Mapping[str, np.ndarray]) -> dict[str, object]:
    """Real and imaginary parts of the velocity and pressure of each mode: ``modes`` maps a name
    to a fluid vector (the fluid unknowns, indexed by ``fluid_index`` in ``steady``'s space)."""
    from ngsolve import GridFunction

    fields = {}
    for name, vector in modes.items():
        for part, values in (("re", vector.real), ("im", vector.imag)):
            field = GridFunction(steady.space)
            field.vec.FV().NumPy()[fluid_index] = values
            fields[f"{name}_velocity_{part}"] = field.components[0]
            fields[f"{name}_pressure_{part}"] = field.components[1]
    return fields


def write_modes_vtk(steady, fluid_index, modes: Mapping[str, np.ndarray], path: Path) -> Path:
    """The modes (:func:`mode_fields`) on ``steady``'s mesh as one VTK file."""
    return write_vtk(steady.mesh, mode_fields(steady, fluid_index, modes), path)


def map_fields(maps: Sequence) -> dict[str, object]:
    """Per target of the sensitivity maps (:class:`fsistab.sensitivity.SensitivityMaps`): the
    real and imaginary parts of the steady-force and control-cylinder maps, and the structural
    sensitivity."""
    fields = {}
    for m in maps:
        for part, index in (("re", 0), ("im", 1)):
            fields[f"{m.kind}_force_{part}"] = m.force[index]
            fields[f"{m.kind}_control_{part}"] = m.control[index]
        fields[f"{m.kind}_structural"] = m.structural
    return fields


def write_maps_vtk(maps: Sequence, mesh, path: Path) -> Path:
    """The sensitivity maps (:func:`map_fields`) on ``mesh`` as one VTK file."""
    return write_vtk(mesh, map_fields(maps), path)


def write_state_vtk(steady, state: np.ndarray, path: Path) -> Path:
    """One state of a time march (every dof of ``steady``'s space, wall dofs included) as a VTK
    file: the velocity (body axes) and the pressure."""
    from ngsolve import GridFunction

    field = GridFunction(steady.space)
    field.vec.FV().NumPy()[:] = state
    fields = {"velocity": field.components[0], "pressure": field.components[1]}
    return write_vtk(steady.mesh, fields, path)


def snapshot_writer(directory: Path, stem: str):
    """``(write, paths)``: ``write(index, time, steady, state)`` saves a march's state as
    ``{stem}_{index:05d}.vtu`` in ``directory`` (:func:`write_state_vtk`) and adds its path to the
    list ``paths`` (the snapshot callback of :func:`fsistab.workflows.simulate`)."""
    paths: list[str] = []

    def write(index: int, time: float, steady, state: np.ndarray) -> None:
        paths.append(str(write_state_vtk(steady, state, Path(directory) / f"{stem}_{index:05d}")))

    return write, paths
