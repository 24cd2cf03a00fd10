"""The continuation as an iterator of points (:class:`fsistab.continuation.ContinuationIterator`,
docs/model.md §8) on curves whose folds and events are known in closed form.

Every expected value comes from the analysis of the curve, written next to the test.
"""

import math

import numpy as np
import pytest

from fsistab.continuation import (
    ContinuationIterator,
    ContinuationSettings,
    CurveProblem,
    TestFunction,
    continuation,
)
from fsistab.errors import ConvergenceError, InputError


def circle(radius=1.0):
    """``x² + p² = r²``: folds of p at the poles ``(0, ±r)``; arclength ``r θ``."""
    return CurveProblem.from_jacobian(
        lambda y: np.array([y[0] ** 2 + y[1] ** 2 - radius**2]),
        lambda y: np.array([[2 * y[0], 2 * y[1]]]),
    )


def parabola():
    """``p - x² = 0``: one fold of p at the origin (the fold normal form)."""
    return CurveProblem.from_jacobian(
        lambda y: np.array([y[1] - y[0] ** 2]), lambda y: np.array([[-2 * y[0], 1.0]])
    )


def test_the_caller_stops_the_circle_after_one_turn():
    """The iterator has no length of its own beyond max_points: the caller stops it once the
    arclength passes 2π, one turn of the unit circle (through both poles)."""
    settings = ContinuationSettings(step=0.05, max_step=0.3, max_points=1000)
    iterator = ContinuationIterator(circle(), [1.0, 0.0], [0.0, 1.0], settings)
    points, folds = [], []
    for accepted in iterator:
        points.append(accepted)
        folds += [e for e in accepted.events if e.kind == "fold"]
        if accepted.arclength > 2 * math.pi:
            break
    assert iterator.stop is None  # stopped by the caller, not by the curve
    assert points[0].index == 0 and points[0].step == 0.0 and points[0].arclength == 0.0
    assert [p.index for p in points] == list(range(len(points)))
    for before, after in zip(points[:-1], points[1:], strict=True):
        assert after.arclength == pytest.approx(before.arclength + after.step, rel=1e-15)
        # Δs is the chord projected on the exact tangent at the point before: on the unit circle
        # sin θ for the angle θ between the two points
        (x0, p0), (x1, p1) = before.point, after.point
        angle = math.atan2(x0 * p1 - p0 * x1, x0 * x1 + p0 * p1)
        assert after.step == pytest.approx(math.sin(angle), abs=1e-9)
    for p in points:
        assert p.point @ p.point == pytest.approx(1.0, abs=1e-10)
        assert np.linalg.norm(p.tangent) == pytest.approx(1.0, abs=1e-12)
        assert abs(p.tangent @ p.point) < 1e-8  # the tangent of a circle is normal to its radius
    # one turn from (1, 0) counter-clockwise: folds at the pole p = +1, then p = -1
    assert [round(f.parameter_value) for f in folds[:2]] == [1, -1]
    for fold in folds:
        assert abs(fold.point[0]) < 1e-8 and abs(abs(fold.point[1]) - 1.0) < 5e-11
    for fold, sign in zip(folds[:2], (1, -1), strict=True):
        # between the points where x changes sign, x > 0 before the upper pole, x < 0 before the lower
        before, after = points[fold.index], points[fold.index + 1]
        assert sign * before.point[0] > 0 > sign * after.point[0]
        assert before.arclength < fold.arclength < after.arclength


def test_events_come_with_the_point_after_them():
    """A fold between points k and k + 1 is yielded with point k + 1 (``event.index == k``)."""
    iterator = ContinuationIterator(parabola(), [-1.0, 1.0], [1.0, -2.0], ContinuationSettings(step=0.1))
    seen = []
    for accepted in iterator:
        for event in accepted.events:
            seen.append((accepted.index, event))
        if accepted.point[0] > 1.0:
            break
    ((index, fold),) = seen
    assert fold.kind == "fold" and fold.localised and fold.index == index - 1
    # the fold of p = x² is at x = 0, p = 0; |F| < 1e-10 and ∂F/∂p = 1 at the located point
    assert abs(fold.point[0]) < 1e-9 and abs(fold.parameter_value) < 1e-9


