"""Neutral curves by pseudo-arclength (MODEL.md §8), plate, Re = 2900, coarse mesh."""

import math

import numpy as np
import pytest

from fsistab.coupled import CoupledSystem
from fsistab.critical import flutter_point, mass_derivative
from fsistab.eigen import eigenpairs_near
from fsistab.errors import InputError
from fsistab.neutral import continue_neutral_curve, divergence_curve, divergence_velocity
from fsistab.params import Solid


def _assert_neutral(fluid, mass_ratio, reduced_velocity, frequency):
    """The eigen-solver finds λ = 0 (1e-8) at (m, U*) with ω = ``frequency`` (1e-7 relative)."""
    system = CoupledSystem(fluid, Solid(mass_ratio=mass_ratio, reduced_velocity=reduced_velocity))
    nearest = min(
        eigenpairs_near(system, [0.002 + 1j * frequency], 3),
        key=lambda p: abs(p.value - 1j * frequency),
    )
    assert abs(nearest.growth_rate) < 1e-8
    assert nearest.frequency == pytest.approx(frequency, rel=1e-7)


def test_mass_ratio_derivative_matches_finite_difference(plate_operators):
    """∂(J + iωM)/∂(log m) q, used by the arclength corrector."""
    q = np.random.default_rng(0).standard_normal(CoupledSystem(plate_operators, Solid()).size) + 0j
    omega, eps = 0.2, 1e-6

    def apply(mass_ratio):
        system = CoupledSystem(plate_operators, Solid(mass_ratio=mass_ratio, reduced_velocity=4.5))
        return system.jacobian @ q + 1j * omega * (system.mass @ q)

    fd = (apply(100 * math.exp(eps)) - apply(100 * math.exp(-eps))) / (2 * eps)
    system = CoupledSystem(plate_operators, Solid(mass_ratio=100, reduced_velocity=4.5))
    exact = mass_derivative(system, q, omega)
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
    _assert_neutral(plate_operators, last.mass_ratio, last.reduced_velocity, last.frequency)


def test_flutter_curve_passes_its_turning_point_in_m(plate_operators):
    """On the coarse mesh the flutter curve traced from m = 1000 towards small m turns back in m a
    little below m = 600 (MODEL.md §8: the continuation must pass turning points). Started at
    m = 600, it must report one located turning point, where m is smallest, and go on to larger m;
    the turning point is itself neutral (checked by the eigen-solver)."""
    solid = Solid(mass_ratio=600, reduced_velocity=3.76)
    pairs = eigenpairs_near(CoupledSystem(plate_operators, solid), [0.002 + 0.22j], 4)
    guess = max((p for p in pairs if p.label != "fluid"), key=lambda p: p.growth_rate)
    start = flutter_point(plate_operators, solid, guess.frequency, guess.vector)
    folds = []
    curve = continue_neutral_curve(
        plate_operators,
        start,
        solid,
        direction=-1,
        step=0.1,
        max_step=0.1,
        max_points=5,
        on_fold=folds.append,
    )
    m = curve.mass_ratios
    (fold,) = curve.turning_points
    assert folds == [fold] and curve.folds == (fold.index,) and fold.localised
    assert np.all(np.diff(m[: fold.index + 1]) < 0) and np.all(np.diff(m[fold.index + 1 :]) > 0)
    assert fold.mass_ratio <= m.min()  # the located fold is the smallest m of the curve
    u = curve.reduced_velocities
    assert np.all(np.diff(u) < 0)  # U* keeps falling through the fold: U*_F(m) is double-valued
    _assert_neutral(plate_operators, fold.mass_ratio, fold.reduced_velocity, fold.frequency)


def test_divergence_velocity_formula():
    """U*_D = √(m r_θ²/(dC_M/dθ)) (MODEL.md §8): thin-airfoil slope π/2, m = 4, r_θ = 1/2 gives
    √(2/π); broadcasting; no divergence (inf) where the slope restores; bad input refused."""
    assert divergence_velocity(math.pi / 2, 0.5, 4.0) == pytest.approx(math.sqrt(2 / math.pi), rel=1e-15)
    grid = divergence_velocity(np.array([[1.0], [4.0], [-2.0], [0.0]]), 0.5, np.array([4.0, 16.0]))
    assert grid.shape == (4, 2)
    assert np.allclose(grid[:2], [[1.0, 2.0], [0.5, 1.0]], rtol=1e-15)
    assert np.all(np.isposinf(grid[2:]))
    bad_inputs = [(math.nan, 0.5, 4), (1.0, math.inf, 4), (1.0, -0.5, 4), (1.0, 0.5, -4), (1.0, 0.5, 0)]
    for bad in bad_inputs:
        with pytest.raises(InputError):
            divergence_velocity(*bad)
    with pytest.raises(InputError, match="mass ratio"):
        divergence_velocity(1.0, 0.5, np.array([1.0, np.nan]))


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


