"""Neutral curves by pseudo-arclength (docs/model.md §8), plate, Re = 2900, coarse mesh."""

import math

import numpy as np
import pytest

from fsistab.coupled import CoupledSystem
from fsistab.critical import flutter_point, mass_derivative
from fsistab.eigen import eigenpairs_near
from fsistab.errors import InputError
from fsistab.neutral import continue_neutral_curve
from fsistab.neutral_map import divergence_curve
from fsistab.neutral_point import divergence_velocity
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
    assert len(curve.points) == 4 and len(saved) == 3 and curve.stops[-1] == "max_points"
    m, u = curve.mass_ratios, curve.reduced_velocities
    assert np.all(np.diff(m) < 0) and np.all(
        np.diff(u) < 0
    )  # U*_F falls with m (Moulin & Marquet 2021 trend)
    # every point is neutral: the eigen-solver finds λ = 0 at (m, U*_c) with ω = ω_c
    last = curve.points[-1]
    _assert_neutral(plate_operators, last.mass_ratio, last.reduced_velocity, last.frequency)


def test_flutter_curve_passes_its_turning_point_in_m(plate_operators):
    """On the coarse mesh the flutter curve traced from m = 1000 towards small m turns back in m a
    little below m = 600 (docs/model.md §8: the continuation must pass turning points). Started at
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
    """U*_D = √(m r_θ²/(dC_M/dθ)) (docs/model.md §8): thin-airfoil slope π/2, m = 4, r_θ = 1/2 gives
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
    from fsistab.neutral_map import curve_crossings

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
    from fsistab.neutral_map import curve_crossings

    folded = [[2.0, 1.0], [0.0, 2.0], [2.0, 3.0]]  # turns back in log m at (0, 2)
    line = [[1.0, 0.0], [1.0, 4.0]]  # log m = 1

    def fail(*_):
        raise ConvergenceError("no convergence")

    crossings = curve_crossings(folded, line, fail)
    assert [(c.segments, c.refined) for c in crossings] == [((0, 0), False), ((1, 0), False)]
    assert [c.reduced_velocity for c in crossings] == pytest.approx([1.5, 2.5])
    assert all(c.mass_ratio == pytest.approx(math.e) for c in crossings)


def test_turning_points_are_stored_with_the_curve(tmp_path):
    from fsistab.neutral import curve_table, saved_turning_points
    from fsistab.neutral_map import TurningPoint
    from fsistab.store import read_dataset

    folds = [
        TurningPoint(1.9, 4.9, 0.21, index=1, localised=True),
        TurningPoint(2.6, 5.2, 0.22, index=4, localised=False),
    ]
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
    from fsistab.neutral import _on_traced_curve
    from fsistab.neutral_map import NeutralCurve, NeutralPoint

    points = tuple(
        NeutralPoint(m, u, 0.2, mode=np.zeros(0), iterations=0)
        for m, u in ((10.0, 1.0), (100.0, 2.0), (50.0, 3.0))
    )
    curve = NeutralCurve(points, kind="flutter", seed_mass_ratio=100.0, boundary="onset", stops=("", ""))
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
    from fsistab.neutral import Seed, trace_neutral_map
    from fsistab.neutral_map import neutral_map_dataset
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


# --- map outputs (issue 14, item 4) ----------------------------------------------------------------


def _curve(kind, pairs, frequencies):
    from fsistab.neutral_map import NeutralCurve, NeutralPoint

    points = tuple(
        NeutralPoint(m, u, w, mode=np.zeros(0), iterations=0)
        for (m, u), w in zip(pairs, frequencies, strict=True)
    )
    return NeutralCurve(points, kind=kind, seed_mass_ratio=math.nan, boundary="onset", stops=("", ""))


