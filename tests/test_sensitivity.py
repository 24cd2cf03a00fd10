"""Adjoint modes and sensitivities (fsistab.sensitivity; docs/model.md §5–§8, docs/reference/sensitivity.md).

Every derivative is checked against a central finite difference of the quantity itself (an
eigenvalue recomputed by Arnoldi, a threshold re-converged by the neutral-point Newton), on
coarse meshes: the plate at Re = 2900, α0 = 2° (at α0 = 0 every α0 derivative vanishes by symmetry;
at 5° the heave mode is unstable at every U* on this mesh: no flutter threshold) and the fixed
cylinder at Re = 50 (the fixed-cylinder references of docs/validation.md).
"""

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fsistab import umfpack
from fsistab.bodies import Cylinder
from fsistab.coupled import CoupledSystem
from fsistab.critical import divergence_point, flutter_point
from fsistab.eigen import eigenpairs_near
from fsistab.errors import ConvergenceError, InputError
from fsistab.forces import recirculation_length
from fsistab.linalg import FactorCounter, FluidFactor
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Solid
from fsistab.plots import plot_sensitivity_maps
from fsistab.sensitivity import (
    CONTROL_DIAMETER,
    PARAMETERS,
    AdjointSolver,
    adjoint_mode,
    adjoint_modes,
    biorthogonality,
    control_cylinder_operators,
    eigenvalue_derivatives,
    energy_centroid,
    flow_tangent,
    force_sensitivity,
    force_vector,
    forced_steady,
    gaussian_force,
    maps_at,
    maps_dataset,
    sensitivity_maps,
    structural_sensitivity,
    threshold_derivatives,
    threshold_sensitivities,
    threshold_sensitivity,
)
from fsistab.steady import SteadyProblem, solve_steady
from fsistab.vtk import write_maps_vtk

pytestmark = pytest.mark.skipif(not umfpack.available(), reason="NGSolve's wheel exports no UMFPACK")

ALPHA0 = 2.0
SOLID = Solid(mass_ratio=1000, reduced_velocity=4.4, zeta_h=0.001)  # ζ_h > 0: a two-sided difference
# finite-difference steps: the steady state is strongly nonlinear in α0 on this mesh (at α0 = 5° the
# error of a central difference of dq⁰/dα0 is 5e-4 at 0.01°, 1.3e-4 at 0.005°: O(h²)), hence small
# steps; solid parameters: 1e-4 max(p, 0.05)
FD_STEPS = {"reynolds": 0.2, "alpha0": 1e-3}
RELATIVE = 1e-4


def _relative_error(difference, derivative) -> float:
    return float(abs(difference - derivative) / abs(derivative))


def _polished(steady, flow):
    """The steady state at ``flow`` by Newton from ``steady`` to a residual of 1e-12 (the cached
    tolerance, 1e-9, would leave errors of the size of the differences measured here)."""
    from ngsolve import GridFunction

    state = GridFunction(steady.space)
    state.vec.data = steady.state.vec
    SteadyProblem.on(steady.mesh, steady.space).newton(state, flow, tol=1e-12)
    return replace(steady, flow=flow, state=state)


@pytest.fixture(scope="module")
def plate_alpha(plate_2900):
    steady = solve_steady(plate_2900.mesh_spec, Flow(2900, ALPHA0), initial=plate_2900)
    return _polished(steady, Flow(2900, ALPHA0))


@pytest.fixture(scope="module")
def operators_alpha(plate_alpha):
    return fluid_operators(plate_alpha)


@pytest.fixture(scope="module")
def flow_operators(plate_alpha):
    """Operators at Re ± δ and α0 ± δ (new steady states), shared by the eigenvalue and the
    threshold differences."""
    out = {}
    for parameter, step in FD_STEPS.items():
        for sign in (1, -1):
            if parameter == "reynolds":
                flow = Flow(2900 + sign * step, ALPHA0)
            else:
                flow = Flow(2900, ALPHA0 + sign * step)
            out[parameter, sign] = fluid_operators(_polished(plate_alpha, flow))
    return out


@pytest.fixture(scope="module")
def heave_mode(operators_alpha):
    system = CoupledSystem(operators_alpha, SOLID)
    pairs = eigenpairs_near(system, [0.003 + 0.18j], 4)
    return max((p for p in pairs if p.label != "fluid"), key=lambda p: p.growth_rate)


# --------------------------------------------------------------------------------------------
# adjoint solves


