"""One mesh for several Reynolds numbers (``Case.mesh_reynolds``, ``--mesh-reynolds``): the mesh is
the preset fitted to the held Re whatever the flow's Re, the default (None) and a held Re equal to the
flow's give today's mesh and keys, and a Re study on the held coarse mesh is smooth: its centred
difference of the flutter threshold is the adjoint derivative dU*_F/dRe of `fsistab sensitivity`,
and its second difference is the one the adjoint derivatives at its ends predict."""

from dataclasses import replace

import pytest

from fsistab.bodies import Plate
from fsistab.coupled import CoupledSystem
from fsistab.critical import flutter_point
from fsistab.eigen import eigenpairs_near
from fsistab.errors import InputError
from fsistab.mesh import mesh_spec, spec_for
from fsistab.operators import fluid_operators
from fsistab.params import MAX_REYNOLDS, Case, Flow, Solid
from fsistab.payloads import payload
from fsistab.steady import solve_steady

HELD = 2900.0
STEP = 29.0  # 1 % of Re: the spacing of the fitted-mesh study (2871, 2900, 2929)
SOLID = Solid(mass_ratio=1000, reduced_velocity=4.39)  # the default springs of `fsistab critical`


def _case(reynolds: float, mesh_reynolds: float | None = None, **kwargs) -> Case:
    return Case(Plate(), Flow(reynolds), "coarse", mesh_reynolds=mesh_reynolds, **kwargs)


@pytest.mark.parametrize("value", [0.0, -1.0, float("nan"), float("inf"), 2 * MAX_REYNOLDS])
def test_mesh_reynolds_is_refused_unless_positive_and_bounded(value):
    with pytest.raises(InputError, match="--mesh-reynolds"):
        _case(HELD, value)


def test_create_passes_the_mesh_reynolds():
    case = Case.create("plate", 2871, preset="coarse", mesh_reynolds=2900)
    assert case.mesh_reynolds == 2900.0 and case.fitted_reynolds == 2900.0
    assert Case.create("plate", 2871, preset="coarse").fitted_reynolds == 2871.0


def test_a_held_re_equal_to_the_flows_is_todays_mesh_keys_and_files():
    for reynolds in (100.0, 2871.0, HELD, 1e4):  # below and above the high-Re branch of the sizes
        today, held = _case(reynolds), _case(reynolds, reynolds)
        assert spec_for(held) == spec_for(today) == mesh_spec(Plate(), "coarse", reynolds)
        assert spec_for(held).key() == spec_for(today).key()
        assert spec_for(held).linear_identity() == spec_for(today).linear_identity()
        assert held.tag == today.tag == f"plate_Re{reynolds:g}_a0"


def test_a_held_re_is_the_mesh_of_that_re_and_names_its_files():
    case = _case(2871, HELD)
    assert spec_for(case) == spec_for(_case(HELD))
    # the mesh fitted to 2871 is another (the wall size follows Re^-1/2): the threshold jumps there
    assert spec_for(case).key() != spec_for(_case(2871)).key()
    assert case.tag == "plate_Re2871_a0_meshRe2900" != _case(2871).tag
    assert _case(2871, 2929).tag != case.tag


def test_payloads_say_the_mesh_reynolds():
    import xarray as xr

    ds = xr.Dataset(attrs={"parameter": "reynolds", "critical_value": 50.0, "frequency": 0.7})
    ds.attrs |= {"iterations": 3, "factorisations": 6, "data": "x.nc", "figure": "x.png"}
    assert "mesh_reynolds" not in payload("onset", ds)
    assert payload("onset", ds.assign_attrs(mesh_reynolds=2900.0))["mesh_reynolds"] == 2900.0


@pytest.fixture(scope="module")
def held_study(plate_coarse_spec, plate_2900, plate_operators):
    """Flutter thresholds at Re 2900 - 29, 2900, 2900 + 29 on the mesh fitted to 2900 (steady states
    continued from the session's Re 2900 state) and their adjoint derivatives dU*_F/dRe."""
    from fsistab.sensitivity import threshold_sensitivity

    system = CoupledSystem(plate_operators, SOLID)
    pair = min(eigenpairs_near(system, [0.1876j], 2), key=lambda p: abs(p.value - 0.1876j))
    centre = flutter_point(plate_operators, SOLID, pair.frequency, pair.vector)
    assert centre.kind == "flutter"
    start = replace(SOLID, reduced_velocity=centre.reduced_velocity)
    velocities, slopes = {}, {}
    for offset in (-STEP, 0.0, STEP):
        case = _case(HELD + offset, HELD)
        assert spec_for(case) == plate_coarse_spec
        if offset == 0:
            fluid, point = plate_operators, centre
        else:
            fluid = fluid_operators(solve_steady(spec_for(case), case.flow, initial=plate_2900))
            point = flutter_point(fluid, start, centre.frequency, centre.mode)
        velocities[offset] = point.reduced_velocity
        slopes[offset] = threshold_sensitivity(fluid, start, point, ("reynolds",)).velocity["reynolds"]
    return velocities, slopes


def test_a_re_study_on_one_mesh_is_smooth_and_matches_the_adjoint(held_study):
    velocities, slopes = held_study
    centred = (velocities[STEP] - velocities[-STEP]) / (2 * STEP)
    assert centred == pytest.approx(slopes[0.0], rel=0.01)
    # U(h) - 2U(0) + U(-h) = h (U'(h) - U'(-h)) / 2 + O(h^4): the curvature of the threshold itself.
    # On meshes fitted to each Re the second difference is 1 % of U*_F (a change of mesh).
    second = velocities[STEP] - 2 * velocities[0.0] + velocities[-STEP]
    predicted = STEP * (slopes[STEP] - slopes[-STEP]) / 2
    assert abs(second - predicted) < 0.1 * abs(predicted) + 1e-7
