"""Aerodynamic transfer functions (fsistab.transfer): exact elimination of the fluid, its derivative,
the neutral point of det T(iω; U*), the viscous Theodorsen function."""

import json
import math
from concurrent.futures import Future

import numpy as np
import pytest
from typer.testing import CliRunner

from fsistab.cli import app
from fsistab.coupled import CoupledSystem
from fsistab.critical import flutter_point
from fsistab.eigen import eigenpairs_near, neutral_eigenpair
from fsistab.errors import InputError
from fsistab.linalg import FactorCounter, FluidFactor
from fsistab.operators import fluid_operators
from fsistab.params import Solid
from fsistab.slopes import static_slopes
from fsistab.transfer import (
    Deferred,
    TransferDeterminant,
    aerodynamic_loads,
    characteristic_matrix,
    exact_transfer,
    iter_transfer_samples,
    transfer_flutter_point,
    transfer_sample,
    viscous_theodorsen_dataset,
)


@pytest.fixture(scope="module")
def plate_fluid_alpha5(plate_2900_alpha5):
    return fluid_operators(plate_2900_alpha5)


def _smallest_singular_ratio(matrix: np.ndarray) -> float:
    values = np.linalg.svd(matrix, compute_uv=False)
    return values[-1] / values[0]


def test_transfer_derivative_matches_finite_difference(plate_fluid_alpha5):
    fluid, s, h = plate_fluid_alpha5, 0.02 + 0.7j, 1e-5
    _, rate = exact_transfer(fluid, s, derivative=True)
    centred = (exact_transfer(fluid, s + h) - exact_transfer(fluid, s - h)) / (2 * h)
    assert np.abs(rate - centred).max() < 1e-5 * np.abs(rate).max()


@pytest.mark.parametrize("fixture", ["plate_operators", "plate_fluid_alpha5"])
def test_zero_frequency_loads_are_the_static_slopes(fixture, request):
    """G(0) is the quasi-static response: the pitch column of the loads gives docs/model.md §9's slopes."""
    fluid = request.getfixturevalue(fixture)
    factor = FluidFactor(fluid, 0.0)  # one factorisation of J_ff serves both
    loads = aerodynamic_loads(exact_transfer(fluid, 0.0, factor=factor), fluid.theta0, fluid.loads0, 0.0)
    slopes = static_slopes(fluid, factor=factor)
    assert loads[0, 1] == pytest.approx(slopes.lift, rel=1e-10)
    assert loads[1, 1] == pytest.approx(slopes.moment, rel=1e-10)
    assert np.abs(loads[:, 0]).max() < 1e-12  # translation invariance: a steady heave changes nothing


def test_neutral_mode_from_the_transfer_function_is_the_arnoldi_eigenvector(plate_operators):
    """At the flutter onset (coarse plate, m = 1000), the critical mode built from the null vector
    of the characteristic matrix (no Arnoldi) is the eigenvector that shift-invert Arnoldi finds
    at σ = iω_c: same eigenvalue, label, energy share and normalised vector."""
    fluid = plate_operators
    point, sample = transfer_flutter_point(fluid, Solid(1000.0, 4.4), 0.187)
    solid = Solid(1000.0, point.reduced_velocity)
    system = CoupledSystem(fluid, solid)
    vector = sample.mode(solid, fluid.theta0, fluid.loads0)
    pair = neutral_eigenpair(system, point.frequency, vector)
    arnoldi = min(eigenpairs_near(system, [1j * point.frequency], 2), key=lambda p: abs(p.value - pair.value))
    assert abs(arnoldi.value - 1j * point.frequency) < 1e-7
    assert pair.residual < 1e-8 and pair.label == arnoldi.label == "heave"
    assert pair.solid_energy_fraction == pytest.approx(arnoldi.solid_energy_fraction, rel=1e-6)
    assert np.linalg.norm(pair.vector - arnoldi.vector) < 1e-6 * np.linalg.norm(arnoldi.vector)


def test_block_solve_in_threads_is_the_column_by_column_solve(plate_operators):
    """The columns of a block solved two at a time (the Krylov blocks of the reduced models) give
    the same vectors as one at a time, each solving ``K_ff(s) x = b`` to round-off."""
    fluid = plate_operators
    factor = FluidFactor(fluid, 0.3 + 0.6j)
    rng = np.random.default_rng(7)
    block = rng.standard_normal((fluid.n_fluid, 5)) + 1j * rng.standard_normal((fluid.n_fluid, 5))
    threaded = factor.solve(block, threads=2)
    serial = factor.solve(block, threads=1)
    assert np.array_equal(threaded, serial)
    matrix = fluid.jff + (0.3 + 0.6j) * fluid.mff
    residual = np.linalg.norm(matrix @ threaded - block, axis=0) / np.linalg.norm(block, axis=0)
    assert residual.max() < 1e-12
    with pytest.raises(InputError, match="threads"):
        factor.solve(block, threads=0)


