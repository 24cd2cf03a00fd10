"""The root tracker of the transfer map: the neutral roots and the resultant's real roots
("tracks") at every sampled frequency, and how those of two neighbouring frequencies correspond
(docs/model.md §8).

Between two samples every neutral root is predicted at the other from its exact tangent in
``log ω`` (:func:`_match`); an interval is resolved when every root inside the mass range is matched
within the tolerance (:func:`_resolved`). The resultant's real roots, with their ``m`` of any sign,
show a curve that crosses the whole mass range inside one interval and leaves no root at either end
(:func:`_swept`, :func:`_side_jump`); a pair born outside the range on one side never entered it
(:func:`_born_outside`: young at the finest bisection, or its fold in ω placed inside the interval
by the tracks' rates, :func:`_pair_fold`). A neutral curve's own fold in ω is placed the same way,
from its pair of roots and their tangents (:func:`_neutral_fold`). :class:`RootTracker` holds the
roots and tracks by frequency; what to do about an interval is the refinement policy's
(:mod:`fsistab.map_refinement`).
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from fsistab.map_roots import (
    AxisSample,
    NeutralRoot,
    _roots_on_tracks,
    linear_solid,
    log_step,
    resultant_tracks,
    second_order_loads,
    track_rates,
)
from fsistab.params import Solid

SWEEP_STEP = 1e-5  # relative step down to which a curve crossing the mass range is looked for
YOUNG_PAIR = 0.05  # a pair of resultant roots this close in v (relative) was born just before (_born_outside)
# a pair's fold placed by its rates (_pair_fold) is trusted when the cubic term of its branch ω(v)
# is at most this share of the quadratic one, and the fold lies within this share of the interval
FOLD_CUBIC = 0.25
FOLD_INSIDE = 0.8
SAME_FREQUENCY = 1e-9  # two frequencies this close (relative) are one (saved grids, bisections)
_T = np.linspace(0.0, 1.0, 201)  # the branch parameter of a fold's Hermite interpolants, t ∈ [0, 1]
_BASIS = (2 * _T**3 - 3 * _T**2 + 1, _T**3 - 2 * _T**2 + _T, 3 * _T**2 - 2 * _T**3, _T**3 - _T**2)


class RootTracker:
    """The neutral roots (``m`` in ``wide``) and the resultant tracks
    (:func:`fsistab.map_roots.resultant_tracks`) at each frequency added, for the solid parameters
    of ``solid`` other than ``m`` and ``U*``; the fluid's steady angle ``theta0`` and loads
    ``loads0`` turn a sample's ``G`` into the loads ``A``."""

    def __init__(self, solid: Solid, wide: tuple[float, float], theta0: float, loads0: np.ndarray):
        self.solid, self.wide = linear_solid(solid, theta0), wide  # W at θ0 (docs/model.md §3.1)
        self.theta0, self.loads0 = theta0, loads0
        self.roots: dict[float, list[NeutralRoot]] = {}
        self.tracks: dict[float, np.ndarray] = {}
        self.rates: dict[float, np.ndarray] = {}

    def knows(self, omega: float) -> bool:
        """Whether ``omega`` was added already, up to rounding (``SAME_FREQUENCY``)."""
        return any(abs(omega - w) <= SAME_FREQUENCY * omega for w in self.roots)

    def add(self, sample: AxisSample) -> None:
        """The tracks and the neutral roots of one sample (ω > 0)."""
        omega = sample.frequency
        loads, rate = second_order_loads(sample, self.theta0, self.loads0)
        self.tracks[omega] = resultant_tracks(loads, omega, self.solid)
        self.rates[omega] = track_rates(self.tracks[omega], loads, rate, omega, self.solid)
        self.roots[omega] = _roots_on_tracks(self.tracks[omega], loads, rate, omega, self.solid, self.wide)

    @property
    def grid(self) -> list[float]:
        """The frequencies added, in increasing order."""
        return sorted(self.roots)

    def resolved(self, w0: float, w1: float, tolerance: float, inner: tuple[float, float]) -> bool:
        """Whether every root in ``inner`` at ``w0`` and ``w1`` is matched within ``tolerance``."""
        return _resolved(self.roots[w0], self.roots[w1], log_step(w0, w1), tolerance, inner)

    def fold(self, w0: float, w1: float) -> bool:
        """Whether a pair of roots of the range (or of the resultant's real roots) is born or dies
        together between ``w0`` and ``w1``: a fold in ω, which no step resolves."""
        roots, tracks = self.roots, self.tracks
        return min(abs(len(roots[w0]) - len(roots[w1])), abs(len(tracks[w0]) - len(tracks[w1]))) >= 2

    def swept(self, w0: float, w1: float, settled: bool = False) -> bool:
        """:func:`_swept` between the tracks at ``w0`` and ``w1``, on the followed range."""
        return _swept(self.tracks[w0], self.tracks[w1], self.wide, settled)

    def born_outside(self, w0: float, w1: float, young: bool = False) -> bool:
        """:func:`_born_outside` between the tracks at ``w0`` and ``w1``, on the followed range: by
        the pair's fold (:func:`_pair_fold`) at any step, and also as a pair close together in v
        if ``young`` (the interval is at the finest bisection)."""
        left, right = self.tracks[w0], self.tracks[w1]
        fold = (w0, w1, self.rates[w0], self.rates[w1])
        at_fold = _born_outside(left, right, self.wide, fold)
        return at_fold or (young and _born_outside(left, right, self.wide))

    def placed_fold(
        self, w0: float, w1: float, tolerance: float, inner: tuple[float, float]
    ) -> tuple[float, float, float] | None:
        """The fold in ω of a neutral curve inside ``[w0, w1]``, placed by its pair, as ``(the
        pair's frequency, the fold's offset from it, the chord between the pair in (log m,
        log U*))``; None unless every root is matched within ``tolerance`` but two at one end (none
        of ``inner`` at the other), both of the pair are matched to the sample beyond that end (so
        the pair is close enough to the fold for its tangents, which go as ``1/√(ω − ω_b)``, to be
        resolved), and their exact tangents place the fold inside the interval
        (:func:`_neutral_fold`, within ``FOLD_INSIDE`` of its width). The curve is joined through
        the fold between the pair, along the same kind of interpolant
        (:class:`fsistab.transfer_map.TransferCurve`)."""
        grid, (left, right) = self.grid, (self.roots[w0], self.roots[w1])
        matches = _match(left, right, log_step(w0, w1), tolerance)
        free_left = [i for i in range(len(left)) if i not in {i for i, _, _ in matches}]
        free_right = [j for j in range(len(right)) if j not in {j for _, j, _ in matches}]
        inside = lambda roots, free: any(inner[0] <= roots[k].mass_ratio <= inner[1] for k in free)  # noqa: E731
        k0, k1 = grid.index(w0), grid.index(w1)
        if len(free_left) == 2 and not inside(right, free_right) and k0 > 0:
            at, pair, sign = w0, [left[i] for i in free_left], 1.0
            beyond = _match(self.roots[grid[k0 - 1]], left, log_step(grid[k0 - 1], w0), tolerance)
            ends = {j for _, j, _ in beyond} >= set(free_left)
        elif len(free_right) == 2 and not inside(left, free_left) and k1 + 1 < len(grid):
            at, pair, sign = w1, [right[j] for j in free_right], -1.0
            beyond = _match(right, self.roots[grid[k1 + 1]], log_step(w1, grid[k1 + 1]), tolerance)
            ends = {i for i, _, _ in beyond} >= set(free_right)
        else:
            return None
        offset = _neutral_fold(*pair)
        if not ends or offset is None or not 0 < sign * offset <= FOLD_INSIDE * (w1 - w0):
            return None
        return at, offset, float(np.linalg.norm(pair[1].plane - pair[0].plane))

    def leaves(self, omega: float, inner: tuple[float, float]) -> bool:
        """:func:`_leaves` at the frequency ``omega``."""
        return _leaves(self.roots[omega], inner)