@pytest.mark.parametrize("complex_values", [False, True])
@pytest.mark.parametrize("refine", [False, True])
def test_transposed_umfpack_solve_equals_superlu(complex_values, refine):
    rng = np.random.default_rng(7)
    n = 300
    import scipy.sparse as sp

    a = sp.random(n, n, density=0.02, random_state=rng, format="csc")
    if complex_values:
        a = a + 1j * sp.random(n, n, density=0.02, random_state=rng, format="csc")
    a = (a + sp.diags(np.full(n, 3.0 + (0.5j if complex_values else 0.0)))).tocsc()
    b = rng.standard_normal(n) + 1j * rng.standard_normal(n)
    x = umfpack.LU(a).solve(b, refine, transpose=True)
    reference = np.linalg.solve(a.toarray().conj().T, b)
    assert np.linalg.norm(x - reference) < 1e-11 * np.linalg.norm(reference)
    assert np.linalg.norm(umfpack.LU(a).solve(b, refine) - reference) > 1e-3 * np.linalg.norm(reference)


def test_adjoint_solver_inverts_the_conjugate_transposed_coupled_matrix(operators_alpha):
    system = CoupledSystem(operators_alpha, SOLID)
    shift = 0.01 + 0.17j
    factor = FluidFactor(operators_alpha, shift)
    solver = AdjointSolver(system, shift, fluid_factor=factor)
    rng = np.random.default_rng(3)
    b = rng.standard_normal(system.size) + 1j * rng.standard_normal(system.size)
    x = solver.solve(b)
    matrix_h = (system.jacobian + shift * system.mass).conj().T
    assert np.linalg.norm(matrix_h @ x - b) < 1e-10 * np.linalg.norm(b)
    with pytest.raises(InputError, match="another shift"):
        AdjointSolver(system, 0.02 + 0.17j, fluid_factor=factor)


def test_adjoint_mode_reports_bad_input_and_failures(operators_alpha, heave_mode):
    system = CoupledSystem(operators_alpha, SOLID)
    with pytest.raises(InputError, match="shape"):
        adjoint_mode(system, heave_mode.value, heave_mode.vector[:-1])
    with pytest.raises(InputError, match="at least one step"):
        adjoint_mode(system, heave_mode.value, heave_mode.vector, maxit=0)
    # NGSolve's own UMFPACK (FluidFactor's other backend) has no transposed solve: said up front
    shift = complex(heave_mode.value)
    with pytest.raises(InputError, match="backend 'umfpack'"):
        AdjointSolver(system, shift, fluid_factor=FluidFactor(operators_alpha, shift, backend="ngsolve"))
    # one step from a shift 0.03 away does not reach the residual asked for
    solver = AdjointSolver(system, heave_mode.value + 0.03)
    with pytest.raises(ConvergenceError, match="did not converge by inverse iteration"):
        adjoint_mode(system, heave_mode.value, heave_mode.vector, solver=solver, maxit=1)


# --------------------------------------------------------------------------------------------
# adjoint modes of the fixed cylinder (the fixed-cylinder references of docs/validation.md; Giannetti &
# Luchini 2007)


@pytest.fixture(scope="module")
def cylinder_50():
    return solve_steady(mesh_spec(Cylinder(), "coarse", 50), Flow(50))


