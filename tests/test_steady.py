import logging
import math
import shutil

import numpy as np
import pytest
from damage import KINDS, damage

from fsistab import store
from fsistab.errors import CacheError
from fsistab.forces import aerodynamic_coefficients, recirculation_length, surface_coefficients
from fsistab.mesh import mesh_spec
from fsistab.params import Cylinder, Flow, Plate
from fsistab.steady import load_steady, solve_steady, steady_key, steady_path


def test_symmetric_plate_has_no_lift_or_moment(plate_2900):
    """MODEL.md §6 / REFERENCE.md §E: at α0 = 0 the steady flow is symmetric."""
    c = aerodynamic_coefficients(plate_2900)
    assert abs(c.lift) < 1e-10
    assert abs(c.moment) < 1e-10
    assert 0.01 < c.drag < 0.2
    assert plate_2900.path, "Re = 2900 is reached by continuation"
    assert plate_2900.history[-1] < 1e-9


def test_positive_incidence_gives_lift_and_nose_up_moment(plate_2900_alpha5):
    c = aerodynamic_coefficients(plate_2900_alpha5)
    assert c.lift > 0.1  # thin-airfoil 2π·sin 5° = 0.55 is the inviscid bound
    assert c.moment < 0  # counter-clockwise positive: nose-up is negative


def test_reaction_and_surface_forces_agree(cylinder_coarse_40, plate_2900_alpha5):
    for steady, tol in [(cylinder_coarse_40, 5e-3), (plate_2900_alpha5, 2e-2)]:
        reaction, surface = aerodynamic_coefficients(steady), surface_coefficients(steady)
        assert surface.drag == pytest.approx(reaction.drag, rel=tol)
    reaction, surface = aerodynamic_coefficients(plate_2900_alpha5), surface_coefficients(plate_2900_alpha5)
    assert surface.lift == pytest.approx(reaction.lift, rel=tol)


def test_newton_converges_quadratically(cylinder_coarse_40):
    """r_{k+1} <= K r_k² with K bounded: a linear rate q would give K = q / r_k -> infinity."""
    r = np.array(cylinder_coarse_40.history)
    assert len(r) >= 4 and r[-1] < 1e-9
    k = r[1:] / r[:-1] ** 2
    assert k.max() < 100, k
    assert r[-1] < 1e-4 * r[-2]  # the last step gains more than four orders


def test_lift_is_smooth_in_alpha0():
    """C_L(α0) at Re = 100: centred differences with steps δ and δ/2 agree to O(δ²)."""
    spec = mesh_spec(Plate(), "coarse", 100)
    base = solve_steady(spec, Flow(100, 2.0))

    def lift(alpha):
        return aerodynamic_coefficients(solve_steady(spec, Flow(100, alpha), initial=base)).lift

    delta = 0.5
    slope_1 = (lift(2 + delta) - lift(2 - delta)) / (2 * math.radians(delta))
    slope_2 = (lift(2 + delta / 2) - lift(2 - delta / 2)) / math.radians(delta)
    assert slope_1 > 0
    assert slope_2 == pytest.approx(slope_1, rel=1e-3)


@pytest.fixture(scope="module")
def cylinder_cache(tmp_path_factory):
    """The coarse cylinder at Re 40 solved once into a cache: (spec, cache dir, steady state)."""
    cache = tmp_path_factory.mktemp("cache")
    spec = mesh_spec(Cylinder(), "coarse", 40)
    return spec, cache, solve_steady(spec, Flow(40), cache_dir=cache)


def test_cache_reuse(cylinder_cache):
    spec, cache, first = cylinder_cache
    again = solve_steady(spec, Flow(40), cache_dir=cache)
    assert again.from_cache and not first.from_cache
    assert np.array_equal(first.state.vec.FV().NumPy(), again.state.vec.FV().NumPy())
    assert aerodynamic_coefficients(again).drag == aerodynamic_coefficients(first).drag
    path = steady_path(spec, Flow(40), cache)
    assert [p.name for p in path.parent.iterdir()] == [path.name]  # no partial file


@pytest.mark.parametrize("kind", [*KINDS, "other_key", "wrong_size"])
def test_a_damaged_steady_state_is_reported_and_recomputed(cylinder_cache, tmp_path, caplog, kind):
    """The issue's example: 4 KiB zeroed in a cached state gave C_D = 3.03 instead of 0.405. Every
    damage is caught, reported, the entry moved aside and recomputed to the original state."""
    import h5py

    spec, cache, first = cylinder_cache
    shutil.copytree(cache, tmp_path, dirs_exist_ok=True)
    path = steady_path(spec, Flow(40), tmp_path)
    original = first.state.vec.FV().NumPy().copy()
    if kind in KINDS:
        damage(path, kind, variable="state")
    else:  # a well-formed file (valid checksum) that is not this computation's
        ds = store.read_dataset(path)
        if kind == "other_key":
            ds = ds.assign_attrs(key=steady_key(spec, Flow(41)))
        else:
            ds = ds.isel(dof=slice(0, 100))
        path.unlink()
        store.write_dataset(ds, path)
    if kind in ("flipped", "zeroed", "edited"):
        with h5py.File(path, "r") as f:  # the damage reaches the values a reader would use
            assert not np.array_equal(f["state"][...], original)
    with caplog.at_level(logging.WARNING, logger="fsistab"):
        again = solve_steady(spec, Flow(40), cache_dir=tmp_path)
    assert not again.from_cache
    (warning,) = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert str(path) in warning and "recomputing" in warning and "\n" not in warning
    assert np.allclose(again.state.vec.FV().NumPy(), original, rtol=0, atol=1e-10)
    drag = aerodynamic_coefficients(first).drag
    assert aerodynamic_coefficients(again).drag == pytest.approx(drag, abs=1e-10)
    assert path.with_name(path.name + ".damaged").exists()
    assert solve_steady(spec, Flow(40), cache_dir=tmp_path).from_cache  # the new entry is sound


def test_load_steady_refuses_a_damaged_file_in_one_line(cylinder_cache, tmp_path):
    spec, cache, _ = cylinder_cache
    shutil.copytree(cache, tmp_path, dirs_exist_ok=True)
    path = steady_path(spec, Flow(40), tmp_path)
    damage(path, "edited", variable="state")
    with pytest.raises(CacheError, match="checksum") as error:
        load_steady(path, spec, Flow(40), tmp_path)
    assert str(path) in str(error.value) and "\n" not in str(error.value)


def test_recirculation_behind_cylinder_grows_with_reynolds(cylinder_coarse_40):
    spec = mesh_spec(Cylinder(), "coarse", 40)
    at_50 = solve_steady(spec, Flow(50), initial=cylinder_coarse_40)
    l40, l50 = recirculation_length(cylinder_coarse_40), recirculation_length(at_50)
    assert 1.8 < l40 < l50 < 3.5


@pytest.mark.parametrize(
    ("reynolds", "drag_range", "length_range"),
    [(40, (1.50, 1.54), (2.2, 2.3)), (50, None, (2.9, 3.0))],
)
def test_cylinder_against_reference_medium_mesh(reynolds, drag_range, length_range):
    """REFERENCE.md §A on the medium mesh, default domain [-50, 100] × [-50, 50]."""
    steady = solve_steady(mesh_spec(Cylinder(), "medium", reynolds), Flow(reynolds))
    if drag_range:
        assert drag_range[0] <= aerodynamic_coefficients(steady).drag <= drag_range[1]
    assert length_range[0] <= recirculation_length(steady) <= length_range[1]
