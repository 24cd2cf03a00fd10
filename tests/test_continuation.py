"""Pseudo-arclength continuation on algebraic curves with known folds and Hopf points (docs/model.md §8).

Every expected value comes from the analysis of the curve, written next to the test.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from fsistab.continuation import (
    ContinuationSettings,
    CurveProblem,
    SquareProblem,
    TestFunction,
    continuation,
    dense_bordered_solver,
    newton,
    polyline_intersections,
)
from fsistab.errors import ConvergenceError, InputError


def circle(centre=(0.0, 0.0), radius=1.0):
    """``(x - c_x)² + (p - c_p)² = r²``: folds of p at ``p = c_p ± r`` (``x = c_x``)."""
    cx, cp = centre
    return CurveProblem.from_jacobian(
        lambda y: np.array([(y[0] - cx) ** 2 + (y[1] - cp) ** 2 - radius**2]),
        lambda y: np.array([[2 * (y[0] - cx), 2 * (y[1] - cp)]]),
    )


def cubic():
    """``x³ - x + p = 0``: p = x - x³ has folds at x = ∓1/√3, p = ∓2/(3√3)."""
    return CurveProblem.from_jacobian(
        lambda y: np.array([y[0] ** 3 - y[0] + y[1]]), lambda y: np.array([[3 * y[0] ** 2 - 1, 1.0]])
    )


@pytest.mark.parametrize("predictor", ["tangent", "secant"])
def test_circle_folds_at_both_poles(predictor):
    branch = continuation(
        circle(), [1.0, 0.0], [0.0, 1.0], step=0.05, max_step=0.3, max_points=40, predictor=predictor
    )
    assert branch.stop == "max_points" and len(branch.points) == 40
    x, p = branch.points.T
    assert np.max(np.abs(x**2 + p**2 - 1)) < 1e-10
    # 40 points at Δs ≤ 0.3 go more than once around (circumference 2π): poles +1, -1, +1, ...
    assert branch.arclengths[-1] > 2 * math.pi
    folds = branch.folds
    assert len(folds) >= 3 and all(f.localised for f in folds)
    for k, fold in enumerate(folds):
        expected = 1.0 if k % 2 == 0 else -1.0
        # the corrector stops at |F| < 1e-10 and |∂F/∂p| = 2 at the poles: |δp| < 5e-11
        assert fold.parameter_value == pytest.approx(expected, abs=5e-11)
        assert abs(fold.point[0]) < 1e-8  # the tangent (-p, x) has no p component only at x = 0
        # the fold lies between points[index] and points[index + 1]: x changes sign there
        assert x[fold.index] * x[fold.index + 1] < 0
        assert branch.arclengths[fold.index] < fold.arclength < branch.arclengths[fold.index + 1]


@settings(max_examples=20, deadline=None)
@given(
    cx=st.floats(-3, 3),
    cp=st.floats(-3, 3),
    radius=st.floats(0.2, 5),
)
def test_circle_folds_anywhere(cx, cp, radius):
    branch = continuation(
        circle((cx, cp), radius),
        [cx + radius, cp],
        [0.0, 1.0],
        step=0.05 * radius,
        max_step=0.3 * radius,
        min_step=1e-5 * radius,
        max_points=30,
    )
    values = sorted(f.parameter_value for f in branch.folds[:2])
    assert values == pytest.approx([cp - radius, cp + radius], abs=1e-9 * max(1.0, radius))


def test_fold_normal_form_is_passed_through():
    """``p - x² = 0`` from x = -1 towards increasing x: p falls to the fold p = 0 at x = 0, rises."""
    problem = CurveProblem.from_jacobian(
        lambda y: np.array([y[1] - y[0] ** 2]), lambda y: np.array([[-2 * y[0], 1.0]])
    )
    branch = continuation(problem, [-1.0, 1.0], [1.0, -2.0], step=0.1, max_points=25)
    (fold,) = branch.folds
    assert abs(fold.point[0]) < 1e-9 and abs(fold.parameter_value) < 1e-9
    x = branch.points[:, 0]
    assert np.all(np.diff(x) > 0) and x[-1] > 1  # through the fold, on the other side
    assert fold.index == np.nonzero(x > 0)[0][0] - 1


@pytest.mark.parametrize("predictor", ["tangent", "secant"])
def test_cubic_folds_and_stops_at_the_parameter_bound(predictor):
    branch = continuation(
        cubic(),
        [-2.0, 6.0],
        [1.0, 0.0],
        step=0.05,
        max_step=0.3,
        bounds={1: (-7.0, 7.0)},
        predictor=predictor,
    )
    fold_p = 2 / (3 * math.sqrt(3))
    assert [round(f.parameter_value / fold_p) for f in branch.folds] == [-1, 1]
    for fold, sign in zip(branch.folds, (-1, 1), strict=True):
        # |F| < 1e-10 at the corrected point and ∂F/∂p = 1: |δp| < 1e-10
        assert fold.parameter_value == pytest.approx(sign * fold_p, abs=1e-10)
        assert fold.point[0] == pytest.approx(sign / math.sqrt(3), abs=1e-6)
    # p = x - x³ = -7 past the second fold: the real root of x³ - x - 7 = 0
    root = max(r.real for r in np.roots([1, 0, -1, -7]) if abs(r.imag) < 1e-12)
    assert branch.stop == "bound" and branch.stop_event.component == 1
    assert branch.points[-1] == pytest.approx([root, -7.0], abs=1e-10)
    assert np.all(branch.parameter_values >= -7.0 - 1e-12)


def test_bound_without_clipping_keeps_the_first_point_outside():
    branch = continuation(
        cubic(), [-2.0, 6.0], [1.0, 0.0], step=0.05, max_step=0.3, bounds={1: (-7, 7)}, clip=False
    )
    p = branch.parameter_values
    assert branch.stop == "bound" and p[-1] < -7 < p[-2]
    assert not branch.stop_event.localised


def bratu(n):
    """``-u'' = λ eᵘ`` on (0, 1), ``u(0) = u(1) = 0``: second-order differences on n interior nodes."""
    h = 1.0 / (n + 1)
    lap = (np.diag(np.full(n, 2.0)) - np.diag(np.ones(n - 1), 1) - np.diag(np.ones(n - 1), -1)) / h**2

    def residual(y):
        u, lam = y[:-1], y[-1]
        return lap @ u - lam * np.exp(u)

    def jacobian(y):
        u, lam = y[:-1], y[-1]
        return np.column_stack([lap - lam * np.diag(np.exp(u)), -np.exp(u)])

    return CurveProblem.from_jacobian(residual, jacobian)


def test_bratu_fold_converges_to_the_exact_one_at_second_order():
    """Exact solution ``u = -2 ln(cosh((x - ½)θ/2)/cosh(θ/4))`` with ``λ = θ²/(2 cosh²(θ/4))``,
    largest where ``z tanh z = 1`` (``z = θ/4``): ``λ* = 8 z²/cosh² z ≈ 3.5138``."""
    z = brentq(lambda z: z * math.tanh(z) - 1, 0.5, 2.0)
    exact = 8 * z**2 / math.cosh(z) ** 2
    errors = []
    for n in (15, 31):
        direction = np.zeros(n + 1)
        direction[-1] = 1.0
        branch = continuation(bratu(n), np.zeros(n + 1), direction, step=0.2, max_step=1.0, max_points=40)
        fold = branch.folds[0]
        assert fold.localised
        errors.append(fold.parameter_value - exact)
        # at the fold u(½) = 2 ln cosh z (the exact maximum), to discretisation accuracy
        assert fold.point[n // 2] == pytest.approx(2 * math.log(math.cosh(z)), rel=2e-2)
    # h = 1/16 → 1/32: the error of the second-order scheme falls about fourfold
    assert 3.5 < errors[0] / errors[1] < 4.5
    assert abs(errors[1]) < 1e-2


def brusselator(a):
    """Equilibria of ``ẋ = a - (b + 1)x + x²y, ẏ = bx - x²y`` in ``(x, y, b)``: ``x = a, y = b/a``.
    Trace of the 2×2 Jacobian there ``b - 1 - a²``: Hopf at ``b = 1 + a²``, determinant ``a² > 0``."""

    def rates_jacobian(y):
        x, v, b = y
        return np.array([[-(b + 1) + 2 * x * v, x**2], [b - 2 * x * v, -(x**2)]])

    problem = CurveProblem.from_jacobian(
        lambda y: np.array([a - (y[2] + 1) * y[0] + y[0] ** 2 * y[1], y[2] * y[0] - y[0] ** 2 * y[1]]),
        lambda y: np.column_stack([rates_jacobian(y), [-y[0], y[0]]]),
    )
    return problem, rates_jacobian


@pytest.mark.parametrize("terminal", [False, True])
def test_hopf_point_of_the_brusselator_by_the_trace_test_function(terminal):
    a = 2.0
    problem, rates_jacobian = brusselator(a)
    trace = TestFunction(lambda y: float(np.trace(rates_jacobian(y))), terminal=terminal)
    branch = continuation(
        problem, [a, 1 / a, 1.0], [0, 0, 1.0], step=0.1, max_step=0.5, max_points=30, events={"hopf": trace}
    )
    (hopf,) = [e for e in branch.events if e.kind == "hopf"]
    assert hopf.localised and hopf.point == pytest.approx([a, (1 + a**2) / a, 1 + a**2], abs=1e-10)
    assert np.linalg.det(rates_jacobian(hopf.point)) == pytest.approx(a**2, rel=1e-10)
    assert branch.folds == ()  # the equilibria are a straight line x = a, y = b/a
    b = branch.parameter_values
    assert b[hopf.index] < 1 + a**2
    if terminal:  # the curve ends at the located Hopf point
        assert branch.stop == "event:hopf" and branch.points[-1] == pytest.approx(hopf.point)
    else:
        assert branch.stop == "max_points" and b[hopf.index + 1] > 1 + a**2


def test_steps_grow_after_fast_convergence_up_to_the_maximum():
    branch = continuation(
        circle(), [1.0, 0.0], [0.0, 1.0], step=0.01, max_step=0.2, max_points=20, growth=1.5
    )
    steps, its = branch.steps, branch.iterations[1:]
    assert steps[0] == 0.01 and steps.max() == 0.2
    for k in range(len(steps) - 1):
        expected = min(0.2, 1.5 * steps[k]) if its[k] <= 3 else steps[k]
        assert steps[k + 1] == pytest.approx(expected)


def test_steps_halve_on_failure_and_the_curve_stops_at_the_minimum_step():
    """The residual refuses points farther than 0.03 from the start: Δs = 0.1 → 0.05 → 0.025."""
    base = circle()

    def residual(y):
        if np.hypot(y[0] - 1, y[1]) > 0.03:
            raise ConvergenceError("outside the admissible region")
        return base.residual(y)

    problem = CurveProblem(residual, base.solve)
    branch = continuation(problem, [1.0, 0.0], [0.0, 1.0], step=0.1, min_step=1e-3, max_points=50)
    assert branch.steps[0] == 0.025
    assert branch.stop == "step_too_small" and 1 < len(branch.points) < 50
    assert np.all(np.hypot(branch.points[:, 0] - 1, branch.points[:, 1]) <= 0.03)


def test_large_turns_are_refused():
    """A step of Δs on the unit circle turns the tangent by about Δs radians."""
    branch = continuation(
        circle(), [1.0, 0.0], [0.0, 1.0], step=0.5, max_step=0.5, max_points=10, max_turn=0.3
    )
    cosines = np.sum(branch.tangents[1:] * branch.tangents[:-1], axis=1)
    assert np.all(cosines >= math.cos(0.3)) and branch.steps.max() <= 0.3


def test_errors_say_what_to_try():
    no_curve = CurveProblem.from_jacobian(
        lambda y: np.array([y[0] ** 2 + y[1] ** 2 + 1]), lambda y: np.array([[2 * y[0], 2 * y[1]]])
    )
    with pytest.raises(ConvergenceError, match="not on the curve.*closer"):
        continuation(no_curve, [1.0, 0.0], [0.0, 1.0])
    with pytest.raises(ConvergenceError, match="try a smaller min_step"):
        continuation(circle(), [1.0, 0.0], [0.0, 1.0], max_iterations=0)
    with pytest.raises(InputError, match="outside its bounds"):
        continuation(circle(), [1.0, 0.0], [0.0, 1.0], bounds={1: (0.5, 2.0)})
    with pytest.raises(InputError, match="direction"):
        continuation(circle(), [1.0, 0.0], [0.0, 0.0])
    with pytest.raises(InputError, match="predictor"):
        continuation(circle(), [1.0, 0.0], [0.0, 1.0], predictor="euler")
    bad = CurveProblem(circle().residual, dense_bordered_solver(lambda y: np.ones((2, 2))))
    with pytest.raises(InputError, match="must be 1 × 2"):
        continuation(bad, [1.0, 0.0], [0.0, 1.0])


def test_record_and_callbacks_see_every_point_and_event():
    seen, events = [], []
    branch = continuation(
        cubic(),
        [-2.0, 6.0],
        [1.0, 0.0],
        step=0.1,
        max_points=40,
        record=lambda y: y[1:],
        on_point=lambda y, its: seen.append(y.copy()),
        on_event=events.append,
    )
    assert branch.points.shape == (40, 1) and len(seen) == 39
    assert np.array_equal(branch.points[1:, 0], [y[1] for y in seen])
    assert events == list(branch.events) and len(events) == 2
    with pytest.raises(ValueError):
        branch.points[0, 0] = 1.0  # results are immutable


def test_polyline_intersections():
    square_diagonals = polyline_intersections([[0, 0], [1, 1]], [[0, 1], [1, 0]])
    ((point, i, a, j, b),) = square_diagonals
    assert point == pytest.approx([0.5, 0.5]) and (i, j) == (0, 0) and a == b == pytest.approx(0.5)
    # a regular 12-gon inscribed in the unit circle against the line y = 0.2: its chord is
    # crossed at x = ±x0 with x0 between the polygon's inner radius cos(π/12) and the circle's
    angle = np.linspace(0, 2 * np.pi, 13)
    polygon = np.column_stack([np.cos(angle), np.sin(angle)])
    hits = polyline_intersections(polygon, [[-2, 0.2], [2, 0.2]])
    xs = sorted(h[0][0] for h in hits)
    assert len(xs) == 2 and xs[0] == pytest.approx(-xs[1])
    assert math.sqrt(math.cos(math.pi / 12) ** 2 - 0.04) < xs[1] < math.sqrt(1 - 0.04)
    assert polyline_intersections([[0, 0], [1, 0]], [[0, 1], [1, 1]]) == []
    with pytest.raises(InputError):
        polyline_intersections([0, 1], [[0, 1], [1, 1]])


@pytest.mark.parametrize("predictor", ["tangent", "secant"])
def test_arclength_weights_measure_the_step_in_the_weighted_components_only(predictor):
    """``z = 10 x², x² + p² = 1`` with weight 0 on z: the steps are pseudo-arclengths in (x, p)
    and the folds of p stay at ±1 (z = 0 there)."""
    problem = CurveProblem.from_jacobian(
        lambda y: np.array([y[0] - 10 * y[1] ** 2, y[1] ** 2 + y[2] ** 2 - 1]),
        lambda y: np.array([[1.0, -20 * y[1], 0.0], [0.0, 2 * y[1], 2 * y[2]]]),
        weights=np.array([0.0, 1.0, 1.0]),
    )
    branch = continuation(problem, [10.0, 1.0, 0.0], [0, 0, 1.0], step=0.1, max_step=0.3, predictor=predictor)
    y, t = branch.points, branch.tangents
    constraint = np.sum((t[:-1] * (y[1:] - y[:-1]))[:, 1:], axis=1)
    assert constraint == pytest.approx(branch.steps, abs=1e-10)
    assert np.linalg.norm(t[:, 1:], axis=1) == pytest.approx(1.0)
    values = [f.parameter_value for f in branch.folds[:2]]
    assert values == pytest.approx([1.0, -1.0], abs=1e-10)
    assert all(abs(f.point[0]) < 2e-10 for f in branch.folds)  # |F₁| < 1e-10 and x ≈ 0


def test_newton_converges_quadratically_to_a_known_root():
    """``y² - 2 = 0`` from 1: Newton's iterates 3/2, 17/12, 577/408 (errors squared each step)."""
    problem = SquareProblem(lambda y: np.array([y[0] ** 2 - 2]), lambda y, rhs, reuse: rhs / (2 * y))
    two_steps = newton(problem, [1.0], tol=1e-300, max_iterations=2)
    assert not two_steps.converged and two_steps.point[0] == pytest.approx(17 / 12, rel=1e-15)
    assert "after 2 iterations" in two_steps.reason
    result = newton(problem, [1.0], tol=1e-14)
    assert result.converged and result.point[0] == pytest.approx(math.sqrt(2), rel=1e-15)
    errors = [abs(r) for r in result.residuals]
    assert errors[:3] == pytest.approx([1.0, 0.25, 1 / 144], rel=1e-12)  # |y_k² - 2|
    # a step criterion stops after the step, without evaluating G at the new point
    by_step = newton(problem, [1.0], tol=0.0, small_step=lambda d, y: abs(d[0]) < 1e-12)
    assert by_step.converged and len(by_step.residuals) == by_step.iterations
    assert by_step.point[0] == pytest.approx(math.sqrt(2), rel=1e-15)