def test_cylinder_adjoint_modes_are_biorthogonal_and_upstream(cylinder_50):
    fluid = fluid_operators(cylinder_50)
    system = CoupledSystem(fluid, Solid(dofs=()))
    factors: dict = {}
    counter = FactorCounter()
    pairs = eigenpairs_near(system, [0.01 + 0.75j], 4, fluid_factors=factors, counter=counter)
    modes = adjoint_modes(system, pairs, fluid_factors=factors, counter=counter)
    lead = max(range(len(pairs)), key=lambda i: pairs[i].growth_rate)
    mode = modes[lead]
    assert mode.value == pytest.approx(
        0.013206 + 0.73761j, abs=2e-3
    )  # the fixed-cylinder references of docs/validation.md, Re = 50
    # the leading mode from the Arnoldi factorisation itself, by adjoint solves only
    assert mode.shift == 0.01 + 0.75j and mode.iterations < 20
    for m in modes:
        assert m.residual < 1e-9 and m.rayleigh_residual < 1e-10
        assert np.vdot(m.adjoint, system.mass @ m.direct) == pytest.approx(1.0, abs=1e-12)
    # without deflation the iteration from the shared shift drifts to the mode nearest to it: an
    # error (not converged, or converged to another eigenvalue), never another mode's adjoint
    other = min(
        (i for i in range(len(pairs)) if i != lead), key=lambda i: abs(pairs[i].value - pairs[i].shift)
    )
    shift = pairs[other].shift
    with pytest.raises(ConvergenceError, match="did not converge|found the eigenvalue"):
        adjoint_mode(
            system,
            pairs[other].value,
            pairs[other].vector,
            solver=AdjointSolver(system, shift, factors[shift]),
        )
    products = biorthogonality(system, modes)
    off_diagonal = products[~np.eye(len(modes), dtype=bool)]
    assert off_diagonal.max() < 1e-9
    # each cosine on the diagonal is 1/κ, κ the eigenvalue's condition number: the wake modes
    # are strongly non-normal (Chomaz 2005), κ ~ 1e3
    assert np.diag(products).min() > 1e3 * off_diagonal.max()

    # the direct mode lives in the far wake, the adjoint upstream of the body
    n = fluid.n_fluid
    direct_x, direct_y = energy_centroid(fluid, mode.direct[-n:])
    adjoint_x, adjoint_y = energy_centroid(fluid, mode.adjoint[-n:])
    assert direct_x > 5.0 and adjoint_x < -0.5
    assert abs(direct_y) < 1e-6 and abs(adjoint_y) < 1e-6  # symmetric energy

    # the wavemaker: the structural sensitivity peaks within the recirculation bubble's length,
    # near the axis, and is small upstream and in the far wake
    xs, ys = np.meshgrid(np.linspace(-4, 12, 321), np.linspace(-3, 3, 121))
    points = np.column_stack([xs.ravel(), ys.ravel()])
    points = points[np.hypot(points[:, 0], points[:, 1]) > 0.52]
    sensitivity = structural_sensitivity(fluid, mode, points)
    x_peak, y_peak = points[np.argmax(sensitivity)]
    bubble = recirculation_length(cylinder_50)
    assert 2.5 < bubble < 3.5  # the fixed-cylinder references of docs/validation.md: 2.9–3.0 D at Re = 50
    assert 0.5 < x_peak < 0.5 + bubble and abs(y_peak) < 1.0
    far = (points[:, 0] < -2) | (points[:, 0] > 0.5 + 2 * bubble)
    assert sensitivity[far].max() < 0.3 * sensitivity.max()


def test_cylinder_control_map_stabilises_beside_the_near_wake(cylinder_50):
    """Strykowski & Sreenivasan (1990, experiments) and Marquet, Sipp & Jacquin (2008, Fig. 10):
    a small control cylinder suppresses the wake mode when placed beside the near wake, about one
    diameter off the axis and behind the cylinder's centre (within the bubble's length); near the
    cylinder's shoulders it destabilises."""
    fluid = fluid_operators(cylinder_50)
    system = CoupledSystem(fluid, Solid(dofs=()))
    pair = max(eigenpairs_near(system, [0.01 + 0.75j], 3), key=lambda p: p.growth_rate)
    maps = sensitivity_maps(system, adjoint_mode(system, pair.value, pair.vector), "wake")
    xs, ys = np.meshgrid(np.linspace(-2, 6, 161), np.linspace(-2.5, 2.5, 101))
    points = np.column_stack([xs.ravel(), ys.ravel()])
    points = points[np.hypot(points[:, 0], points[:, 1]) > 0.5 + CONTROL_DIAMETER]
    growth = maps_at(maps, cylinder_50.mesh, points)["control"].real
    x_best, y_best = points[np.argmin(growth)]
    assert 0.0 < x_best < 3.0 and 0.5 < abs(y_best) < 1.5 and growth.min() < 0
    shoulder = maps_at(maps, cylinder_50.mesh, np.array([[0.0, 0.65], [0.0, -0.65]]))["control"].real
    assert (shoulder > 0).all() and shoulder.min() > 0.5 * growth.max()
    assert "d_reduced_velocity_control" not in maps_at(maps, cylinder_50.mesh, points[:1])  # no threshold


# --------------------------------------------------------------------------------------------
# eigenvalue derivatives (S1) against differences of eigenvalues


def _eigenvalue_near(fluid, solid, value):
    pairs = eigenpairs_near(CoupledSystem(fluid, solid), [value], 3)
    return min(pairs, key=lambda p: abs(p.value - value)).value