def test_a_zero_column_of_a_block_is_not_solved(plate_operators):
    """The heave column of ``J_fs + s M_fs`` is zero (the body-frame equations do not see the heave
    displacement, docs/model.md §7): its solution is returned as zeros without a solve, the other
    columns as solved one by one."""
    fluid = plate_operators
    shift = 0.3 + 0.6j
    block = fluid.jfs + shift * fluid.mfs
    assert not np.any(block[:, 0]) and all(np.any(block[:, k]) for k in (1, 2, 3))
    factor = FluidFactor(fluid, shift)
    solves = []
    solve = factor._lu.solve
    factor._lu.solve = lambda b, *args, **kwargs: solves.append(1) or solve(b, *args, **kwargs)
    result = factor.solve(block, refine=False, threads=1)
    assert len(solves) == 3
    assert not np.any(result[:, 0])
    for k in (1, 2, 3):
        assert np.array_equal(result[:, k], solve(block[:, k], False))


@pytest.mark.parametrize("shift", [0.0, 0.2j, 1.1j, 0.05 + 0.7j])
def test_unrefined_samples_agree_with_refined_ones(plate_operators, shift):
    """The map samples G without the refinement step (``fsistab.transfer_map.SAMPLE_REFINE``): with
    the symmetric nested-dissection analysis the plain solves give G and dG/ds as the refined ones
    to far below the rational fits' certification (1e-6); 3e-13 and 3e-12 on the default mesh."""
    fluid = plate_operators
    factor = FluidFactor(fluid, shift)
    plain = transfer_sample(fluid, shift, factor=factor, refine=False)
    refined = transfer_sample(fluid, shift, factor=factor, refine=True)
    assert np.abs(plain.value - refined.value).max() < 1e-11 * np.abs(refined.value).max()
    assert np.abs(plain.rate - refined.rate).max() < 1e-10 * np.abs(refined.rate).max()


@pytest.mark.parametrize("threads", [1, 2])
def test_later_shifts_join_the_batch_once_known(plate_operators, threads):
    """``iter_transfer_samples`` with shifts known only once a future is done (a reduced model being
    built, in a map): with two threads they join the queue at the first sample finished after the
    future is done, not after the batch; with one thread, after the batch. Every sample counted
    once and equal to the one made alone, bit for bit."""
    shifts, extra = [0.3j, 0.5j, 0.7j, 0.9j], [0.4j]
    model = Future()
    seen, asked = [], []

    def items():
        asked.append(len(seen))
        return extra

    later = Deferred((model,), items)
    counter = FactorCounter()
    found = iter_transfer_samples(plate_operators, shifts, counter, threads=threads, later=later)
    for n, sample in enumerate(found):
        seen.append(sample)
        if n == 0:
            model.set_result(None)  # the model is done while the batch is under way
    # two threads: asked before the batch's end (after the first or second sample, as they finish)
    assert len(asked) == 1 and (asked[0] < len(shifts) if threads == 2 else asked[0] == len(shifts))
    assert sorted(s.s.imag for s in seen) == sorted(s.imag for s in shifts + extra)
    assert counter.count == len(shifts) + len(extra)
    alone = transfer_sample(plate_operators, 0.4j)
    (joined,) = [s for s in seen if s.s == 0.4j]
    assert np.array_equal(joined.value, alone.value) and np.array_equal(joined.rate, alone.rate)


@pytest.mark.parametrize(
    ("fixture", "solid", "shift"),
    [
        ("plate_operators", Solid(1000.0, 4.7), 0.002 + 0.17j),
        ("plate_fluid_alpha5", Solid(1000.0, 4.7), 0.002 + 0.17j),
        ("plate_operators", Solid(5.0, 1.0), 0.8j),
        ("plate_operators", Solid(50.0, 2.0, dofs=("heave",)), 0.4j),
    ],
)
def test_characteristic_matrix_is_singular_at_coupled_eigenvalues(fixture, solid, shift, request):
    """Exact elimination: det T(σ) = 0 at eigenvalues of the full coupled problem (E), and T is
    regular away from them."""
    fluid = request.getfixturevalue(fixture)
    pair = eigenpairs_near(CoupledSystem(fluid, solid), [shift], 3)[0]
    sigma = pair.value
    t = characteristic_matrix(exact_transfer(fluid, sigma), solid, sigma, fluid.theta0, fluid.loads0)
    assert _smallest_singular_ratio(t) < 1e-9
    away = sigma + 0.05
    t_away = characteristic_matrix(exact_transfer(fluid, away), solid, away, fluid.theta0, fluid.loads0)
    assert _smallest_singular_ratio(t_away) > 1e-4