def test_newton_reports_failures_instead_of_raising():
    def residual(y):
        if y[0] < 0:
            raise ConvergenceError("left the admissible region")
        return np.array([y[0] ** 2 + 1.0])  # no real root

    result = newton(SquareProblem(residual, lambda y, rhs, reuse: rhs / (2 * y)), [0.5], max_iterations=5)
    assert not result.converged and "admissible" in result.reason  # 0.5 → -0.75
    singular = SquareProblem(lambda y: np.array([y[0] ** 2 + 1.0]), lambda y, rhs, reuse: rhs / 0.0)
    with np.errstate(divide="ignore"):
        assert "non-finite" in newton(singular, [0.5]).reason


def test_newton_small_step_with_final_residual_records_the_residual_of_the_returned_point():
    """``y² - 2 = 0`` from 1 stopped by the step size only (``tol = 0``): with ``final_residual`` the
    same iterates, plus ``|y² - 2|`` at the returned point (≤ the round-off of ``y²`` near 2)."""
    problem = SquareProblem(lambda y: np.array([y[0] ** 2 - 2]), lambda y, rhs, reuse: rhs / (2 * y))
    by_step = newton(problem, [1.0], tol=0.0, small_step=lambda d, y: abs(d[0]) < 1e-12)
    final = newton(problem, [1.0], tol=0.0, small_step=lambda d, y: abs(d[0]) < 1e-12, final_residual=True)
    assert final.converged and final.iterations == by_step.iterations
    assert final.point[0] == by_step.point[0] == pytest.approx(math.sqrt(2), rel=1e-15)
    assert final.residuals[:-1] == by_step.residuals and len(final.residuals) == final.iterations + 1
    assert final.residuals[-1] <= 4.5e-16 and len(final.path) == len(final.residuals)
    assert final.path[-1][0] == final.point[0]
    # the final evaluation counts: if it fails, the step criterion alone does not converge
    calls = []

    def residual_failing_second(y):
        calls.append(y[0])
        if len(calls) > 1:
            raise ConvergenceError("left the admissible region")
        return np.array([y[0] ** 2 - 2])

    failing = SquareProblem(residual_failing_second, problem.solve)
    assert newton(failing, [1.0], tol=0.0, small_step=lambda d, y: True).converged
    calls.clear()
    result = newton(failing, [1.0], tol=0.0, small_step=lambda d, y: True, final_residual=True)
    assert not result.converged and "admissible" in result.reason and calls == [1.0, 1.5]
    with pytest.raises(InputError, match="small_step"):
        newton(problem, [1.0], final_residual=True)


