"""Neutral curves in the (Re, U*) and (α0, U*) planes (fsistab.flow_neutral), plate, coarse mesh."""

import math

import numpy as np
import pytest

from fsistab.coupled import CoupledSystem
from fsistab.eigen import eigenpairs_near
from fsistab.errors import InputError
from fsistab.flow_neutral import (
    _FlowDeterminant,
    continue_flow_neutral_curve,
    flow_curve_table,
    record_flow_curve,
)
from fsistab.linalg import FactorCounter
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Solid
from fsistab.steady import solve_steady

SOLID = Solid(mass_ratio=1000, reduced_velocity=4.39)


def test_determinant_derivatives_match_finite_differences(plate_2900, plate_coarse_spec):
    """∂ det T/∂ω and ∂ det T/∂ log U* (analytic) against centred differences of det T."""
    problem = _FlowDeterminant(
        plate_coarse_spec, Flow(2900), SOLID, "alpha0", None, FactorCounter(), plate_2900
    )
    y = np.array([0.19, math.log(4.4), 0.0])
    det, d_omega, d_logu = problem.determinant(y, derivatives=True)
    for index, exact in ((0, d_omega), (1, d_logu)):
        eps = 1e-5
        up, down = y.copy(), y.copy()
        up[index] += eps
        down[index] -= eps
        fd = (problem.determinant(up) - problem.determinant(down)) / (2 * eps)
        assert abs(fd - exact) < 1e-6 * abs(exact)


def test_points_along_reynolds_are_neutral(plate_2900, plate_coarse_spec, cache_dir, tmp_path):
    """Two steps down in Re from the m = 1000 flutter onset: at each point, the full eigen-solver
    on that flow's steady state has an eigenvalue λ = 0 (1e-7) at ω = ω_c."""
    counter = FactorCounter()
    curve = continue_flow_neutral_curve(
        plate_coarse_spec,
        Flow(2900),
        SOLID,
        0.1876,
        "reynolds",
        (1000.0, 2900.0),
        direction=-1,
        step=0.1,
        max_points=3,
        cache_dir=cache_dir,
        initial=plate_2900,
        counter=counter,
    )
    assert curve.stops[-1] == "max_points" and len(curve.points) == 3
    reynolds = curve.values("reynolds")
    assert reynolds[0] == pytest.approx(2900) and np.all(np.diff(reynolds) < 0)
    for point in curve.points[1:]:
        steady = solve_steady(plate_coarse_spec, Flow(point.reynolds), cache_dir=cache_dir)
        system = CoupledSystem(
            fluid_operators(steady), Solid(mass_ratio=1000, reduced_velocity=point.reduced_velocity)
        )
        pair = min(eigenpairs_near(system, [1j * point.frequency], 4), key=lambda p: abs(p.value.real))
        assert abs(pair.value.real) < 1e-7 and pair.frequency == pytest.approx(point.frequency, rel=1e-6)
    ds = record_flow_curve(flow_curve_table(tmp_path / "half.nc", {"mass_ratio": 1000.0}), curve)
    assert ds.attrs["parameter"] == "reynolds" and ds.sizes["point"] == 3
    saved = flow_curve_table(tmp_path / "half.nc", {"mass_ratio": 1000.0})  # what a rerun reads
    assert saved.complete and saved.final_attrs["stop"] == "max_points"
    assert [r["reynolds"] for r in saved.records_of("point")] == reynolds.tolist()


def test_bad_flow_continuation_input(plate_coarse_spec):
    for args in (("mach", (0.0, 1.0)), ("reynolds", (3000.0, 1000.0)), ("alpha0", (1.0, 2.0))):
        with pytest.raises(InputError):
            continue_flow_neutral_curve(plate_coarse_spec, Flow(2900), SOLID, 0.19, *args)