def test_eigenvalue_derivatives_match_finite_differences(operators_alpha, flow_operators, heave_mode):
    system = CoupledSystem(operators_alpha, SOLID)
    mode = adjoint_mode(system, heave_mode.value, heave_mode.vector)
    assert mode.iterations <= 2 and mode.residual < 1e-10
    derivatives = eigenvalue_derivatives(system, mode)
    assert tuple(derivatives) == PARAMETERS
    errors = {}
    for parameter, derivative in derivatives.items():
        if parameter in FD_STEPS:
            step = FD_STEPS[parameter]
            values = [_eigenvalue_near(flow_operators[parameter, s], SOLID, mode.value) for s in (1, -1)]
        else:
            value = getattr(SOLID, parameter)
            step = 1e-4 * max(value, 0.05)
            values = [
                _eigenvalue_near(operators_alpha, replace(SOLID, **{parameter: value + s * step}), mode.value)
                for s in (1, -1)
            ]
        difference = (values[0] - values[1]) / (2 * step)
        errors[parameter] = _relative_error(difference, derivative)
    assert max(errors.values()) < RELATIVE, errors


def test_a_change_that_leaves_the_eigenvalue_is_not_reported(operators_alpha, flow_operators, heave_mode):
    """ζ_θ moves the solid row of θ' only: a heave-only system has no such row, so dσ/dζ_θ = 0,
    and r_θ enters through the pitch row alone."""
    solid = replace(SOLID, dofs=("heave",))
    system = CoupledSystem(operators_alpha, solid)
    pair = min(eigenpairs_near(system, [heave_mode.value], 3), key=lambda p: abs(p.value - heave_mode.value))
    mode = adjoint_mode(system, pair.value, pair.vector)
    derivatives = eigenvalue_derivatives(system, mode, ("zeta_theta", "r_theta", "zeta_h"))
    assert derivatives["zeta_theta"] == 0 and derivatives["r_theta"] == 0
    assert abs(derivatives["zeta_h"]) > 0.01
    with pytest.raises(InputError, match="unknown parameter"):
        eigenvalue_derivatives(system, mode, ("mass",))
    elsewhere = {"reynolds": flow_tangent(flow_operators["reynolds", 1], "reynolds")}
    with pytest.raises(InputError, match="reynolds were made at other operators"):
        eigenvalue_derivatives(system, mode, ("reynolds",), tangents=elsewhere)


# --------------------------------------------------------------------------------------------
# threshold derivatives (S3) against differences of thresholds


def test_threshold_derivatives_are_the_implicit_function_theorem():
    derivatives = {"reduced_velocity": 0.02 - 0.04j, "mass_ratio": -1e-6 + 5e-7j}
    velocity, frequency = threshold_derivatives(derivatives)
    # Re σ stays 0: 0.02 dU + (-1e-6) = 0
    assert velocity["mass_ratio"] == pytest.approx(5e-5, rel=1e-14)
    assert frequency["mass_ratio"] == pytest.approx(5e-7 - 0.04 * 5e-5, rel=1e-14)
    with pytest.raises(InputError, match="dσ/dU"):
        threshold_derivatives({"mass_ratio": 1j})


@pytest.fixture(scope="module")
def flutter(operators_alpha, heave_mode):
    """The flutter point of the heave mode: the crossing predicted by the adjoint,
    ``U*_c ≈ U* − λ/Re(dσ/dU*)``, then the neutral-point Newton from an eigenpair there."""
    system = CoupledSystem(operators_alpha, SOLID)
    mode = adjoint_mode(system, heave_mode.value, heave_mode.vector)
    slope = eigenvalue_derivatives(system, mode, ("reduced_velocity",))["reduced_velocity"]
    predicted = SOLID.reduced_velocity - heave_mode.growth_rate / slope.real
    guess = replace(SOLID, reduced_velocity=predicted)
    expected = heave_mode.value + slope * (predicted - SOLID.reduced_velocity)
    pair = min(
        eigenpairs_near(CoupledSystem(operators_alpha, guess), [expected], 4),
        key=lambda p: abs(p.value - expected),
    )
    point = flutter_point(operators_alpha, guess, pair.frequency, pair.vector)
    assert point.kind == "flutter" and abs(point.reduced_velocity - predicted) < 0.05 * predicted
    return point