def _affine_static_problem(singular_is_root: bool) -> SquareProblem:
    """``A(κ) q = 0`` with ``A(κ) = [[κ - 1, 1], [1, 2]]`` and ``q₀ = 1``, in ``y = (q₀, q₁, κ)``:
    the second row gives ``q₁ = -1/2``, the first ``κ = 3/2``, where ``det A = 2κ - 3 = 0``. Like
    the static problem of :mod:`fsistab.critical`, affine in ``κ`` and solved through ``A(κ)⁻¹``
    (``δq = a + δκ c``, ``A a = r_q``, ``A c = -∂A/∂κ q``), which fails at the root only."""

    def matrix(kappa):
        return np.array([[kappa - 1.0, 1.0], [1.0, 2.0]])

    def residual(y):
        return np.append(matrix(y[2]) @ y[:2], y[0] - 1.0)

    def solve(y, rhs, reuse):
        a = np.linalg.solve(matrix(y[2]), rhs[:2])
        c = np.linalg.solve(matrix(y[2]), [-y[0], 0.0])
        d_kappa = (rhs[2] - a[0]) / c[0]
        return np.append(a + d_kappa * c, d_kappa)

    return SquareProblem(residual, solve, singular_is_root=singular_is_root)


def test_newton_stops_converged_where_a_singular_is_root_problem_is_singular():
    """From ``(1, 0, 1)``: ``a = (-1, 0)``, ``c = (2, -1)``, ``δκ = 1/2``, so one step lands on the
    root ``(1, -1/2, 3/2)`` exactly (``G = 0``). With ``tol = 0`` the next solve is attempted and
    ``A(3/2)`` is singular: converged there if the problem says so, a failure otherwise."""
    result = newton(_affine_static_problem(True), [1.0, 0.0, 1.0], tol=0.0)
    assert result.converged and result.iterations == 1 and result.reason == ""
    assert result.point.tolist() == [1.0, -0.5, 1.5]
    assert result.residuals == (1.0, 0.0)
    assert result.last_step.tolist() == [0.0, -0.5, 0.5]
    plain = newton(_affine_static_problem(False), [1.0, 0.0, 1.0], tol=0.0)
    assert not plain.converged and "singular" in plain.reason.lower()
    assert plain.point.tolist() == [1.0, -0.5, 1.5]
    # from elsewhere, q₁ = 0.3 and κ = 0: a = (-1, -0.3), c = (2/3, -1/3), δκ = 3/2, one step to the
    # root (up to round-off)
    other = newton(_affine_static_problem(True), [1.0, 0.3, 0.0], tol=1e-14)
    assert other.converged and other.iterations == 1
    assert other.point == pytest.approx([1.0, -0.5, 1.5], abs=1e-15)


