"""The nonlinear time march (fsistab.simulation, docs/model.md §12) against the linear spectrum.

A small multiple of an eigenmode added to the steady state grows like ``e^{σt}``: the growth rate
and frequency fitted to the marched lift (or heave) must be the eigenvalue ``σ`` that shift-invert
Arnoldi finds on the same mesh — the two paths share the discrete operators only (the march
evaluates the nonlinear residual, the spectrum factorises its Jacobian). For the time-discrete
march the fitted value is BDF2's image of ``σ`` (the root ``g`` of
``(3/2 − σΔt) g² − 2g + 1/2 = 0``, ``σ_Δt = log(g)/Δt``), which it must match to the
nonlinearity's and the chord tolerance's size, and ``σ`` to the scheme's second order in Δt.
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from fsistab.bodies import Cylinder
from fsistab.coupled import CoupledSystem
from fsistab.eigen import eigenpairs_near
from fsistab.errors import InputError
from fsistab.forces import aerodynamic_coefficients
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Case, Flow, SimulationSettings, solid_for
from fsistab.simulation import (
    InertialFluidResidual,
    MarchState,
    TimeStepper,
    damped_oscillation,
    last_cycles,
    march,
    mean_over,
    perturbed_state,
)
from fsistab.steady import solve_steady

SHIFT = 0.05 + 0.75j  # near the cylinder's wake mode at Re 60 (ω ≈ 0.75 in U/D)


@pytest.fixture(scope="module")
def cylinder_60():
    """The fluid operators of the cylinder at Re 60 on the coarse mesh."""
    return fluid_operators(solve_steady(mesh_spec(Cylinder(), "coarse", 60), Flow(60)))


def _bdf2_image(sigma: complex, dt: float) -> complex:
    """``σ_Δt``: the growth per step of BDF2 applied to ``q' = σ q`` (its principal root)."""
    roots = np.roots([1.5 - sigma * dt, -2.0, 0.5])
    return complex(np.log(roots[np.argmax(np.abs(roots))]) / dt)


def _march(system, pair, dt: float, steps: int) -> list:
    """``steps`` steps from the steady state plus 1e-4 of ``pair``'s mode: the samples."""
    stepper = TimeStepper(system, dt)
    state = MarchState(0.0, 0, perturbed_state(stepper, pair.vector, 1e-4))
    samples = [sample for _, sample in march(stepper, state, steps * dt)]
    assert all(s.iterations <= 3 for s in samples)
    return samples


def _fit(samples, signal) -> complex:
    """``σ`` of ``signal`` from the third step on: the BDF1 start's parasitic root has decayed
    (``|g| = 1/3`` per step)."""
    kept = samples[2:]
    return damped_oscillation([s.time for s in kept], [signal(s) for s in kept])


def _fitted(system, pair, dt: float, steps: int, signal) -> complex:
    return _fit(_march(system, pair, dt, steps), signal)


def test_a_start_scaled_on_the_heave_releases_the_body_in_the_mode_s_solid_state(cylinder_60):
    """``--perturbation-of heave``: the body released at heave ε in the mode's solid state (the
    ratio ḣ/h of the mode's real parts kept), the fluid at its steady state; ``largest`` scales the
    whole mode's largest entry to ε; a solid without the named dof is refused."""
    system = CoupledSystem(cylinder_60, solid_for("cylinder", mass_ratio=10, reduced_velocity=5))
    pair = min(eigenpairs_near(system, [0.1 + 0.75j], 2), key=lambda p: abs(p.value - 0.1 - 0.75j))
    stepper = TimeStepper(system, 0.1)
    q0 = stepper.steady_point()
    names = system.state_labels()
    h, hdot, eps = names.index("h"), names.index("hdot"), 0.05
    start = perturbed_state(stepper, pair.vector, eps, "heave") - q0
    assert start[h] == pytest.approx(eps, rel=1e-12)
    assert start[hdot] == pytest.approx(eps * (pair.vector[hdot] / pair.vector[h]).real, rel=1e-9)
    assert not np.any(start[len(names) :])
    largest = perturbed_state(stepper, pair.vector, eps) - q0
    assert np.max(np.abs(largest)) == pytest.approx(eps, rel=1e-12)
    assert abs(largest[h]) < 1e-2 * eps  # the wake mode's heave is a small part of it
    with pytest.raises(InputError, match="pitch is not a degree of freedom"):
        perturbed_state(stepper, pair.vector, eps, "pitch")