def test_crossings_of_known_lines_are_found_at_the_analytic_points():
    """In (log m, U*): a flutter line U* = 4 and the divergence curve U*_D = r_θ √(m/s) cross at
    log m = 2 log(4 √s/r_θ) (exact with the divergence formula, whatever the grid); a VIV line
    U* = 1 + (log m)/4 crosses the flutter line at log m = 12 and divergence where
    1 + μ/4 = r_θ e^{μ/2}/√s; a curve folded in m (a V opening to larger m) crosses divergence
    twice; a loop crosses itself. Each crossing carries both kinds' frequencies, interpolated
    (0 on divergence)."""
    from fsistab.neutral_map import map_crossings

    slope, r_theta = math.pi / 2, 0.289
    masses = np.geomspace(1.0, 1e7, 40)  # a coarse grid: the refinement puts crossings on the formula
    divergence = divergence_curve(slope, r_theta, masses)
    mu = np.linspace(0.0, 16.0, 9)
    flutter = _curve("flutter", [(math.exp(x), 4.0) for x in mu], 0.2 + 0.01 * mu)
    viv = _curve("viv", [(math.exp(x), 1 + x / 4) for x in mu], 10.8 + 0.001 * mu)
    # folded in m: from (e^6, 1) back to (e^2, 2) and out again to (e^6, 3) (turning point in m)
    folded = _curve("flutter", [(math.exp(6), 1.0), (math.exp(2), 2.0), (math.exp(6), 3.0)], [0.3, 0.4, 0.5])
    loop = _curve("flutter", [(1e2, 30.0), (1e4, 40.0), (1e4, 30.0), (1e2, 40.0)], [1.0, 2.0, 3.0, 4.0])
    crossings = map_crossings([flutter, viv, folded, loop], masses, divergence, r_theta, slope)
    by_pair = {}
    for c in crossings:
        by_pair.setdefault((c.first, c.second), []).append(c)
    (fd,) = by_pair[(0, -1)]
    exact = 2 * math.log(4 * math.sqrt(slope) / r_theta)
    assert math.log(fd.crossing.mass_ratio) == pytest.approx(exact, abs=1e-12) and fd.crossing.refined
    assert fd.frequencies == pytest.approx((0.2 + 0.01 * exact, 0.0), abs=1e-12)
    (fv,) = by_pair[(0, 1)]
    assert math.log(fv.crossing.mass_ratio) == pytest.approx(12.0, abs=1e-12)
    assert fv.crossing.reduced_velocity == pytest.approx(4.0, abs=1e-12)
    assert fv.frequencies == pytest.approx((0.32, 10.812), abs=1e-12)
    (vd,) = by_pair[(1, -1)]
    x = math.log(vd.crossing.mass_ratio)
    assert 1 + x / 4 == pytest.approx(r_theta * math.exp(x / 2) / math.sqrt(slope), abs=1e-12)
    twice = by_pair[(2, -1)]
    assert len(twice) == 2
    for c in twice:
        x = math.log(c.crossing.mass_ratio)
        assert c.crossing.reduced_velocity == pytest.approx(r_theta * math.exp(x / 2) / math.sqrt(slope))
    (own,) = by_pair[(3, 3)]
    assert own.crossing.mass_ratio == pytest.approx(1e3) and own.crossing.reduced_velocity == pytest.approx(
        35.0
    )
    assert own.frequencies == pytest.approx((1.5, 3.5))
    assert (1, 0) not in by_pair and (0, 0) not in by_pair  # each pair once, no self-crossing of a line


def test_unstable_sides_follow_the_role_through_a_turning_point():
    """Synthetic growth rate Re σ = μ − (U* − 2)² (μ = log m): the neutral curve μ = (U* − 2)²
    turns in m at U* = 2. Traced from U* = 3.5 down to 0.5 with its seed on the lower branch
    (an onset: unstable above it), the sides from the role are, at every point, the change of the
    number of unstable modes (1 where Re σ > 0) across the curve along U*: −1 on the upper branch,
    +1 on the lower one."""
    from fsistab.neutral_map import sides_from_role

    velocities = np.linspace(3.5, 0.5, 31)
    velocities = velocities[np.abs(velocities - 2) > 1e-9]  # not the turning point itself
    plane = np.column_stack([(velocities - 2) ** 2, velocities])
    seed = int(np.argmin(np.abs(velocities - 1.0)))

    def count(log_mass, velocity):
        return int(log_mass - (velocity - 2) ** 2 > 0)

    sides = sides_from_role(plane, seed, "onset")
    expected = [count(x, u + 1e-6) - count(x, u - 1e-6) for x, u in plane]
    assert list(sides) == expected and set(expected) == {-1, 1}
    assert sides_from_role(plane, seed, "restabilisation") == tuple(-s for s in sides)
    upper = int(np.argmin(np.abs(velocities - 3.0)))  # a seed where log m falls along the order
    assert sides_from_role(plane, upper, "restabilisation") == sides
    with pytest.raises(InputError):
        sides_from_role(plane, seed, "both")