@pytest.fixture(scope="module")
def flutter_differences(operators_alpha, flow_operators, flutter):
    """``(dU*_c/dp, dω_c/dp)`` by central differences of flutter points re-converged at p ± δ."""
    at_point = replace(SOLID, reduced_velocity=flutter.reduced_velocity)
    out = {}
    for parameter in PARAMETERS:
        if parameter == "reduced_velocity":
            continue
        values = []
        for sign in (1, -1):
            if parameter in FD_STEPS:
                step = FD_STEPS[parameter]
                fluid, solid = flow_operators[parameter, sign], at_point
            else:
                step = 1e-4 * max(getattr(SOLID, parameter), 0.05)
                fluid = operators_alpha
                solid = replace(at_point, **{parameter: getattr(SOLID, parameter) + sign * step})
            moved = flutter_point(fluid, solid, flutter.frequency, flutter.mode)
            values.append((moved.reduced_velocity, moved.frequency))
        out[parameter] = tuple((values[0][i] - values[1][i]) / (2 * step) for i in range(2))
    return out


def test_flutter_threshold_derivatives_match_finite_differences(
    operators_alpha, flutter, flutter_differences
):
    counter = FactorCounter()
    result = threshold_sensitivity(operators_alpha, SOLID, flutter, counter=counter)
    assert result.adjoint.residual < 1e-9 and result.adjoint.iterations <= 2
    # one factorisation at iω_c (adjoint), one of J_ff (steady tangents of Re and α0)
    assert counter.count == 2
    assert set(result.velocity) == set(flutter_differences)
    errors = {}
    for parameter, (d_velocity, d_frequency) in flutter_differences.items():
        errors[parameter] = _relative_error(d_velocity, result.velocity[parameter])
        errors[parameter, "frequency"] = _relative_error(d_frequency, result.frequency_derivative[parameter])
    assert max(errors.values()) < RELATIVE, errors


def test_threshold_sensitivities_dataset(operators_alpha, flutter, flutter_differences):
    """The API for ``fsistab sensitivity``: every threshold of a sweep in U* with its derivatives."""
    with pytest.raises(InputError, match="unknown parameter"):
        threshold_sensitivities(operators_alpha, SOLID, [4.2, 4.7], ("alpha",))
    velocities = np.array([4.2, 4.45, 4.7])
    ds = threshold_sensitivities(operators_alpha, SOLID, velocities)
    assert list(ds.parameter.values) == [p for p in PARAMETERS if p != "reduced_velocity"]
    assert ds.unit.sel(parameter="alpha0").item() == "degree"
    flutter_rows = np.flatnonzero(ds.kind.values == "flutter")
    assert len(flutter_rows) == 1
    row = ds.isel(threshold=flutter_rows[0])
    assert row.boundary.item() == "onset"
    assert row.reduced_velocity.item() == pytest.approx(flutter.reduced_velocity, rel=1e-8)
    errors = {
        p: _relative_error(d_velocity, row.d_reduced_velocity.sel(parameter=p).item())
        for p, (d_velocity, _) in flutter_differences.items()
    }
    assert max(errors.values()) < RELATIVE, errors
    assert row.adjoint_residual.item() < 1e-9


def test_divergence_threshold_derivatives_match_finite_differences(operators_alpha, flow_operators):
    """Divergence (ω = 0, real arithmetic): the factorisation at σ = 0 serves the adjoint and the
    steady tangents."""
    counter = FactorCounter()
    point = divergence_point(operators_alpha, replace(SOLID, reduced_velocity=7.0), counter=counter)
    parameters = ("reynolds", "alpha0", "mass_ratio", "r_theta")
    before = counter.count
    result = threshold_sensitivity(operators_alpha, SOLID, point, parameters, counter=counter)
    assert counter.count - before == 1  # J_ff at σ = 0, shared by the adjoint and both tangents
    assert result.frequency == 0 and result.adjoint.rayleigh_residual < 1e-10
    errors = {}
    for parameter in parameters:
        values = []
        for sign in (1, -1):
            if parameter in FD_STEPS:
                step = FD_STEPS[parameter]
                fluid, solid = flow_operators[parameter, sign], SOLID
            else:
                step = 1e-4 * max(getattr(SOLID, parameter), 0.05)
                fluid, solid = (
                    operators_alpha,
                    replace(SOLID, **{parameter: getattr(SOLID, parameter) + sign * step}),
                )
            start = replace(solid, reduced_velocity=0.99 * point.reduced_velocity)
            values.append(divergence_point(fluid, start).reduced_velocity)
        difference = (values[0] - values[1]) / (2 * step)
        errors[parameter] = _relative_error(difference, result.velocity[parameter])
        assert result.frequency_derivative[parameter] == 0.0  # a real eigenvalue stays real
    assert max(errors.values()) < RELATIVE, errors