def test_a_step_failing_on_the_steady_matrix_is_retried_on_one_rebuilt_at_its_start(cylinder_60):
    """A start far from the steady state (the wake mode at amplitude one) needs more chord
    iterations on the steady state's matrix than allowed; the step is tried once more on the matrix
    rebuilt at its start, converges there, and to the state the unrestricted iteration reaches (the
    residual is the same: only the iteration matrix changed)."""
    from fsistab.errors import ConvergenceError

    system = CoupledSystem(cylinder_60, solid_for("cylinder", mass_ratio=10, reduced_velocity=5))
    pair = min(eigenpairs_near(system, [0.05 + 0.75j], 2), key=lambda p: abs(p.value - 0.05 - 0.75j))
    stepper = TimeStepper(system, 0.2, max_iterations=7)
    start = MarchState(0.0, 0, perturbed_state(stepper, pair.vector, 1.0))
    with pytest.raises(ConvergenceError):
        TimeStepper(system, 0.2, max_iterations=7)._converge(start)
    new, sample = stepper.step(start)
    assert stepper.refreshes == 1 and sample.iterations <= 7
    reference, _ = TimeStepper(system, 0.2, max_iterations=100).step(start)
    assert np.max(np.abs(new.current - reference.current)) < 1e-8


def test_a_diverging_step_is_retried_on_the_rebuilt_matrix_then_refused_in_one_line(cylinder_60):
    """A chord iteration whose update turns non-finite (diverged) fails like one that does not
    converge: retried once on the matrix rebuilt at the step's start, then a ConvergenceError with
    the advice, never a LinAlgError from the mixing's least squares."""
    from fsistab.errors import ConvergenceError

    system = CoupledSystem(cylinder_60, solid_for("cylinder", mass_ratio=10, reduced_velocity=5))
    stepper = TimeStepper(system, 0.1)
    start = MarchState(0.0, 0, stepper.steady_point())
    equations = stepper._equations

    def diverging(order, current, previous):
        residual = equations(order, current, previous)
        return lambda q: np.full_like(residual(q), np.nan)

    stepper._equations = diverging
    with pytest.raises(ConvergenceError, match="diverged .* at iteration 1.*reduce --time-step"):
        stepper.step(start)
    assert stepper.refreshes == 1
    stepper._equations = equations
    new, sample = stepper.step(start)  # the same stepper marches on once the residual is finite
    assert sample.iterations <= 2 and np.all(np.isfinite(new.current))


def test_a_non_finite_rebuilt_matrix_is_refused_as_such(cylinder_60):
    """A residual whose linearisation is not finite somewhere (as the far-field layer's was, in
    NGSolve's automatic differentiation) is refused when the matrix is rebuilt, in words that say
    so, not later as a "singular" factorisation."""
    from fsistab.errors import ConvergenceError

    system = CoupledSystem(cylinder_60, solid_for("cylinder", mass_ratio=10, reduced_velocity=5))
    stepper = TimeStepper(system, 0.1)
    linearisation = stepper.fluid.linearisation

    def poisoned(q_solid, values):
        matrix = linearisation(q_solid, values)
        matrix.data[0] = np.nan
        return matrix

    stepper.fluid.linearisation = poisoned
    with pytest.raises(ConvergenceError, match="rebuilt about the current state is not finite"):
        stepper.refresh(stepper.steady_point())
    assert stepper.refreshes == 0