def test_curve_kind_needs_no_wake_frequency():
    """Flutter follows the solid's frequency (heavy: U* = 0.2 √m and ω U* = 0.8 along the curve,
    following 1); a VIV window stays at the wake frequency while U* grows by 30 % (following 0.1);
    a lock-in boundary at constant U* whose frequency moves by 1 % while m grows by 60 % is VIV
    through ½ Δ log m (0.04); the threshold is 1/2; one point cannot be measured: flutter."""
    from fsistab.neutral_map import curve_kind, frequency_following

    m = np.geomspace(100.0, 1e4, 10)
    u = 0.2 * np.sqrt(m)
    assert frequency_following(m, u, 0.8 / u) == pytest.approx(1.0, rel=1e-12)
    assert curve_kind(m, u, 0.8 / u) == "flutter"
    v = np.linspace(0.067, 0.088, 10)
    w = 10.69 * (v / 0.067) ** -0.1
    light = np.linspace(1.0, 1.2, 10)  # ½ Δ log m = 0.09 < Δ log U* = 0.27
    assert frequency_following(light, v, w) == pytest.approx(0.1, rel=1e-12)
    assert curve_kind(light, v, w) == "viv"
    boundary = np.geomspace(1.0, 1.6, 10)
    w = np.geomspace(10.4, 10.4 * 1.01, 10)
    flat = np.full(10, 0.083)
    following = frequency_following(boundary, flat, w)
    assert following == pytest.approx(math.log(1.01) / (0.5 * math.log(1.6)), rel=1e-12)
    assert curve_kind(boundary, flat, w) == "viv"
    assert curve_kind(m, u, u**-0.49) == "viv" and curve_kind(m, u, u**-0.51) == "flutter"
    assert (
        math.isnan(frequency_following([1.0], [2.0], [3.0])) and curve_kind([1.0], [2.0], [3.0]) == "flutter"
    )


def test_map_outputs_carry_kinds_sides_crossings_and_unresolved_intervals():
    """The NetCDF dataset and the JSON of a map: per point the unstable side, per curve the kind
    and frequency following, per crossing both kinds and frequencies, per unresolved interval its
    range and reason, and their count; a map with none says so."""
    from fsistab import payloads, workflows
    from fsistab.neutral_map import NeutralMap, map_crossings, neutral_map_dataset
    from fsistab.params import MapSettings

    mu = np.linspace(0.0, 8.0, 5)
    flutter = _curve("flutter", [(math.exp(x), 2.0) for x in mu], [0.3] * 5)
    viv = _curve("viv", [(math.exp(x), 1 + x / 4) for x in mu], [10.8] * 5)
    flutter = flutter.__class__(**{**flutter.__dict__, "unstable_sides": (1, 1, 1, -1, -1)})
    masses = np.geomspace(1.0, 3000.0, 20)
    divergence = divergence_curve(1.5, 0.289, masses)
    crossings = map_crossings([flutter, viv], masses, divergence, 0.289, 1.5)
    attrs = {"wake_frequency": math.nan, "method": "transfer"}

    def outputs(unresolved):
        result = NeutralMap((flutter, viv), masses, divergence, 1.5, crossings, 3, unresolved)
        ds = neutral_map_dataset(result, attrs)
        ds = workflows._map_details(ds, result, None, MapSettings())
        ds = ds.assign_attrs(factorisations_this_run=3, reduced_models=0, data="m.nc", figure="m.png")
        return ds, payloads.payload("neutral", ds)

    ds, payload = outputs(((10.5, 10.6, "budget"), (11.0, 11.001, "fold")))
    assert ds.curve_kind.values.tolist() == ["flutter", "viv"]
    assert ds.curve_unstable_side.values.tolist() == [1, 1, 1, -1, -1] + [0] * 5
    assert payload["curves"][0]["unstable_side"] == [1, 1, 1, -1, -1]
    assert [c["kind"] for c in payload["curves"]] == ["flutter", "viv"]
    (fv,) = [c for c in payload["codimension_two"] if c["curves"] == ["flutter 0", "viv 1"]]
    assert fv["kinds"] == ["flutter", "viv"] and fv["frequencies"] == [0.3, 10.8]
    assert fv["mass_ratio"] == pytest.approx(math.e**4) and fv["reduced_velocity"] == pytest.approx(2.0)
    assert {tuple(c["kinds"]) for c in payload["codimension_two"]} == {
        ("flutter", "viv"),
        ("flutter", "divergence"),
        ("viv", "divergence"),
    }
    assert payload["unresolved"] == [
        {"frequency_range": [10.5, 10.6], "reason": "budget"},
        {"frequency_range": [11.0, 11.001], "reason": "fold"},
    ]
    assert payload["unresolved_count"] == 2 and ds.unresolved_reason.values.tolist() == ["budget", "fold"]
    ds, payload = outputs(())
    assert payload["unresolved"] == [] and payload["unresolved_count"] == 0 and ds.sizes["unresolved"] == 0