def test_crossing_of_a_flutter_line_with_the_divergence_curve():
    """``U*_D = r_θ √(m/s)`` is ``(r_θ/√s) e^{μ/2}`` in μ = log m: it meets ``U* = 4`` at
    ``μ* = 2 log(4 √s / r_θ)``. The chord of the convex curve lies above it, so the interpolated
    crossing comes early, by at most ``h²/8 · max U_D'' / U_D' = h²/16`` (× e^{h/2}) on a grid h."""
    from fsistab.neutral import curve_crossings

    slope, r_theta, level, h = math.pi / 2, 0.289, 4.0, 0.1
    exact = 2 * math.log(level * math.sqrt(slope) / r_theta)
    mu = np.arange(0.0, 10.0, h)
    divergence = np.column_stack([mu, divergence_curve(slope, r_theta, np.exp(mu))])
    flutter = [[0.0, level], [10.0, level]]
    (crossing,) = curve_crossings(flutter, divergence)
    error = exact - math.log(crossing.mass_ratio)
    assert 0 < error <= h**2 / 16 * math.exp(h / 2)
    assert crossing.reduced_velocity == pytest.approx(level) and not crossing.refined
    assert (
        divergence[crossing.segments[1], 0]
        < math.log(crossing.mass_ratio)
        < divergence[crossing.segments[1] + 1, 0]
    )

    def refine(log_mass, velocity, segments):  # Newton on U_D(μ) = level
        for _ in range(20):
            u = divergence_curve(slope, r_theta, np.array([math.exp(log_mass)]))[0]
            log_mass -= (u - level) / (u / 2)
        return log_mass, level

    (refined,) = curve_crossings(flutter, divergence, refine)
    assert refined.refined and math.log(refined.mass_ratio) == pytest.approx(exact, abs=1e-12)


def test_a_folded_curve_crosses_twice_and_failed_refinements_are_kept():
    from fsistab.errors import ConvergenceError
    from fsistab.neutral import curve_crossings

    folded = [[2.0, 1.0], [0.0, 2.0], [2.0, 3.0]]  # turns back in log m at (0, 2)
    line = [[1.0, 0.0], [1.0, 4.0]]  # log m = 1

    def fail(*_):
        raise ConvergenceError("no convergence")

    crossings = curve_crossings(folded, line, fail)
    assert [(c.segments, c.refined) for c in crossings] == [((0, 0), False), ((1, 0), False)]
    assert [c.reduced_velocity for c in crossings] == pytest.approx([1.5, 2.5])
    assert all(c.mass_ratio == pytest.approx(math.e) for c in crossings)


def test_turning_points_are_stored_with_the_curve(tmp_path):
    from fsistab.neutral import TurningPoint, curve_table, saved_turning_points
    from fsistab.store import read_dataset

    folds = [TurningPoint(1.9, 4.9, 0.21, 1, True), TurningPoint(2.6, 5.2, 0.22, 4, False)]
    table = curve_table(tmp_path / "c.nc", {"case": "plate"})
    for fold in folds:
        record = {"fold_mass_ratio": fold.mass_ratio, "fold_reduced_velocity": fold.reduced_velocity}
        record |= {"fold_frequency": fold.frequency, "fold_index": fold.index}
        table.append({**record, "fold_localised": int(fold.localised)}, kind="fold")
    table.finish({"stop": "mass_range"})
    assert saved_turning_points(curve_table(tmp_path / "c.nc", {"case": "plate"})) == folds
    ds = read_dataset(tmp_path / "c.nc", expect={"case": "plate", "stop": "mass_range"})
    assert ds.fold_mass_ratio.values.tolist() == [1.9, 2.6] and ds.sizes["point"] == 0


def test_a_threshold_on_a_traced_curve_is_recognised():
    """Seeds that find a curve already traced do not trace it again (1 % in U* at that m)."""
    from fsistab.neutral import MapCurve, NeutralPoint, _on_traced_curve

    points = tuple(
        NeutralPoint(m, u, 0.2, np.zeros(0), 0) for m, u in ((10.0, 1.0), (100.0, 2.0), (50.0, 3.0))
    )
    curve = MapCurve("flutter", 100.0, "onset", points, (), ("", ""))
    half = math.sqrt(10.0 * 100.0)  # log-midpoint of the first segment: U* = 1.5
    assert _on_traced_curve([curve], "flutter", half, 1.505)
    assert not _on_traced_curve([curve], "flutter", half, 1.6)
    assert not _on_traced_curve([curve], "viv", half, 1.5)
    # the folded part: at m = 70 the curve passes U* = 2 + (3 - 2) * log(100/70)/log(2)
    assert _on_traced_curve([curve], "flutter", 70.0, 2 + math.log(100 / 70) / math.log(2))
    assert not _on_traced_curve([curve], "flutter", 5.0, 1.0)