def test_growth_of_the_wake_mode_is_its_eigenvalue_at_second_order(cylinder_60):
    system = CoupledSystem(cylinder_60, solid_for("cylinder", dofs=()))
    pair = min(eigenpairs_near(system, [SHIFT], 4), key=lambda p: abs(p.value - SHIFT))
    sigma = pair.value
    assert sigma.real > 0  # the wake is unstable at Re 60
    errors = []
    for dt, steps in ((0.1, 16), (0.05, 32)):
        fit = _fitted(system, pair, dt, steps, lambda s: s.lift)
        assert abs(fit - _bdf2_image(sigma, dt)) < 1e-5 * abs(sigma)
        errors.append(abs(fit.real - sigma.real) / sigma.real)
        assert abs(fit.imag - sigma.imag) < 0.01 * sigma.imag
    assert errors[1] < 0.01  # growth rate within 1 % at Δt = 0.05
    assert 3.0 < errors[0] / errors[1] < 5.0  # second order in Δt


def test_spring_mounted_cylinder_at_mass_ratio_one_follows_its_coupled_mode(cylinder_60):
    """Monolithic coupling: at m = 1 (added mass comparable with the body's) the heave follows the
    coupled eigenvalue, the solid rows and the loads' inertia included."""
    system = CoupledSystem(cylinder_60, solid_for("cylinder", 1.0, 5.0, dofs=("heave",)))
    pair = max(eigenpairs_near(system, [SHIFT], 4), key=lambda p: p.growth_rate)
    assert abs(pair.solid[0]) > 0  # the mode moves the body
    dt = 0.05
    fit = _fitted(system, pair, dt, 24, lambda s: s.solid[0])
    assert abs(fit - _bdf2_image(pair.value, dt)) < 1e-5 * abs(pair.value)
    assert abs(fit.real - pair.value.real) < 0.01 * abs(pair.value.real)


def test_the_steady_state_stays_steady_with_its_drag(cylinder_60):
    system = CoupledSystem(cylinder_60, solid_for("cylinder", 20.0, 5.0, dofs=("heave",)))
    stepper = TimeStepper(system, 0.1)
    state = MarchState(0.0, 0, stepper.steady_point())
    samples = [stepper.initial_sample(state)] + [s for _, s in march(stepper, state, 0.3)]
    steady = aerodynamic_coefficients(cylinder_60.steady)
    for sample in samples:
        assert sample.drag == pytest.approx(steady.drag, abs=1e-7)
        assert abs(sample.lift - steady.lift) < 1e-7 and abs(sample.solid[0]) < 1e-8


def test_damped_oscillation_refuses_uneven_samples():
    with pytest.raises(ValueError, match="equal time steps"):
        damped_oscillation([0, 1, 2, 4, 5, 6, 7], np.zeros(7))


@pytest.mark.slow
def test_an_interrupted_march_resumes_where_it_stopped(tmp_path, cache_dir):
    """Interrupted after its third step (the snapshot callback raises), the march saves its state;
    rerun, it resumes from there, and its time series equals an uninterrupted run's."""
    from fsistab.store import read_dataset
    from fsistab.workflows import simulate

    case = Case.create("cylinder", 60, preset="coarse")
    solid = solid_for("cylinder", dofs=())
    settings = SimulationSettings(0.5, 0.1, 1e-4, SHIFT, checkpoint_every=100, snapshot_interval=0.1)

    def interrupt(index, time, steady, state):
        if index == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        simulate(case, solid, settings, cache_dir, tmp_path / "a", snapshot=interrupt)
    resumed = simulate(case, solid, settings, cache_dir, tmp_path / "a").dataset
    assert resumed.attrs["steps_this_run"] == 2 and resumed.attrs["steps"] == 5
    # a new march from the saved state starts where the first one stopped
    again = SimulationSettings(0.1, 0.1, start=resumed.attrs["checkpoint"])
    restarted = simulate(case, solid, again, cache_dir, tmp_path / "c").dataset
    saved = read_dataset(resumed.attrs["checkpoint"])["current_state"].values
    assert np.array_equal(read_dataset(restarted.attrs["checkpoint"])["previous_state"].values, saved)
    Path(resumed.attrs["checkpoint"]).unlink()  # the same march again, from its start
    whole = simulate(case, solid, settings, cache_dir, tmp_path / "b").dataset
    assert whole.attrs["steps_this_run"] == 5
    np.testing.assert_allclose(resumed.lift_coefficient, whole.lift_coefficient, rtol=0, atol=1e-12)
    written = read_dataset(resumed.attrs["netcdf"])
    assert written.time.size == 6 and written.lift_coefficient.attrs["units"] == "1"
    assert math.isclose(written.attrs["start_frequency"], whole.attrs["start_frequency"])