# --------------------------------------------------------------------------------------------
# spatial maps: the sensitivity to a steady force against eigenvalues of forced steady states


def _forced_eigenvalue(steady, force, solid, value):
    forced = forced_steady(steady, force)
    assert forced.history[-1] < 1e-12
    return _eigenvalue_near(fluid_operators(forced), solid, value)


def _check_force_sensitivity(steady, system, mode, centres, step=1e-3):
    """``∫ δf·S_f`` (the adjoint, one transposed solve with J_ff) against a central difference of
    the eigenvalue of the steady states forced by ``±step δf``, a Gaussian of radius 0.1."""
    sensitivity = force_sensitivity(system, mode)
    errors = []
    for centre, direction in centres:
        force = force_vector(steady, gaussian_force(centre, 0.1, direction))
        predicted = sensitivity @ force
        values = [_forced_eigenvalue(steady, s * step * force, system.solid, mode.value) for s in (1, -1)]
        difference = (values[0] - values[1]) / (2 * step)
        assert abs(difference) > 1e-5  # the force moves the eigenvalue measurably
        errors.append(_relative_error(difference, predicted))
    return errors


def test_force_sensitivity_of_the_coupled_mode_matches_forced_steady_states(
    plate_alpha, operators_alpha, heave_mode
):
    """The coupled heave–pitch mode: the steady state moves the fluid block, the wall coupling
    and the loads on the solid rows (steady force rotated with the body included)."""
    system = CoupledSystem(operators_alpha, SOLID)
    mode = adjoint_mode(system, heave_mode.value, heave_mode.vector)
    # behind the trailing edge, and on the lower side across the flow
    centres = [((0.7, 0.1), (1.0, 0.0)), ((0.1, -0.15), (0.3, 1.0))]
    errors = _check_force_sensitivity(plate_alpha, system, mode, centres)
    assert max(errors) < 1e-5, errors  # measured 4e-7: the difference's O(step²) error


def test_force_sensitivity_of_the_cylinder_wake_mode(cylinder_50):
    """The fixed cylinder's wake mode at Re = 50 (no solid rows): a force in the recirculation
    region (Marquet, Sipp & Jacquin 2008: where a steady force stabilises the wake)."""
    fluid = fluid_operators(cylinder_50)
    system = CoupledSystem(fluid, Solid(dofs=()))
    pair = max(eigenpairs_near(system, [0.01 + 0.75j], 3), key=lambda p: p.growth_rate)
    mode = adjoint_mode(system, pair.value, pair.vector)
    errors = _check_force_sensitivity(cylinder_50, system, mode, [((1.5, 0.3), (1.0, 0.0))])
    assert max(errors) < 1e-5, errors


def test_force_sensitivity_of_the_divergence_threshold(plate_alpha, operators_alpha):
    """A threshold moved by a force (S4 then S3), in real arithmetic (σ = 0): ``δU*_D`` against
    divergence points re-converged on the forced steady states."""
    point = divergence_point(operators_alpha, replace(SOLID, reduced_velocity=7.0))
    result = threshold_sensitivity(operators_alpha, SOLID, point, ("mass_ratio",))
    system = CoupledSystem(operators_alpha, replace(SOLID, reduced_velocity=point.reduced_velocity))
    force = force_vector(plate_alpha, gaussian_force((-0.3, 0.2), 0.1, (0.0, 1.0)))
    predicted = (
        -(force_sensitivity(system, result.adjoint) @ force).real / result.eigenvalue["reduced_velocity"].real
    )
    step, values = 1e-3, []
    for sign in (1, -1):
        fluid = fluid_operators(forced_steady(plate_alpha, sign * step * force))
        start = replace(SOLID, reduced_velocity=0.99 * point.reduced_velocity)
        values.append(divergence_point(fluid, start).reduced_velocity)
    difference = (values[0] - values[1]) / (2 * step)
    assert abs(difference) > 1e-3 and _relative_error(difference, predicted) < 1e-5