def test_map_from_one_seed_resumes_and_saves_everything(plate_operators, tmp_path):
    """One sweep at m = 1000 gives the flutter curve through U*_F, the divergence curve from the
    static moment slope; a second call reads the curves back (no new curve factorisations)."""
    from fsistab.linalg import FactorCounter
    from fsistab.neutral import Seed, neutral_map_dataset, trace_neutral_map
    from fsistab.slopes import static_slopes

    seed = Seed(1000.0, tuple(np.geomspace(4.0, 5.0, 3)))
    attrs = {"case": "test"}
    counter = FactorCounter()

    def trace():
        return trace_neutral_map(
            plate_operators,
            Solid(),
            [seed],
            tmp_path,
            "t",
            attrs,
            mass_range=(300, 3000),
            max_points=3,
            counter=counter,
        )

    first = trace()
    assert [c.kind for c in first.curves] == ["flutter"]
    curve = first.curves[0]
    masses = [p.mass_ratio for p in curve.points]
    assert masses == sorted(masses) and len(masses) == 5  # 2 points down, the seed, 2 points up
    seed_point = curve.points[2]
    assert seed_point.mass_ratio == 1000.0
    # neutral by the eigen-solver: λ = 0 with ω = ω_c at (m, U*_c)
    _assert_neutral(plate_operators, 1000.0, seed_point.reduced_velocity, seed_point.frequency)
    slope = static_slopes(plate_operators).moment
    assert first.moment_slope == pytest.approx(slope, rel=1e-10)
    assert np.allclose(
        first.divergence_velocities, divergence_curve(slope, 0.289, first.divergence_mass_ratios)
    )
    used = counter.count
    again = trace()
    assert [p.reduced_velocity for p in again.curves[0].points] == [p.reduced_velocity for p in curve.points]
    # only the sweep and the static slope again: no curve point recomputed
    from fsistab.critical import find_thresholds
    from fsistab.linalg import FluidFactor

    sweep = FactorCounter()
    static = FluidFactor(plate_operators, 0.0, sweep)  # shared by the map's sweeps and slope
    find_thresholds(
        plate_operators,
        Solid(reduced_velocity=4.0),
        np.array(seed.velocities),
        counter=sweep,
        static_factor=static,
    )
    static_slopes(plate_operators, sweep, factor=static)
    assert counter.count - used == sweep.count
    ds = neutral_map_dataset(again, attrs)
    assert ds.attrs["case"] == "test" and ds.sizes["point"] == 5
    assert np.allclose(ds.curve_reduced_velocity.values, [p.reduced_velocity for p in curve.points])
    assert np.allclose(ds.divergence_reduced_velocity.values, first.divergence_velocities)


def test_determinant_formulation_points_and_curve():
    """f(ω, v, p) = (ω² - p) + i(vω - 1): neutral points ω = √p, v = 1/√p. Held p = 4 gives (2, ½),
    held ω = 3 gives (v, p) = (⅓, 9); the curve through them keeps ω² = p and vω = 1."""
    from fsistab.continuation import continuation, newton
    from fsistab.neutral_point import DeterminantProblem

    def characteristic(y, gradient):
        omega, v, p = y
        value = complex(omega**2 - p, v * omega - 1)
        return (value, np.array([2 * omega + 1j * v, 1j * omega, -1.0])) if gradient else value

    problem = DeterminantProblem(characteristic)
    at_p = newton(problem.at(2, 4.0), [1.5, 0.8, 4.0], tol=1e-14)
    assert at_p.converged and at_p.point == pytest.approx([2.0, 0.5, 4.0], rel=1e-14)
    at_omega = newton(problem.at(0, 3.0), [3.0, 0.5, 7.0], tol=1e-14)
    assert at_omega.converged and at_omega.point == pytest.approx([3.0, 1 / 3, 9.0], rel=1e-14)
    # a general border (not a held component): the 3×3 system of F_y = [[2ω, 0, -1], [v, ω, 0]]
    y, border, rhs = np.array([1.5, 0.8, 4.0]), np.array([0.0, 0.6, 0.8]), np.array([0.1, -0.2, 0.3])
    delta = problem.solve(y, border, rhs, False)
    assert 2 * 1.5 * delta[0] - delta[2] == pytest.approx(0.1, rel=1e-14)
    assert 0.8 * delta[0] + 1.5 * delta[1] == pytest.approx(-0.2, rel=1e-14)
    assert border @ delta == pytest.approx(0.3, rel=1e-14)
    branch = continuation(problem.curve(), at_p.point, [0.0, 0.0, 1.0], step=0.2, max_points=15)
    omega, v, p = branch.points.T
    assert p[-1] > 6 and np.allclose(omega**2, p, rtol=1e-9) and np.allclose(v * omega, 1.0, rtol=1e-9)
