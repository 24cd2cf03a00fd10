"""Shared fixtures: coarse meshes and steady states, computed once per test session."""

import os

# Single-threaded BLAS before NumPy/NGSolve load: with other processes on the cores, OpenBLAS
# threads spinning beside NGSolve's made sparse factorisations up to ten times slower.
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import pytest  # noqa: E402

from fsistab.bodies import Cylinder, Plate  # noqa: E402
from fsistab.mesh import mesh_spec  # noqa: E402
from fsistab.operators import fluid_operators  # noqa: E402
from fsistab.params import Flow  # noqa: E402
from fsistab.steady import solve_steady  # noqa: E402


@pytest.fixture(scope="session")
def cache_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(scope="session")
def plate_coarse_spec():
    return mesh_spec(Plate(), "coarse", 2900)


@pytest.fixture(scope="session")
def plate_2900(plate_coarse_spec):
    """Plate at Re = 2900, α0 = 0, coarse mesh (reached by continuation from rest)."""
    return solve_steady(plate_coarse_spec, Flow(2900, 0.0))


@pytest.fixture(scope="session")
def plate_operators(plate_2900):
    """Fluid operators of ``plate_2900``, assembled once for every module that needs them."""
    return fluid_operators(plate_2900)


@pytest.fixture(scope="session")
def plate_2900_alpha5(plate_coarse_spec):
    return solve_steady(plate_coarse_spec, Flow(2900, 5.0))


@pytest.fixture(scope="session")
def cylinder_coarse_40():
    return solve_steady(mesh_spec(Cylinder(), "coarse", 40), Flow(40))


@pytest.fixture(scope="module")
def client():
    """A dask.distributed client on a 2-worker LocalCluster of single-threaded processes (one per
    test module that asks for it)."""
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(
            n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as c,
    ):
        yield c