def test_sensitivity_maps_at_vertices_and_files(tmp_path, operators_alpha, heave_mode, plate_alpha):
    system = CoupledSystem(operators_alpha, SOLID)
    mode = adjoint_mode(system, heave_mode.value, heave_mode.vector)
    with pytest.raises(InputError, match="positive diameter"):
        sensitivity_maps(system, mode, "heave", diameter=0.0)
    maps = sensitivity_maps(system, mode, "heave", slope=0.02 + 0.01j)
    points = np.array([[0.7, 0.1], [0.1, -0.15]])
    values = maps_at(maps, plate_alpha.mesh, points)
    # the force map is the field of force_sensitivity's coefficients, in body axes: its integral
    # against a force equals the pairing with the force's load vector
    from ngsolve import Integrate

    sensitivity = force_sensitivity(system, mode)
    for centre, direction in [((0.7, 0.1), (1.0, 0.0)), ((0.1, -0.15), (0.3, 1.0))]:
        force = gaussian_force(centre, 0.1, direction)
        paired = sensitivity @ force_vector(plate_alpha, force)
        integral = [
            Integrate(force[0] * f[0] + force[1] * f[1], plate_alpha.mesh, order=12) for f in maps.force
        ]
        assert complex(*integral) == pytest.approx(paired, rel=1e-6)
    assert np.allclose(values["d_reduced_velocity_control"], -values["control"].real / 0.02)
    ds = maps_dataset([maps], plate_alpha.mesh, {"reynolds": 2900.0})
    assert ds.sizes["vertex"] == plate_alpha.mesh.nv and list(ds.target.values) == ["heave"]
    assert ds.wall_distance.min() == 0 and ds.wall_distance.max() > 10
    vtk = write_maps_vtk([maps], plate_alpha.mesh, tmp_path / "maps")
    assert vtk.name == "maps.vtu" and vtk.stat().st_size > 0
    figure = plot_sensitivity_maps([maps], plate_alpha, tmp_path / "maps.png")
    assert figure.stat().st_size > 0


def test_control_cylinder_map_matches_a_smoothed_cylinder(plate_alpha, operators_alpha, heave_mode):
    """The control-cylinder map (its steady force through the force sensitivity, its linearised
    drag on the perturbation) against a central difference in the strength ``k = C_d d/2`` of a
    cylinder spread over a Gaussian of radius 0.1: eigenvalues of the operators re-assembled at
    the steady state with that force. The step is small because the Gaussian's peak is 1/(πr²)."""
    from ngsolve import Integrate, exp, x, y

    system = CoupledSystem(operators_alpha, SOLID)
    mode = adjoint_mode(system, heave_mode.value, heave_mode.vector)
    maps = sensitivity_maps(system, mode, "heave")
    k = 0.5 * maps.drag * maps.diameter
    step, radius = 1e-4, 0.1
    with pytest.raises(InputError, match="radius must be positive"):
        control_cylinder_operators(plate_alpha, (0.7, 0.1), 0.0)
    errors = []
    for centre in [(0.7, 0.1), (-0.2, 0.15)]:  # in the wake; above the plate's leading half
        values = [
            _eigenvalue_near(
                control_cylinder_operators(plate_alpha, centre, radius, diameter=2 * step, drag=s),
                SOLID,
                mode.value,
            )
            for s in (1, -1)
        ]
        difference = (values[0] - values[1]) / (2 * step)
        weight = exp(-((x - centre[0]) ** 2 + (y - centre[1]) ** 2) / radius**2) / (np.pi * radius**2)
        predicted = (
            complex(*(Integrate(weight * part, plate_alpha.mesh, order=12) for part in maps.control)) / k
        )
        errors.append(_relative_error(difference, predicted))
    assert max(errors) < 1e-4, errors  # measured 2.5e-6, 7.9e-6: the difference's O(step²)


# --------------------------------------------------------------------------------------------
# fsistab sensitivity


def _cli(args, tmp_path):
    from typer.testing import CliRunner

    from fsistab.cli import app

    out, cache = str(tmp_path / "out"), str(tmp_path / "cache")
    return CliRunner().invoke(app, ["sensitivity", *args, "--out", out, "--cache", cache, "--json"])


def test_cli_refuses_a_fixed_body_before_any_work(tmp_path):
    result = _cli(["--dofs", "none"], tmp_path)
    assert result.exit_code == 2 and result.stdout == ""
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "at least one solid degree of freedom" in lines[0]
    assert not (tmp_path / "cache").exists()


