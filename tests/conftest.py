"""Shared fixtures: coarse meshes and steady states, computed once per test session."""

import pytest

from fsistab.mesh import mesh_spec
from fsistab.params import Cylinder, Flow, Plate
from fsistab.steady import solve_steady


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
def plate_2900_alpha5(plate_coarse_spec):
    return solve_steady(plate_coarse_spec, Flow(2900, 5.0))


@pytest.fixture(scope="session")
def cylinder_coarse_40():
    return solve_steady(mesh_spec(Cylinder(), "coarse", 40), Flow(40))
