import math

import numpy as np
import pytest

from fsistab.errors import CacheError
from fsistab.forces import aerodynamic_coefficients, recirculation_length, surface_coefficients
from fsistab.mesh import mesh_spec
from fsistab.params import Cylinder, Flow, Plate
from fsistab.steady import solve_steady, steady_path


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


def test_cache_reuse_and_refusal(tmp_path, plate_coarse_spec):
    spec = mesh_spec(Cylinder(), "coarse", 40)
    first = solve_steady(spec, Flow(40), cache_dir=tmp_path)
    again = solve_steady(spec, Flow(40), cache_dir=tmp_path)
    assert again.from_cache and not first.from_cache
    assert np.array_equal(first.state.vec.FV().NumPy(), again.state.vec.FV().NumPy())
    assert aerodynamic_coefficients(again).drag == aerodynamic_coefficients(first).drag
    path = steady_path(spec, Flow(40), tmp_path)
    assert [p.name for p in path.parent.iterdir()] == [path.name]  # no partial file
    # a file under this key but describing another computation is refused
    other = steady_path(spec, Flow(41), tmp_path)
    path.rename(other)
    with pytest.raises(CacheError, match="does not match"):
        solve_steady(spec, Flow(41), cache_dir=tmp_path)
    other.write_bytes(b"\x89HDF garbage")
    with pytest.raises(CacheError, match="corrupt"):
        solve_steady(spec, Flow(41), cache_dir=tmp_path)


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