def test_last_cycles_of_a_growing_then_saturated_sinusoid():
    t = np.arange(0.0, 200.0, 0.05)
    omega, amplitude = 1.03, 0.33
    envelope = amplitude * np.tanh(np.exp(0.1 * (t - 60.0)))  # grows, then saturates
    cycle = last_cycles(t, 0.2 + envelope * np.sin(omega * t), periods=8)
    assert cycle.periods == 8
    assert cycle.frequency == pytest.approx(omega, rel=1e-4)
    assert cycle.mean == pytest.approx(0.2, abs=1e-3)
    assert cycle.amplitude == pytest.approx(amplitude, rel=1e-3)
    assert mean_over(t, np.cos(omega * t) ** 2, cycle.start, cycle.end) == pytest.approx(0.5, rel=1e-3)


def test_plate_flutter_mode_grows_at_its_eigenvalue(plate_operators):
    """The plate at Re 2900, m = 1000, U* = 5 (just past flutter on the coarse mesh): heave and pitch
    follow the flutter mode's small growth rate, the pitch's rotation terms and lifting included."""
    from fsistab.params import Solid

    system = CoupledSystem(plate_operators, Solid(mass_ratio=1000.0, reduced_velocity=5.0))
    pair = max(eigenpairs_near(system, [0.01 + 0.17j], 4), key=lambda p: p.solid_energy_fraction)
    assert pair.label != "fluid" and pair.growth_rate > 0  # the flutter mode, unstable
    dt = 0.1
    samples = _march(system, pair, dt, 20)
    for signal in (lambda s: s.solid[1], lambda s: s.solid[0]):  # pitch, heave
        fit = _fit(samples, signal)
        assert abs(fit - _bdf2_image(pair.value, dt)) < 1e-5 * abs(pair.value)
        assert abs(fit.real - pair.growth_rate) < 0.01 * pair.growth_rate


def test_simulate_command_json_and_bad_input(tmp_path):
    """The command's one JSON object names the time series, whose variables carry units; a bad
    option is one line before any work."""
    from typer.testing import CliRunner

    from fsistab.cli import app
    from fsistab.store import read_dataset

    runner = CliRunner()
    where = ["--out", str(tmp_path / "out"), "--cache", str(tmp_path / "cache")]
    result = runner.invoke(app, ["simulate", "--time-step", "0", *where])
    assert result.exit_code == 2 and "--time-step must be positive" in result.output
    args = ["simulate", "--body", "cylinder", "--Re", "40", "--mesh", "coarse", "--mass-ratio", "5"]
    args += ["--duration", "0.2", "--time-step", "0.1", "--perturbation", "0", "--json", *where]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert payload["steps"] == 2 and payload["start_eigenvalue"] is None and payload["factorisations"] == 2
    ds = read_dataset(payload["data"])
    for name in ("heave", "pitch", "heave_rate", "pitch_rate", "lift_coefficient", "drag_coefficient"):
        assert ds[name].sizes["time"] == 3 and "units" in ds[name].attrs
    assert ds.heave.attrs["units"] == "1" and ds.pitch.attrs["units"] == "rad"
    assert abs(payload["last"]["heave"]) < 1e-8  # the steady state stays


def test_the_matrix_is_rebuilt_when_the_next_step_would_cost_more_than_the_average_since_the_last():
    """The renewal rule of :func:`rebuild_due`, on counts of the plate's cycle: a matrix that ages
    fast (12 → 57 iterations over four steps) is rebuilt after its second step, when the third,
    predicted at 23, costs more than the 21 per step spent so far with the rebuild's 11; a steady
    count never is; a count creeping up is, once it passes the falling average; a free rebuild
    follows the first step on a matrix, not a step that was cheaper than the one before."""
    from fsistab.simulation import rebuild_due

    assert not rebuild_due([13], 11.0)
    assert rebuild_due([13, 18], 11.0)  # 18 + 5 = 23 ≥ (11 + 31)/2 = 21
    assert not rebuild_due([13, 16], 11.0)  # 19 < 20
    assert not any(rebuild_due([6] * k, 11.0) for k in range(1, 200))
    creeping = [5, 5, 5, 5, 6, 6, 7, 8]
    due = [rebuild_due(creeping[: k + 1], 11.0) for k in range(len(creeping))]
    assert due == [False] * 6 + [True, True]  # 8 ≥ (11 + 39)/7 = 7.1 at the seventh step
    assert rebuild_due([3], 0.0) and rebuild_due([9, 4], 0.0) is False