def _side(m: float, band: tuple[float, float]) -> int:
    """Where a resultant root's ``m`` lies: -1 at ``m ≤ 0``, 0 below ``band``, 1 in it, 2 above."""
    return -1 if m <= 0 else 0 if m < band[0] else 1 if m <= band[1] else 2


def _born(left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """Of two frequencies' resultant tracks, the longer, the shorter and the rows of the longer that
    are born or die in between: each root of the shorter is the nearest in ``v`` of the longer."""
    longer, shorter = (left, right) if len(left) > len(right) else (right, left)
    free = list(range(len(longer)))
    for v, _ in shorter:
        free.remove(min(free, key=lambda i: abs(longer[i, 0] - v)))
    return longer, shorter, free


def _swept(left: np.ndarray, right: np.ndarray, band: tuple[float, float], settled: bool = False) -> bool:
    """Whether a pair of real resultant roots is born or dies between two frequencies, or a root
    (matched by nearest ``v``) passes from one side of ``band`` to the other, or through
    ``m = 0``/``∞``, without being in the band at either frequency, or (unless ``settled``) a root
    changed sides other than across an edge of the band, matched or not (:func:`_side_jump`).
    ``settled``: the two
    frequencies are ``SWEEP_STEP`` apart, too close for a root to go round through the band, so a
    root that changes sign beyond the band at both (``|m| > band[1]``) passes through ``m = ∞``,
    one below it at both (``|m| < band[0]``) through ``m = 0``, and roots born or dying all on one
    side of the band (outside it) were born or died there: none of these is a sweep."""

    if len(left) != len(right):  # real roots born or dying in between
        if not settled:
            return True
        longer, _, free = _born(left, right)
        sides = {_side(m, band) for m in longer[free, 1]}
        if len(sides) > 1 or 1 in sides:
            return True
    elif not settled and _side_jump(left, right, band):
        # a root changed sides other than across an edge of the band, matched below or not: a
        # curve near-vertical in ω moves fast in v too (on the plate at Re 2900 with a resolved far
        # wake, from v = 1.21, m = −36.8 to v = 2.30, m = 0.91 in 0.017 of ω, through m = ∞ and
        # the whole band: a VIV curve within ω 11.25–11.26)
        return True
    for v, m in left:
        if not len(right):
            return False
        k = int(np.argmin(np.abs(right[:, 0] - v)))
        if abs(right[k, 0] - v) > 0.25 * v:
            continue
        a, b = _side(m, band), _side(right[k, 1], band)
        if a != b and 1 not in (a, b):
            low, high = sorted((abs(m), abs(right[k, 1])))
            if settled and (low > band[1] or high < band[0]):
                continue  # through ∞ or 0 next to where it was: a pole of the neutral mass
            return True
    return False


def _side_jump(left: np.ndarray, right: np.ndarray, band: tuple[float, float]) -> bool:
    """Whether the sides (:func:`_side`) of two frequencies' resultant roots differ by more than
    roots entering or leaving ``band`` across its edges (below ↔ in, in ↔ above), whichever root is
    whose: a root that went from ``m < 0`` into the band, or from one side of it to the other, went
    through ``m = 0`` or ``∞`` and may have crossed the whole band."""
    lost = Counter(_side(m, band) for m in left[:, 1])
    gained = Counter(_side(m, band) for m in right[:, 1])
    lost, gained = lost - gained, gained - lost
    for a, b in ((0, 1), (1, 0), (1, 2), (2, 1)):  # across an edge: the band's roots are matched
        k = min(lost[a], gained[b])
        lost[a] -= k
        gained[b] -= k
    return bool(+lost or +gained)


def _born_outside(left: np.ndarray, right: np.ndarray, band: tuple[float, float], fold=None) -> bool:
    """Whether the only change between two frequencies is a pair of real resultant roots born (or
    dying) on one side outside ``band``, close together at the frequency where they exist
    (``|Δv| ≤ YOUNG_PAIR v``), with every other root matched and not sweeping (:func:`_swept`);
    or, given ``fold = (w0, w1, left rates, right rates)`` (:func:`fsistab.map_roots.track_rates`),
    not close but with the fold placed inside the interval by the pair's rates and the branch
    between its two roots outside ``band`` on one side (:func:`_fold_outside`).

    A pair is born where the track folds in ``ω`` (a double real root): from there both roots move
    as ``√(ω − ω_b)`` to leading order, in ``v`` and in ``m``, so between the birth and the sample
    where they exist their ``m`` stay between the two values there. A young pair that lies outside
    the band on one side there never entered it: no curve to look for. This settles an interval at
    ``min_step`` instead of bisecting it down to ``SWEEP_STEP`` (a chain of samples that finds
    nothing)."""
    if abs(len(left) - len(right)) != 2:
        return False
    longer, shorter, free = _born(left, right)
    (v1, m1), (v2, m2) = longer[free]
    if fold is not None:
        w0, w1, left_rates, right_rates = fold
        born = len(right) > len(left)
        rates = (right_rates if born else left_rates)[free]
        if not _fold_outside(longer[free], rates, w1 - w0, born, band):
            return False
    elif abs(v1 - v2) > YOUNG_PAIR * max(v1, v2):
        return False
    side = _side(m1, band)
    if side != _side(m2, band) or side == 1:
        return False
    kept = np.delete(longer, free, axis=0)
    return not _swept(shorter, kept, band)


def _fold_frequency(width: float, rate_a: float, rate_b: float) -> float | None:
    """A branch through a fold in ω, seen from one sampled frequency at two points ``width`` apart
    in a parameter ``x`` along it that moves at ``rate_a``, ``rate_b`` (``dx/dω``) there: the
    extreme of the cubic Hermite of ``ω(x)`` on ``t ∈ [0, 1]`` (``_T``; zero at both ends, slopes
    ``dω/dx``), the fold's offset from the sample (< 0: the fold lies below it). None if the two
    are not one fold resolved by its ends: rates of one sign (no extreme between), a cubic term
    above ``FOLD_CUBIC`` of the quadratic one, or a rate that could not be formed.

    Near a fold ``ω(x)`` is smooth with an extreme while ``x(ω)`` goes as ``√(ω − ω_b)``: in ``x``
    the branch between the pair is one segment, resolved by its ends as a neutral curve is by its
    tangents (:func:`_match`)."""
    if not np.all(np.isfinite([rate_a, rate_b])) or width <= 0 or rate_a * rate_b >= 0:
        return None
    slope_a, slope_b = width / rate_a, width / rate_b  # dω/dt, x = x_a + t width
    if abs(slope_a + slope_b) > FOLD_CUBIC * abs(slope_b - slope_a):
        return None
    omega = _BASIS[1] * slope_a + _BASIS[3] * slope_b
    return float(omega.min() if slope_a < 0 else omega.max())


def _pair_fold(pair: np.ndarray, rates: np.ndarray) -> tuple[float, float, float] | None:
    """A pair of resultant roots at one frequency (rows ``(v, m)``) and their rates (rows
    ``(dv/dω, dε/dω)``, ``ε = 1/m``) as the two sides of one branch through a fold in ω
    (:func:`_fold_frequency` in ``x = v``), with the cubic Hermite of ``ε(v)`` on the same segment.
    Returns the fold's offset from the sample (< 0 for a pair born below the sample, > 0 for one
    dying above it) and the lowest and highest ``ε`` on the segment, or None (no resolved fold).
    ``ε`` is smooth along the branch even through ``m = ∞``."""
    order = np.argsort(pair[:, 0])
    (va, ma), (vb, mb) = pair[order]
    (dva, dea), (dvb, deb) = rates[order]
    width = vb - va
    offset = _fold_frequency(width, dva, dvb)
    if offset is None or not np.all(np.isfinite(rates)):
        return None
    h00, h10, h01, h11 = _BASIS
    eps = h00 / ma + h10 * dea * width / dva + h01 / mb + h11 * deb * width / dvb
    return offset, float(eps.min()), float(eps.max())


def _neutral_fold(a: NeutralRoot, b: NeutralRoot) -> float | None:
    """Two neutral roots at one frequency as the two sides of a neutral curve through a fold in ω
    (:func:`_fold_frequency`, the parameter along the chord from ``a`` to ``b`` in
    ``(log m, log U*)``, its rates the exact tangents projected on the chord): the fold's offset
    from the sample, or None. The curve itself is joined through the fold by
    :class:`fsistab.transfer_map.TransferCurve` between the same two roots."""
    chord = b.plane - a.plane
    width = float(np.linalg.norm(chord))
    if width == 0:
        return None
    return _fold_frequency(width, float(chord @ a.tangent) / width, float(chord @ b.tangent) / width)


def _fold_outside(pair: np.ndarray, rates: np.ndarray, step: float, born: bool, band) -> bool:
    """Whether a pair of resultant roots that exists at one end of an interval ``step`` wide (the
    upper end if ``born``) comes from a fold in ω inside it (:func:`_pair_fold`: on the side
    where the pair does not exist, within ``FOLD_INSIDE`` of the width), with the branch between
    its roots on one side outside ``band`` (``ε = 1/m`` of one sign, ``m`` on one side)."""
    fold = _pair_fold(pair, rates)
    if fold is None:
        return False
    offset, low, high = fold
    if (offset >= 0 if born else offset <= 0) or abs(offset) > FOLD_INSIDE * step:
        return False
    if low <= 0 <= high:
        return False  # through m = ∞ (or ε = 0 touched): both sides of the band's upper end
    sides = {_side(1 / low, band), _side(1 / high, band)}
    return len(sides) == 1 and 1 not in sides


def _match(
    left: list[NeutralRoot], right: list[NeutralRoot], step: float, limit: float
) -> list[tuple[int, int, float]]:
    """Pairs ``(i, j, d)`` of roots at two adjacent frequencies ``step`` apart in ``log ω``
    (:func:`log_step`), ``d`` the larger of the two tangent predictions' errors (∞-norm in
    ``(log m, log U*)``), greedy by ``d`` below ``limit``."""
    pairs = []
    for i, a in enumerate(left):
        for j, b in enumerate(right):
            forward = np.abs(a.plane + step * a.log_tangent - b.plane).max()
            backward = np.abs(b.plane - step * b.log_tangent - a.plane).max()
            pairs.append((max(forward, backward), i, j))
    used_left, used_right, matches = set(), set(), []
    for d, i, j in sorted(pairs):
        if d < limit and i not in used_left and j not in used_right:
            used_left.add(i)
            used_right.add(j)
            matches.append((i, j, d))
    return matches


def _resolved(left, right, step, tolerance, inner) -> bool:
    """Every root inside ``inner`` (a mass range) on either side is matched within ``tolerance``."""
    matches = _match(left, right, step, tolerance)
    done_left = {i for i, _, _ in matches}
    done_right = {j for _, j, _ in matches}
    need = lambda roots, done: all(  # noqa: E731
        k in done or not inner[0] <= r.mass_ratio <= inner[1] for k, r in enumerate(roots)
    )
    return need(left, done_left) and need(right, done_right)


def _leaves(roots: list[NeutralRoot], inner: tuple[float, float]) -> bool:
    """Whether a curve crosses the end of the sampled range at one of ``roots`` (those at the
    lowest or highest frequency): a root with its mass inside ``inner``."""
    return any(inner[0] <= r.mass_ratio <= inner[1] for r in roots)