def test_transfer_newton_finds_the_augmented_newton_flutter_point(plate_operators):
    """Newton on det T(iω; U*) = 0 (4 × 4) and on the augmented sparse system (docs/model.md §8) find the
    same neutral point, and the former converges quadratically."""
    solid = Solid(1000.0, 4.5)
    point, _ = transfer_flutter_point(plate_operators, solid, 0.18)
    residuals = np.array(point.residuals)
    assert residuals[-1] < 1e-12
    pairs = [
        (a, b) for a, b in zip(residuals[:-1], residuals[1:], strict=True) if 1e-10 < a < 1e-3 and b > 1e-15
    ]
    assert pairs and all(b < 1e3 * a * a for a, b in pairs)  # quadratic convergence
    velocity = point.reduced_velocity
    system = CoupledSystem(plate_operators, Solid(1000.0, velocity))
    mode = min(eigenpairs_near(system, [1j * point.frequency], 3), key=lambda p: abs(p.value.real))
    assert abs(mode.value - 1j * point.frequency) < 1e-8
    reference = flutter_point(plate_operators, Solid(1000.0, velocity * 1.001), point.frequency, mode.vector)
    assert point.reduced_velocity == pytest.approx(reference.reduced_velocity, rel=1e-8)
    assert point.frequency == pytest.approx(reference.frequency, rel=1e-8)
    assert point.factorisations == point.iterations


@pytest.mark.parametrize("dofs", [("heave", "pitch"), ("pitch",)])
def test_determinant_gradient_matches_finite_differences(plate_operators, dofs):
    """∂ det T/∂(ω, log U*, log m) of the transfer formulation against centred differences of det T
    (∂/∂ log m is new: every aerodynamic term of T scales with 1/m)."""
    fluid, eps = plate_operators, 1e-5
    determinant = TransferDeterminant(fluid, Solid(1000.0, 4.5, dofs=dofs), FactorCounter())
    y = np.array([0.19, math.log(4.4), math.log(300.0)])
    _, gradient = determinant.characteristic(y, True)
    for index in range(3):
        up, down = y.copy(), y.copy()
        up[index] += eps
        down[index] -= eps
        fd = (determinant.characteristic(up, False) - determinant.characteristic(down, False)) / (2 * eps)
        assert abs(fd - gradient[index]) < 1e-6 * abs(gradient[index])


def test_bad_input_is_refused_before_any_factorisation(plate_operators):
    counter = FactorCounter()
    for frequencies in ([], [0.5, -0.1], [0.5, float("nan")], [0.0]):
        with pytest.raises(InputError, match="frequencies"):
            viscous_theodorsen_dataset(plate_operators, frequencies, counter=counter)
    assert counter.count == 0


def test_transfer_command_json(tmp_path, monkeypatch):
    monkeypatch.setenv("FSISTAB_CACHE", str(tmp_path / "cache"))
    args = ["transfer", "--Re", "2900", "--mesh", "coarse", "--points", "3", "--out", str(tmp_path), "--json"]
    result = CliRunner().invoke(app, [*args, "--reduced-frequency-range", "0.001", "0.5"])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert payload["factorisations"] == 3 + 1
    first = payload["samples"][0]
    assert first["reduced_frequency"] == pytest.approx(0.001)
    # at k → 0 the lift per unit pitch tends to the static slope dC_L/dθ = -dC_L/dα
    assert first["lift_per_pitch"][0] == pytest.approx(-payload["lift_slope_alpha"], rel=0.02)
    assert (tmp_path / "transfer_plate_Re2900_a0_coarse.png").is_file()
    # the samples are kept: a repeated (or interrupted) run factorises only for the static slopes
    again = CliRunner().invoke(app, [*args, "--reduced-frequency-range", "0.001", "0.5"])
    assert again.exit_code == 0, again.output
    repeated = json.loads(again.stdout)
    assert repeated["factorisations"] == 1
    assert repeated["samples"] == payload["samples"]
    bad = CliRunner().invoke(app, [*args, "--reduced-frequency-range", "0.5", "0.1"])
    assert bad.exit_code == 2
    assert "reduced-frequency range" in bad.stderr


def test_a_diverged_newton_on_det_t_is_a_convergence_error_not_an_overflow(monkeypatch, plate_operators):
    """A Newton iteration on det T that diverged may end at log U* = 1e4 (U* not a float): the
    failure is reported as the ConvergenceError the sweep handles (an unresolved crossing), not an
    OverflowError from reading the point."""
    import fsistab.transfer as transfer
    from fsistab.continuation import NewtonResult
    from fsistab.errors import ConvergenceError

    diverged = NewtonResult(np.array([0.2, 1e4, math.log(10.0)]), False, 12, (), None, "step grew")
    monkeypatch.setattr(transfer, "newton", lambda *args, **kwargs: diverged)
    with pytest.raises(ConvergenceError, match="did not converge"):
        transfer.transfer_flutter_point(plate_operators, Solid(10.0, 2.0), 0.2)