def test_rebuilding_the_iteration_matrix_changes_iterations_not_states(cylinder_60):
    """Relinearised about the current field after every step, the march reaches the same states:
    only the chord iteration's matrix changes, never the equations."""
    system = CoupledSystem(cylinder_60, solid_for("cylinder", 1.0, 5.0, dofs=("heave",)))
    start = TimeStepper(system, 0.1).steady_point()
    start[0] = 0.05  # a heave displaced far from the steady state: a nonlinear start
    results = []
    for refresh_after in (0, 1):
        stepper = TimeStepper(system, 0.1, refresh_after=refresh_after, rebuild_cost=0.0)
        samples = [s for _, s in march(stepper, MarchState(0.0, 0, start.copy()), 0.3)]
        results.append(np.array([[s.solid[0], s.lift, s.drag] for s in samples]))
        assert stepper.refreshes == (0 if refresh_after == 0 else 3)
    np.testing.assert_allclose(results[1], results[0], rtol=0, atol=1e-8)


def test_the_rebuilt_fluid_block_is_the_residual_s_derivative_about_a_moving_state(plate_operators):
    """The iteration matrix's rebuilt ``J_ff`` (:meth:`FluidResidual.linearisation` of the march's
    compiled form) against a central difference of the nonlinear residual (quadratic in the fluid
    state: exact to round-off) at a pitching, heaving state off the steady flow; the steady
    state's ``J_ff``, without the grid velocity's and the rotation's part, misses it there by far
    more."""
    from fsistab.params import Solid

    system = CoupledSystem(plate_operators, Solid(mass_ratio=1000.0, reduced_velocity=5.0))
    stepper = TimeStepper(system, 0.05)
    residual = stepper.fluid
    residual.set_rate(0.0, np.zeros(residual.mass.shape[0]))  # R_f alone, no inertia
    rng = np.random.default_rng(7)
    q_solid, fluid0 = np.array([0.1, 0.12, 0.05, 0.03]), stepper.steady_point()[system.n_solid :]
    q_fluid = fluid0 + 1e-2 * rng.standard_normal(fluid0.size)
    direction, eps = rng.standard_normal(fluid0.size), 1e-4
    index = plate_operators.free_dofs
    jff = residual.linearisation(q_solid, residual.full_state(q_solid, q_fluid))[index][:, index]
    plus, _ = residual(q_solid, q_fluid + eps * direction)
    minus, _ = residual(q_solid, q_fluid - eps * direction)
    difference = (plus - minus) / (2 * eps)
    scale = np.max(np.abs(difference))
    assert np.max(np.abs(jff @ direction - difference)) < 1e-8 * scale
    assert np.max(np.abs(plate_operators.jff @ direction - difference)) > 1e-2 * scale


