"""Critical points of the plate (docs/model.md §8), Re = 2900, α0 = 0, coarse mesh."""

import math

import numpy as np
import pytest

from fsistab.coupled import CoupledSystem, stiffness_derivative
from fsistab.critical import divergence_point, flutter_point
from fsistab.eigen import eigenpairs_near
from fsistab.errors import ConvergenceError, InputError
from fsistab.linalg import FactorCounter
from fsistab.operators import fluid_operators
from fsistab.params import Solid
from fsistab.slopes import static_slopes


def _quadratic(history):
    """Converged, and the last step squares the residual (up to a bounded constant)."""
    r = np.array(history)
    return r[-1] < 1e-9 and r[-1] < 1e4 * r[-2] ** 2


def test_stiffness_derivative_matches_finite_difference():
    from fsistab.coupled import solid_stiffness

    solid, eps = Solid(mass_ratio=10, reduced_velocity=3.0, zeta_h=0.02), 1e-6
    fd = (
        solid_stiffness(Solid(**{**solid.__dict__, "reduced_velocity": 3.0 + eps}))
        - solid_stiffness(Solid(**{**solid.__dict__, "reduced_velocity": 3.0 - eps}))
    ) / (2 * eps)
    assert np.allclose(fd, stiffness_derivative(solid), atol=1e-8)


def test_divergence_is_the_torsional_formula(plate_operators):
    """docs/model.md §8: U*_D = sqrt(m r_θ² / (dC_M/dθ)) with the computed static slope."""
    slope = static_slopes(plate_operators).moment
    counter = FactorCounter()
    for mass_ratio in (100.0, 1000.0):
        point = divergence_point(
            plate_operators, Solid(mass_ratio=mass_ratio, reduced_velocity=5.0), counter=counter
        )
        expected = math.sqrt(mass_ratio * 0.289**2 / slope)
        assert point.reduced_velocity == pytest.approx(expected, rel=1e-9)
        assert point.kind == "divergence" and point.frequency == 0
        assert _quadratic(point.residuals)
    assert counter.count == 2  # one real factorisation of J_ff per call


def test_divergence_mode_is_static_and_failure_is_reported(plate_operators):
    """The returned pair solves the static problem: θ̂ = 1 exactly, ḣ = θ' = 0 (the kinematic rows
    of docs/model.md §7), ``J(U*_D) q̂ ≈ 0`` at the returned U*_D; without a Newton step the start
    (``q̂ = J⁻¹ e_θ``, ``‖J q̂‖ = 1/|(J⁻¹ e_θ)_θ|``) is not a root and the error says where."""
    solid = Solid(mass_ratio=1000, reduced_velocity=7.0)
    point = divergence_point(plate_operators, solid)
    system = CoupledSystem(plate_operators, Solid(mass_ratio=1000, reduced_velocity=point.reduced_velocity))
    labels = system.state_labels()
    mode = point.mode
    assert mode[labels.index("theta")] == 1.0
    assert np.max(np.abs(mode[[labels.index("hdot"), labels.index("thetadot")]])) < 1e-12
    assert np.linalg.norm(system.jacobian @ mode) < 1e-10
    with pytest.raises(
        ConvergenceError, match=r"divergence Newton did not converge near U\* = 7 \(residuals"
    ):
        divergence_point(plate_operators, solid, maxit=0)


def test_flutter_point_is_an_eigenvalue_crossing(plate_operators):
    # bracket the crossing with two eigen-solves, interpolate, then Newton from there
    branch = {}
    for velocity in (4.3, 4.7):
        system = CoupledSystem(plate_operators, Solid(mass_ratio=1000, reduced_velocity=velocity))
        pairs = eigenpairs_near(system, [0.003 + 0.17j], 4)
        branch[velocity] = max((p for p in pairs if p.label != "fluid"), key=lambda p: p.growth_rate)
    assert branch[4.3].growth_rate < 0 < branch[4.7].growth_rate  # flutter onset (Moulin & Marquet 2021)
    weight = branch[4.7].growth_rate / (branch[4.7].growth_rate - branch[4.3].growth_rate)
    guess_velocity = 4.7 - weight * 0.4
    solid = Solid(mass_ratio=1000, reduced_velocity=guess_velocity)
    counter = FactorCounter()
    guess = branch[4.7]
    point = flutter_point(plate_operators, solid, guess.frequency, guess.vector, counter=counter)
    assert _quadratic(point.residuals)
    assert counter.count == len(point.residuals) - 1  # one factorisation per Newton step
    assert 4.0 < point.reduced_velocity < 4.7  # Moulin & Marquet 2021: U*_F ≈ 4.5 (fine mesh)
    # the eigen-solver at the critical U* finds a neutral eigenvalue at the critical frequency
    at_critical = CoupledSystem(
        plate_operators, Solid(mass_ratio=1000, reduced_velocity=point.reduced_velocity)
    )
    shift = 1j * point.frequency + 0.002
    nearest = min(eigenpairs_near(at_critical, [shift], 3), key=lambda p: abs(p.value - 1j * point.frequency))
    assert abs(nearest.growth_rate) < 1e-8
    assert nearest.frequency == pytest.approx(point.frequency, rel=1e-8)
    # and the growth rate changes sign across U*_c: onset of flutter as U* increases
    below = CoupledSystem(
        plate_operators, Solid(mass_ratio=1000, reduced_velocity=0.99 * point.reduced_velocity)
    )
    value = min(eigenpairs_near(below, [shift], 3), key=lambda p: abs(p.value - 1j * point.frequency))
    assert value.growth_rate < 0