def test_cli_sensitivity_json_and_maps(tmp_path, plate_alpha, flutter, flutter_differences):
    """The coarse plate at Re = 2900, α0 = 2° (its steady state put in the cache): the flutter
    threshold's derivatives against the re-converged thresholds, the maps' files."""
    from fsistab.mesh import spec_for
    from fsistab.params import Case
    from fsistab.steady import save_steady, steady_path
    from fsistab.store import read_dataset

    case = Case.create("plate", 2900.0, ALPHA0, "coarse")
    assert spec_for(case).key() == plate_alpha.mesh_spec.key()
    save_steady(plate_alpha, steady_path(spec_for(case), case.flow, tmp_path / "cache"))
    args = ["--body", "plate", "--Re", "2900", "--alpha0", str(ALPHA0), "--mesh", "coarse"]
    args += ["--mass-ratio", "1000", "--zeta-h", "0.001", "--reduced-velocity-range", "4.2", "4.7"]
    result = _cli([*args, "--points", "3", "--wake-shift", "0+11i"], tmp_path)
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    (threshold,) = payload["thresholds"]
    assert threshold["kind"] == "flutter"
    assert threshold["reduced_velocity"] == pytest.approx(flutter.reduced_velocity, rel=1e-8)
    errors = {
        p: _relative_error(d_velocity, threshold["derivatives"][p])
        for p, (d_velocity, _) in flutter_differences.items()
    }
    assert max(errors.values()) < RELATIVE, errors
    maps = read_dataset(Path(payload["maps"]))
    assert list(maps.target.values) == ["flutter0", "wake"]
    assert np.isnan(maps.d_reduced_velocity_control.sel(target="wake")).all()
    assert np.isfinite(maps.d_reduced_velocity_control.sel(target="flutter0")).all()
    for target, best in payload["best_control"].items():
        vertex = np.argmin(np.hypot(maps.x.values - best["x"], maps.y.values - best["y"]))
        assert maps.wall_distance.values[vertex] >= maps.attrs["control_diameter"]  # clear of the body
        if target == "wake":
            assert best["d_growth_rate"] == maps.control.sel(target="wake", part="real").values[vertex] < 0
        else:
            assert best["d_reduced_velocity"] > 0
    assert Path(payload["vtk"]).stat().st_size > 0 and Path(payload["figure"]).stat().st_size > 0


def test_cylinder_viv_threshold_derivatives_match_finite_differences(cylinder_50):
    """The heave-only cylinder at Re 50 (coarse), m = 20 in its convention: the VIV restabilisation
    on the wake branch (U* = 7.17 in diameter units). Its dU*_c/dm and dU*_c/dζ_h against central
    differences of re-converged points; with ζ_h = 0 the neutral frequency solves Im T(iω) = 0
    alone (docs/model.md §8, one dof), so dω_c/dm = 0 exactly."""
    from fsistab.critical import find_thresholds
    from fsistab.params import solid_for

    fluid = fluid_operators(cylinder_50)
    solid = solid_for("cylinder", 20.0, 4.0)
    velocities = np.geomspace(4.0, 8.0, 24) / (2 * np.pi)
    found, _ = find_thresholds(fluid, solid, velocities, wake_shift=0.75j)
    # ζ_h = 0 fixes the neutral frequency whatever U* (above), so both edges of the lock-in
    # window follow the wake, not the spring: both are VIV
    viv = {t.boundary: t for t in found if t.kind == "viv"}
    assert sorted(viv) == ["onset", "restabilisation"]
    assert viv["onset"].reduced_velocity < viv["restabilisation"].reduced_velocity
    point = viv["restabilisation"]
    at_point = replace(solid, reduced_velocity=point.reduced_velocity)
    result = threshold_sensitivity(fluid, at_point, point, ("mass_ratio", "zeta_h"))
    assert abs(result.frequency_derivative["mass_ratio"]) < 1e-8
    # central differences in m; one-sided second-order ones in ζ_h, which is 0 and cannot go below
    for parameter, step, offsets, weights in (
        ("mass_ratio", 1e-4 * solid.mass_ratio, (1, -1), (0.5, -0.5)),
        ("zeta_h", 1e-4, (0, 1, 2), (-1.5, 2.0, -0.5)),
    ):
        values = []
        for offset in offsets:
            moved_solid = replace(at_point, **{parameter: getattr(solid, parameter) + offset * step})
            moved = flutter_point(fluid, moved_solid, point.frequency, point.mode)
            values.append(moved.reduced_velocity)
        difference = sum(w * v for w, v in zip(weights, values, strict=True)) / step
        assert _relative_error(difference, result.velocity[parameter]) < RELATIVE, parameter