def test_the_march_s_residual_is_the_terms_form_at_moving_states(plate_2900):
    """The march evaluates the residual from its affine parts and the convection alone
    (:func:`fsistab.simulation.affine_parts`); against the terms' whole form
    (:class:`fsistab.operators.FluidResidual`) at pitching, heaving and rotating states off the
    steady flow (plate with its outlet sponge, whose target turns with the body): the residual,
    the loads and the linearisation agree to round-off. A term with another nonlinearity, or
    weights of the motion other than the grid velocity's, would fail here."""
    from fsistab.operators import FluidResidual

    march, form = InertialFluidResidual(plate_2900), FluidResidual(plate_2900)
    march.set_rate(0.0, np.zeros(march.mass.shape[0]))  # R_f alone, no inertia
    rng = np.random.default_rng(3)
    _, fluid0 = form.steady_point()
    for q_solid in ([0.0, 0.0, 0.0, 0.0], [0.1, 0.14, 0.05, 0.02], [0.3, -0.3, -0.2, 0.1]):
        q_solid = np.array(q_solid)
        q_fluid = fluid0 + 1e-2 * rng.standard_normal(fluid0.size)
        (found, found_loads), (expected, loads) = march(q_solid, q_fluid), form(q_solid, q_fluid)
        assert np.abs(found - expected).max() < 1e-13 * np.abs(expected).max()
        assert np.abs(found_loads - loads).max() < 1e-13 * np.abs(loads).max()
        values = form.full_state(q_solid, q_fluid)
        found = march.linearisation(q_solid, values)
        difference = found - FluidResidual.linearisation(form, q_solid, values)
        assert abs(difference).max() < 1e-13 * abs(found).max()


def test_a_released_start_takes_the_body_s_mode_when_a_fluid_mode_is_nearer(plate_operators):
    """At U* = 5.4 (coarse plate, Re 2900, m = 1000) a far-field mode, in which the plate is
    still, lies nearer the shift 0.01 + 0.18i than the flutter mode, whose frequency has fallen
    with U*: the perturbed start keeps the nearest mode, a released one (--perturbation-of pitch)
    the body's."""
    from fsistab.bodies import Plate
    from fsistab.params import Solid
    from fsistab.workflows import _start_mode

    system = CoupledSystem(plate_operators, Solid(mass_ratio=1000.0, reduced_velocity=5.4))
    case, shift = Case(Plate(), Flow(2900.0), preset="coarse"), 0.01 + 0.18j
    nearest = _start_mode(system, SimulationSettings(100.0, shift=shift), case, lambda message: None)
    released = SimulationSettings(100.0, perturbation=0.1, shift=shift, perturbation_of="pitch")
    body = _start_mode(system, released, case, lambda message: None)
    assert nearest.solid_energy_fraction < 1e-12  # a far-field mode: the plate does not move
    assert body.label != "fluid" and body.growth_rate > 0  # the flutter mode, past its threshold
    assert abs(body.value - shift) > abs(nearest.value - shift)
    # at U* = 5.8 the flutter mode (ω ≈ 0.14) is not among the six nearest: one line, no march
    system = CoupledSystem(plate_operators, Solid(mass_ratio=1000.0, reduced_velocity=5.8))
    pair = _start_mode(system, released, case, lambda message: None)
    assert pair.label == "fluid"
    stepper = TimeStepper(system, 0.05)
    with pytest.raises(InputError, match="no pitch component .* give a --shift nearer the body's mode"):
        perturbed_state(stepper, pair.vector, 0.1, "pitch")


@pytest.fixture(scope="module")
def cylinder_60_coarser_wake():
    """The cylinder at Re 60 on a second mesh: ``coarse`` with wake elements of 0.5 instead of 0.35."""
    return solve_steady(mesh_spec(Cylinder(), "coarse", 60, wake=0.5), Flow(60))


def _heaving_stepper(steady) -> TimeStepper:
    system = CoupledSystem(fluid_operators(steady), solid_for("cylinder", 10.0, 5.0, dofs=("heave",)))
    return TimeStepper(system, 0.1)


def _coupled_state(stepper: TimeStepper, velocity, pressure, solid=(0.02, -0.3)) -> np.ndarray:
    """A coupled state whose fluid unknowns are the fields ``velocity``, ``pressure`` interpolated
    on the stepper's mesh, its solid state (h, ḣ) ``solid``."""
    from ngsolve import GridFunction

    field = GridFunction(stepper.fluid.steady.space)
    field.components[0].Set(velocity)
    field.components[1].Set(pressure)
    return np.concatenate([solid, field.vec.FV().NumPy()[stepper.fluid.index]])