def test_pinned_curve_problem_is_a_point_of_the_curve():
    """The circle x² + p² = 1 with p held at 0.6: x = 0.8 (from 1), p exactly 0.6 throughout."""
    pinned = circle().pinned(1, 0.6)
    result = newton(pinned, [1.0, 0.6], tol=1e-14)
    assert result.converged and result.point[0] == pytest.approx(0.8, rel=1e-14)
    assert result.point[1] == 0.6
    # from off the held value the first step lands on it exactly
    assert newton(pinned, [1.0, 0.5], tol=1e-14).point[1] == 0.6


def test_settings_object_and_keyword_overrides_are_the_same():
    settings_ = ContinuationSettings(step=0.05, max_step=0.3, max_points=12, predictor="secant")
    by_object = continuation(circle(), [1.0, 0.0], [0.0, 1.0], settings_)
    by_keywords = continuation(
        circle(), [1.0, 0.0], [0.0, 1.0], step=0.05, max_step=0.3, max_points=12, predictor="secant"
    )
    assert np.array_equal(by_object.points, by_keywords.points) and len(by_object.points) == 12
    overridden = continuation(circle(), [1.0, 0.0], [0.0, 1.0], settings_, max_points=5)
    assert np.array_equal(overridden.points, by_object.points[:5])
    for bad in (
        {"step": math.nan},
        {"max_points": 0},
        {"max_points": 2.5},
        {"min_step": 2.0, "step": 1.0},
        {"tol": 0.0},
        {"growth": 0.5},
        {"predictor": "euler"},
    ):
        with pytest.raises(InputError):
            ContinuationSettings(**bad)
    with pytest.raises(InputError, match="unknown continuation settings"):
        continuation(circle(), [1.0, 0.0], [0.0, 1.0], stepsize=0.1)