def test_a_test_function_zero_is_located_where_it_vanishes():
    """``g = x - 1/2`` on the unit circle from (1, 0) upwards: zero at ``(1/2, √3/2)``; terminal,
    the curve ends there."""
    events = {"half": TestFunction(lambda y: y[0] - 0.5, terminal=True)}
    iterator = ContinuationIterator(
        circle(), [1.0, 0.0], [0.0, 1.0], ContinuationSettings(step=0.05, max_step=0.2), events=events
    )
    points = list(iterator)
    assert iterator.stop == "event:half" and iterator.stop_event is points[-1].events[-1]
    end = points[-1].point
    assert end[0] == pytest.approx(0.5, abs=1e-9) and end[1] == pytest.approx(math.sqrt(3) / 2, abs=1e-9)
    assert np.all([p.point[0] > 0.5 for p in points[:-1]])


def test_stop_is_known_with_the_last_point_or_after_a_failed_step():
    at_bound = ContinuationIterator(
        circle(), [1.0, 0.0], [0.0, 1.0], ContinuationSettings(step=0.1), bounds={1: (-0.5, 0.5)}
    )
    points = []
    for accepted in at_bound:
        points.append(accepted)
        assert at_bound.stop in (None, "bound")
    # clipped at p = 1/2: x = √(1 - 1/4)
    assert at_bound.stop == "bound" and points[-1].point == pytest.approx([math.sqrt(0.75), 0.5], abs=1e-10)
    assert next(at_bound, None) is None  # single pass: exhausted

    counted = ContinuationIterator(circle(), [1.0, 0.0], [0.0, 1.0], ContinuationSettings(max_points=4))
    stops = [counted.stop for _ in counted]
    assert stops == [None, None, None, "max_points"]

    def wall(y):  # no residual beyond p = 1/2: the corrector fails there, down to min_step
        if y[1] > 0.5:
            raise ValueError("no residual beyond the wall")
        return np.array([y[0] ** 2 + y[1] ** 2 - 1])

    walled = ContinuationIterator(
        CurveProblem.from_jacobian(wall, lambda y: np.array([[2 * y[0], 2 * y[1]]])), [1.0, 0.0], [0.0, 1.0]
    )
    points = list(walled)
    assert walled.stop == "step_too_small" and points[-1].point[1] <= 0.5
    assert 0.5 - points[-1].point[1] < 2 * ContinuationSettings().min_step


def test_the_iterator_checks_its_input_at_once_and_the_start_at_the_first_point():
    with pytest.raises(InputError, match="direction"):
        ContinuationIterator(circle(), [1.0, 0.0], [0.0, 0.0])
    with pytest.raises(InputError, match="outside its bounds"):
        ContinuationIterator(circle(), [1.0, 0.0], [0.0, 1.0], bounds={0: (-0.5, 0.5)})
    no_curve = CurveProblem.from_jacobian(
        lambda y: np.array([y[0] ** 2 + 1.0]), lambda y: np.array([[2 * y[0], 0.0]])
    )
    iterator = ContinuationIterator(no_curve, [1.0, 0.0], [0.0, 1.0])
    with pytest.raises(ConvergenceError, match="not on the curve"):
        next(iterator)


@pytest.mark.parametrize("predictor", ["tangent", "secant"])
def test_continuation_keeps_what_the_iterator_yields(predictor):
    """:func:`continuation` is the iterator's points gathered: the same points, steps, events."""
    settings = ContinuationSettings(step=0.05, max_step=0.3, max_points=30, predictor=predictor)
    branch = continuation(circle(), [1.0, 0.0], [0.0, 1.0], settings)
    points = list(ContinuationIterator(circle(), [1.0, 0.0], [0.0, 1.0], settings))
    assert np.array_equal(branch.points, [p.point for p in points])
    assert np.array_equal(branch.tangents, [p.tangent for p in points])
    assert np.array_equal(branch.steps, [p.step for p in points[1:]])
    assert np.array_equal(branch.arclengths[1:], np.cumsum([p.step for p in points[1:]]))
    assert [e.arclength for e in branch.events] == [e.arclength for p in points for e in p.events]
    assert branch.stop == "max_points"