def test_a_state_carried_to_another_mesh_keeps_the_fields_that_both_represent(
    cylinder_60, cylinder_60_coarser_wake
):
    """docs/model.md §12, Start: a linear velocity and pressure field lies in the P2 and P1 spaces
    of both meshes, so away from the walls (whose values the solid state sets through the lifting)
    and the inlet and sides (held at zero) the carried field equals it to round-off; the solid state
    is kept exactly. Carried to its own mesh, a state comes back unchanged."""
    from ngsolve import CF, GridFunction, x, y

    from fsistab.simulation import transferred_state

    source, target = _heaving_stepper(cylinder_60.steady), _heaving_stepper(cylinder_60_coarser_wake)
    velocity, pressure = CF((0.1 + 0.01 * x - 0.02 * y, 0.03 * x + 0.005 * y)), 0.2 - 0.01 * x + 0.04 * y
    q = _coupled_state(source, velocity, pressure)
    carried = transferred_state(cylinder_60.steady, q, target)
    assert carried.size == target.system.size and carried.size != q.size
    assert np.array_equal(carried[:2], q[:2])
    field = GridFunction(target.fluid.steady.space)
    field.vec.FV().NumPy()[:] = target.fluid.full_state(target.solid_state(carried), carried[2:])
    angles = np.linspace(0.0, 2.0 * np.pi, 24, endpoint=False)
    for radius in (3.0, 8.0, 20.0):
        for angle in angles:
            px, py = radius * np.cos(angle), radius * np.sin(angle)
            point = target.fluid.steady.mesh(px, py)
            expected = (0.1 + 0.01 * px - 0.02 * py, 0.03 * px + 0.005 * py)
            assert np.allclose(field.components[0](point), expected, rtol=0, atol=1e-10)
            assert abs(field.components[1](point) - (0.2 - 0.01 * px + 0.04 * py)) < 1e-10
    np.testing.assert_allclose(transferred_state(cylinder_60.steady, q, source), q, rtol=0, atol=1e-12)
    with pytest.raises(InputError, match="unknowns"):
        transferred_state(cylinder_60.steady, q[:-1], target)


def test_a_march_starts_from_a_checkpoint_of_another_mesh(tmp_path, cache_dir):
    """``--start`` with a checkpoint marched on another mesh of the same body and flow: its state
    is carried over (the solid state exactly) and marched; refused, in one line before any work,
    when the checkpoint's mesh is not described in its cache or does not cover this domain."""
    import shutil

    from fsistab.workflows import simulate

    solid = solid_for("cylinder", 10.0, 5.0, dofs=("heave",))
    first = SimulationSettings(0.2, 0.1, 0.01, SHIFT, perturbation_of="heave")
    source = Case.create("cylinder", 60, preset="coarse")
    marched = simulate(source, solid, first, cache_dir, tmp_path / "a").dataset
    checkpoint = marched.attrs["checkpoint"]
    target = Case.create("cylinder", 60, preset="coarse", mesh_sizes="wake=0.5")
    series = simulate(
        target, solid, SimulationSettings(0.2, 0.1, start=checkpoint), cache_dir, tmp_path / "b"
    ).dataset
    assert series.attrs["ndof"] < marched.attrs["ndof"] and series.attrs["steps"] == 2
    for name in ("heave", "heave_rate"):
        assert series[name].values[0] == marched[name].values[-1] != 0
    moved = tmp_path / "elsewhere" / "simulations" / "start.nc"
    moved.parent.mkdir(parents=True)
    shutil.copy(checkpoint, moved)
    elsewhere = SimulationSettings(0.2, 0.1, start=str(moved))
    with pytest.raises(InputError, match="steady state is not in its cache"):
        simulate(target, solid, elsewhere, tmp_path / "none", tmp_path / "c")
    small = Case.create("cylinder", 60, preset="coarse", domain=(20.0, 40.0, 20.0), mesh_sizes="wake=0.5")
    inside = simulate(small, solid, SimulationSettings(0.1, 0.1, start=checkpoint), cache_dir, tmp_path / "d")
    assert inside.dataset.attrs["steps"] == 1
    start = SimulationSettings(0.1, 0.1, start=inside.dataset.attrs["checkpoint"])
    with pytest.raises(InputError, match="does not cover"):
        simulate(target, solid, start, tmp_path / "none", tmp_path / "e")
