"""Neutral curves by pseudo-arclength (MODEL.md §8), plate, Re = 2900, coarse mesh."""

import math

import numpy as np
import pytest

from fsistab.coupled import CoupledSystem
from fsistab.critical import flutter_point
from fsistab.eigen import eigenpairs_near
from fsistab.errors import InputError
from fsistab.neutral import _aero_rows, continue_neutral_curve, divergence_curve
from fsistab.operators import fluid_operators
from fsistab.params import Solid


@pytest.fixture(scope="module")
def plate_operators(plate_2900):
    return fluid_operators(plate_2900)


def test_mass_ratio_derivative_matches_finite_difference(plate_operators):
    """∂(J + iωM)/∂(log m) q, used by the arclength corrector."""
    q = np.random.default_rng(0).standard_normal(CoupledSystem(plate_operators, Solid()).size) + 0j
    omega, eps = 0.2, 1e-6

    def apply(mass_ratio):
        system = CoupledSystem(plate_operators, Solid(mass_ratio=mass_ratio, reduced_velocity=4.5))
        return system.jacobian @ q + 1j * omega * (system.mass @ q)

    fd = (apply(100 * math.exp(eps)) - apply(100 * math.exp(-eps))) / (2 * eps)
    exact = _aero_rows(CoupledSystem(plate_operators, Solid(mass_ratio=100, reduced_velocity=4.5)), q, omega)
    assert np.linalg.norm(fd - exact) < 1e-7 * np.linalg.norm(fd)


def test_flutter_curve_towards_small_mass_ratios(plate_operators):
    solid = Solid(mass_ratio=1000, reduced_velocity=4.7)
    pairs = eigenpairs_near(CoupledSystem(plate_operators, solid), [0.003 + 0.17j], 4)
    guess = max((p for p in pairs if p.label != "fluid"), key=lambda p: p.growth_rate)
    start = flutter_point(
        plate_operators, Solid(mass_ratio=1000, reduced_velocity=4.56), guess.frequency, guess.vector
    )
    saved = []
    curve = continue_neutral_curve(
        plate_operators, start, solid, direction=-1, max_points=4, on_point=saved.append
    )
    assert len(curve.points) == 4 and len(saved) == 3 and curve.stop == "max_points"
    m, u = curve.mass_ratios, curve.reduced_velocities
    assert np.all(np.diff(m) < 0) and np.all(np.diff(u) < 0)  # U*_F falls with m (REFERENCE.md §E trend)
    # every point is neutral: the eigen-solver finds λ = 0 at (m, U*_c) with ω = ω_c
    last = curve.points[-1]
    system = CoupledSystem(
        plate_operators, Solid(mass_ratio=last.mass_ratio, reduced_velocity=last.reduced_velocity)
    )
    nearest = min(
        eigenpairs_near(system, [0.002 + 1j * last.frequency], 3),
        key=lambda p: abs(p.value - 1j * last.frequency),
    )
    assert abs(nearest.growth_rate) < 1e-8
    assert nearest.frequency == pytest.approx(last.frequency, rel=1e-7)


def test_divergence_curve_and_bad_input(plate_operators):
    assert divergence_curve(1.0, 0.5, np.array([4.0]))[0] == pytest.approx(1.0)
    assert np.isnan(divergence_curve(-1.0, 0.5, np.array([4.0]))[0])
    from fsistab.critical import divergence_point

    point = divergence_point(plate_operators, Solid(mass_ratio=1000, reduced_velocity=7.0))
    with pytest.raises(InputError, match="dynamic"):
        continue_neutral_curve(plate_operators, point, Solid())


def test_interrupted_curve_resumes_from_its_last_point(plate_operators, tmp_path):
    from fsistab.errors import CacheError
    from fsistab.neutral import trace_curve_resumable

    solid = Solid(mass_ratio=1000, reduced_velocity=4.7)
    pairs = eigenpairs_near(CoupledSystem(plate_operators, solid), [0.003 + 0.17j], 4)
    guess = max((p for p in pairs if p.label != "fluid"), key=lambda p: p.growth_rate)
    start = flutter_point(
        plate_operators, Solid(mass_ratio=1000, reduced_velocity=4.56), guess.frequency, guess.vector
    )
    path, attrs = tmp_path / "curve.nc", {"case": "plate"}
    first = trace_curve_resumable(plate_operators, start, solid, path, attrs, direction=1, max_points=2)
    resumed = trace_curve_resumable(plate_operators, start, solid, path, attrs, direction=1, max_points=4)
    assert len(first) == 2 and len(resumed) == 4
    assert [p.mass_ratio for p in resumed[:2]] == [p.mass_ratio for p in first]
    assert resumed[-1].mass_ratio > resumed[-2].mass_ratio > 1000
    with pytest.raises(CacheError, match="does not match"):
        trace_curve_resumable(plate_operators, start, solid, path, {"case": "other"}, max_points=4)