def test_critical_point_needs_a_solid(plate_operators):
    with pytest.raises(InputError, match="pitch"):
        divergence_point(plate_operators, Solid(dofs=("heave",)))


def test_thresholds_along_reduced_velocity(plate_operators):
    """m = 1000: flutter onset, then divergence (Moulin & Marquet 2021 order), from one sweep."""
    from fsistab.critical import find_thresholds

    counter = FactorCounter()
    thresholds, details = find_thresholds(
        plate_operators,
        Solid(mass_ratio=1000, reduced_velocity=3.0),
        np.geomspace(3, 9, 12),
        counter=counter,
        method="tracking",
    )
    kinds = [(t.kind, t.boundary) for t in thresholds]
    assert kinds[0] == ("flutter", "onset") and ("divergence", "onset") in kinds
    direct = flutter_point(
        plate_operators,
        Solid(mass_ratio=1000, reduced_velocity=thresholds[0].reduced_velocity * 1.01),
        thresholds[0].frequency,
        thresholds[0].mode,
    )
    assert thresholds[0].reduced_velocity == pytest.approx(direct.reduced_velocity, rel=1e-8)
    divergence = next(t for t in thresholds if t.kind == "divergence")
    slope = static_slopes(plate_operators).moment
    assert divergence.reduced_velocity == pytest.approx(math.sqrt(1000 * 0.289**2 / slope), rel=1e-9)
    heave = details["branches"]["heave"]
    assert all(label != "fluid" for label in heave.labels)  # the branch kept its identity


def test_thresholds_continue_along_reynolds(plate_coarse_spec, plate_2900, tmp_path):
    """(Re, U*) plane: the continued flutter point is an eigenvalue on the axis of the full problem at
    the new Re, and the divergence point obeys the torsional formula with that Re's static slope."""
    from fsistab.critical import critical_points_along_flow
    from fsistab.params import Flow
    from fsistab.steady import solve_steady

    flows = [Flow(2900.0), Flow(2600.0)]
    sweep = critical_points_along_flow(
        plate_coarse_spec, flows, Solid(1000.0, 4.5), 0.18, cache_dir=tmp_path, initial=plate_2900
    )
    pairs = list(sweep)
    assert [(f.reynolds, d.reynolds) for f, d in pairs] == [(2900.0, 2900.0), (2600.0, 2600.0)]
    assert [(f.kind, d.kind) for f, d in pairs] == [("flutter", "divergence")] * 2
    flutter, divergence = pairs[1]
    fluid = fluid_operators(solve_steady(plate_coarse_spec, flows[1], cache_dir=tmp_path))  # cached
    system = CoupledSystem(fluid, Solid(1000.0, flutter.reduced_velocity))
    nearest = eigenpairs_near(system, [1j * flutter.frequency], 2)[0]
    assert abs(nearest.value - 1j * flutter.frequency) < 1e-8
    slope = static_slopes(fluid).moment
    assert divergence.reduced_velocity == pytest.approx(math.sqrt(1000.0 * 0.289**2 / slope), rel=1e-9)
    assert flutter.reduced_velocity != pytest.approx(pairs[0][0].reduced_velocity, rel=1e-3)  # it moved


def test_wake_mode_is_refined_from_a_guess(plate_operators):
    """The fixed plate's wake mode (Moulin & Marquet 2021: slightly stable, ω ≈ 11.2) from a rough guess;
    it is the least stable of the fixed-body eigenvalues near the guess. Coarse mesh, default
    domain [-20, 40] × [-20, 20]: ω within 5 % of 11.2 (the coarse value is 3.5 % low)."""
    from fsistab.critical import wake_mode_near

    wake = wake_mode_near(plate_operators, 11.0)
    assert wake.growth_rate < 0 and abs(wake.frequency - 11.2) < 0.05 * 11.2
    assert wake.label == "fluid"
    from_other_guess = wake_mode_near(plate_operators, 10.9)
    assert from_other_guess.value == pytest.approx(wake.value, rel=1e-8)
    with pytest.raises(InputError):
        wake_mode_near(plate_operators, -1.0)


def test_thresholds_at_re_100_hold_each_point_once(tmp_path):
    """At Re 100 (coarse, m = 1000, the study's sweep: 24 values of U* in [2, 10]) the pitch
    branch's frequency falls to zero at divergence: its sign change used to be refined into a
    second, "flutter" copy of the divergence point (ω ≈ -1.7e-13). Every threshold is reported
    once, the static one as divergence only."""
    from fsistab.bodies import Plate
    from fsistab.critical import find_thresholds
    from fsistab.mesh import mesh_spec
    from fsistab.params import Flow
    from fsistab.steady import solve_steady

    spec = mesh_spec(Plate(), "coarse", 100.0)
    fluid = fluid_operators(solve_steady(spec, Flow(100.0), cache_dir=tmp_path))
    found, _ = find_thresholds(fluid, Solid(1000.0, 2.0), np.geomspace(2.0, 10.0, 24))
    assert [t.kind for t in found].count("divergence") == 1
    for t in found:
        if t.kind != "divergence":
            assert abs(t.frequency) > 1e-6
    points = [(t.kind, t.boundary, round(t.reduced_velocity, 6), round(abs(t.frequency), 6)) for t in found]
    assert len(points) == len(set(points))
