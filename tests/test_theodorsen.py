"""Analytic typical section with Theodorsen aerodynamics (docs/model.md §9, Theodorsen 1935; Hodges & Pierce;
Moulin & Marquet 2021).

Fast: no mesh, except the one CLI test of calibrated slopes (marked slow).
"""

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from fsistab.cli import app
from fsistab.errors import InputError
from fsistab.params import Solid
from fsistab.theodorsen import (
    AirfoilSlopes,
    TypicalSection,
    critical_points,
    divergence_velocity,
    divergence_velocity_from_determinant,
    flutter_determinant,
    flutter_points,
    load_matrices,
    lower_envelope,
    neutral_curves,
    pk_branches,
    pk_root,
    small_velocity_limit,
    theodorsen_function,
)

PLATE = TypicalSection.create(mass_ratio=1000.0)  # docs/model.md §2: Ω 0.8, ζ_h 0, ζ_θ 0.05, r_θ 0.289


# --- C(k), Theodorsen 1935, docs/validation.md
# ---------------------------------------------------------------------

TABLE_K = [0.05, 0.1, 0.2, 0.3, 0.5, 1.0, 2.0]
TABLE_F = [0.90901, 0.83192, 0.72758, 0.66497, 0.59794, 0.53943, 0.51295]
TABLE_G = [-0.13064, -0.17230, -0.18862, -0.17932, -0.15071, -0.10027, -0.05769]


def test_theodorsen_function_matches_the_table():
    c = theodorsen_function(np.array(TABLE_K))
    assert c.shape == (7,)
    assert np.max(np.abs(c.real - TABLE_F)) < 1e-5
    assert np.max(np.abs(c.imag - TABLE_G)) < 1e-5


def test_theodorsen_function_limits():
    assert theodorsen_function(0.0) == 1.0  # exactly
    assert abs(theodorsen_function(1e-12) - 1) < 1e-10
    assert abs(theodorsen_function(1e-300) - 1) == 0.0
    assert theodorsen_function(np.inf) == 0.5
    assert abs(theodorsen_function(1e6) - 0.5) < 1e-6
    # the asymptotic branch 1/2 - i/(8k) joins the Hankel functions
    below, above = theodorsen_function(np.array([0.999999e8, 1.000001e8]))
    assert abs(below - above) < 1e-14
    # both limits are approached monotonically in F
    k = np.geomspace(1e-6, 1e6, 200)
    f = theodorsen_function(k).real
    assert np.all(np.diff(f) < 0) and f[0] < 1 and f[-1] > 0.5
    # e^{-i|ω|t}: C(-k) = conj C(k)
    assert theodorsen_function(-0.3) == np.conj(theodorsen_function(0.3))
    with pytest.raises(InputError):
        theodorsen_function(np.nan)


# --- loads: the project's form is Theodorsen's textbook form in other conventions ---------------


def _textbook_loads(h, alpha, p, rho, speed, b, a_b, c_k):
    """Theodorsen (Bisplinghoff, Hodges & Pierce): h down, α nose-up, semi-chord b, elastic axis at
    a_b semi-chords aft of mid-chord; L up, M nose-up about the elastic axis; e^{pt} motion."""
    downwash = p * h + speed * alpha + b * (0.5 - a_b) * p * alpha
    lift = math.pi * rho * b**2 * (p * p * h + speed * p * alpha - b * a_b * p * p * alpha)
    lift += 2 * math.pi * rho * speed * b * c_k * downwash
    moment = (
        math.pi
        * rho
        * b**2
        * (
            b * a_b * p * p * h
            - speed * b * (0.5 - a_b) * p * alpha
            - b**2 * (1 / 8 + a_b**2) * p * p * alpha
        )
    )
    moment += 2 * math.pi * rho * speed * b**2 * (a_b + 0.5) * c_k * downwash
    return lift, moment


@pytest.mark.parametrize("elastic_axis", [0.0, -0.1, 0.2])
def test_loads_are_theodorsen_in_project_conventions(elastic_axis):
    rng = np.random.default_rng(1)
    section = TypicalSection.create(elastic_axis=elastic_axis)
    rho, speed, b = 1.2, 3.1, 0.37  # dimensional, arbitrary
    chord = 2 * b
    for _ in range(5):
        s = complex(*rng.normal(size=2))  # e^{st}, t in c/U
        c_k = complex(rng.uniform(0.5, 1), rng.uniform(-0.2, 0))
        h, theta = complex(*rng.normal(size=2)), complex(*rng.normal(size=2))
        l2, l1, l0 = load_matrices(section, c_k)
        cl, cm = (s * s * l2 + s * l1 + l0) @ np.array([h, theta])
        # h up in chords → h down dimensional; θ counter-clockwise → α = -θ; a in chords → a_b = 2a
        lift, moment = _textbook_loads(
            -h * chord, -theta, s * speed / chord, rho, speed, b, 2 * elastic_axis, c_k
        )
        q = 0.5 * rho * speed**2
        assert abs(cl - lift / (q * chord)) < 1e-12 * abs(cl)
        assert abs(cm - (-moment) / (q * chord**2)) < 1e-12 * abs(cm)  # C_M counter-clockwise


def test_added_mass_is_symmetric_and_thin_airfoil_moment_slope_about_the_elastic_axis():
    for a in (-0.3, 0.0, 0.25):
        section = TypicalSection.create(elastic_axis=a)
        l2 = load_matrices(section, 1.0)[0]
        assert l2[0, 1] == l2[1, 0]  # docs/model.md §9 prints (π/4) a h'': that would break this
        assert section.moment_slope_elastic_axis == pytest.approx(math.pi / 2 * (1 + 4 * a), rel=1e-14)


# --- Hodges & Pierce, Hodges & Pierce, docs/validation.md
# -----------------------------------------------------------


def _hodges_pierce_section():
    """Their conventions: semi-chord b, a and e in semi-chords aft of mid-chord, μ = m̃/(πρb²),
    r² = I_EA/(m̃b²), σ = ω_h/ω_θ, V = U/(bω_θ). Converted explicitly to the project's."""
    a, e, mu, r2, sigma = -1 / 5, -1 / 10, 20.0, 6 / 25, 2 / 5
    b, c = 0.5, 1.0  # chord c = 2b is the project's length unit
    mass = mu * math.pi * b**2  # m̃ with ρ = 1, per unit span
    return TypicalSection.create(
        mass_ratio=mass / (0.5 * c**2),  # m = m̃/(½ρc²) = πμ/2
        freq_ratio=sigma,
        zeta_h=0.0,
        zeta_theta=0.0,
        r_theta=math.sqrt(r2) * b / c,  # about the elastic axis, in chords
        elastic_axis=a * b / c,
        static_unbalance=(e - a) * b / c,  # x_θ = e - a semi-chords, centre of mass aft
    )


def test_hodges_pierce_flutter_and_divergence():
    section = _hodges_pierce_section()
    found = critical_points(section, (0.1, 10.0))
    flutter = [p for p in found if p.kind == "flutter"]
    divergence = [p for p in found if p.kind == "divergence"]
    assert len(flutter) == 1 and len(divergence) == 1
    speed_to_v = 2.0  # V = U/(bω_θ) = U* c/b
    v_f = speed_to_v * flutter[0].reduced_velocity
    assert abs(v_f - 2.18) < 0.005  # exact C(k): ≈ 2.18 (the book's 2.17 uses a rational C(k))
    assert 0.64 <= flutter[0].frequency * flutter[0].reduced_velocity <= 0.65
    assert flutter[0].boundary == "onset"
    assert speed_to_v * divergence[0].reduced_velocity == pytest.approx(2 * math.sqrt(2), rel=1e-13)
    assert speed_to_v * divergence_velocity_from_determinant(section) == pytest.approx(
        2 * math.sqrt(2), rel=1e-10
    )


# --- divergence ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("mass_ratio", "elastic_axis", "unbalance", "slopes"),
    [
        (1000.0, 0.0, 0.0, AirfoilSlopes()),
        (50.0, -0.1, 0.05, AirfoilSlopes()),
        (3.0, 0.1, -0.1, AirfoilSlopes.from_alpha(5.98, 1.562)),
    ],
)
def test_torsional_divergence_formula_is_the_root_of_the_static_determinant(
    mass_ratio, elastic_axis, unbalance, slopes
):
    section = TypicalSection.create(
        mass_ratio=mass_ratio, elastic_axis=elastic_axis, static_unbalance=unbalance, slopes=slopes
    )
    expected = math.sqrt(mass_ratio * 0.289**2 / slopes.moment_about(elastic_axis))  # docs/model.md §8
    assert divergence_velocity(section) == pytest.approx(expected, rel=1e-14)
    assert divergence_velocity_from_determinant(section) == pytest.approx(expected, rel=1e-10)


def test_no_divergence_when_the_moment_slope_about_the_axis_is_negative():
    section = TypicalSection.create(elastic_axis=-0.4)  # elastic axis ahead of the quarter chord
    assert section.moment_slope_elastic_axis < 0
    assert math.isnan(divergence_velocity(section))
    assert math.isnan(divergence_velocity_from_determinant(section))


# --- flutter boundaries -------------------------------------------------------------------------


def test_flutter_point_is_a_neutral_p_k_root():
    (point,) = flutter_points(PLATE)
    assert (
        abs(flutter_determinant(PLATE, point.frequency, point.reduced_velocity))
        < 1e-9 * (PLATE.mass_ratio * 0.289 * point.frequency) ** 2 * 4
    )
    sigma = pk_root(PLATE, point.reduced_velocity, 1j * point.frequency)
    assert abs(sigma - 1j * point.frequency) < 1e-9 * point.frequency
    below = pk_root(PLATE, point.reduced_velocity * 0.99, 1j * point.frequency)
    above = pk_root(PLATE, point.reduced_velocity * 1.01, 1j * point.frequency)
    assert below.real < 0 < above.real


def test_plate_thin_airfoil_at_m_1000_against_the_viscous_reference():
    """Moulin & Marquet 2021: the viscous plate at Re = 2900 flutters at U*_F ≈ 4.5 with ω ≈ Ω/U* and
    diverges at U*_D ≈ 7.4; the potential-flow section is a few per cent away."""
    found = critical_points(PLATE)
    assert [p.kind for p in found] == ["flutter", "divergence"]
    flutter, divergence = found
    assert abs(flutter.reduced_velocity - 4.5) / 4.5 < 0.05
    assert abs(flutter.frequency - 0.8 / flutter.reduced_velocity) / flutter.frequency < 0.05
    assert divergence.reduced_velocity == pytest.approx(math.sqrt(1000 * 0.289**2 / (math.pi / 2)), rel=1e-14)
    assert abs(divergence.reduced_velocity - 7.4) / 7.4 < 0.05


def test_several_boundaries_or_none():
    none = flutter_points(PLATE.with_mass_ratio(4.0), (0.01, 1e4))
    assert none == []  # below the critical mass ratio of the thin-airfoil plate
    section = TypicalSection.create(mass_ratio=50, freq_ratio=1.2, zeta_theta=0.2, static_unbalance=0.05)
    onset, restabilisation = flutter_points(section, (0.01, 100))
    assert (onset.boundary, restabilisation.boundary) == ("onset", "restabilisation")
    # p-k growth rate: unstable between the two boundaries only
    for velocity, unstable in [
        (0.9 * onset.reduced_velocity, False),
        (math.sqrt(onset.reduced_velocity * restabilisation.reduced_velocity), True),
        (1.1 * restabilisation.reduced_velocity, False),
    ]:
        ds = pk_branches(section, np.geomspace(0.05, velocity, 80))
        assert (ds.growth_rate.values[-1].max() > 0) == unstable


def test_flutter_points_do_not_depend_on_the_frequency_grid():
    section = _hodges_pierce_section()
    coarse = flutter_points(section, (0.1, 10), points_per_decade=50)
    fine = flutter_points(section, (0.1, 10), points_per_decade=1000)
    assert len(coarse) == len(fine) == 1
    assert coarse[0].reduced_velocity == pytest.approx(fine[0].reduced_velocity, rel=1e-10)
    assert coarse[0].frequency == pytest.approx(fine[0].frequency, rel=1e-10)


def test_high_mass_ratio_limit():
    """m → ∞ with U* = √m u: the circulatory damping and the moment's heave-rate coupling are
    O(m^-1/2) against the springs and static stiffness, so the heave root iΩ/U* + δ has (C → 1)
    ``2m δ = L'(1 + M'/D_θθ)``, ``D_θθ = (r_θ²/u²)(1 - Ω² + 2iζ_θΩ) - M'`` (L' = dC_L/dθ < 0,
    M' = dC_M/dθ). Hence Re δ > 0 for ``u² > r_θ²((1-Ω²)² + 4ζ_θ²Ω²)/((1-Ω²)M')``: the flutter
    boundary tends to ``U*_F = U*_D √((1-Ω²) + 4ζ_θ²Ω²/(1-Ω²))``, at the heave frequency,
    ``ω_F U*_F → Ω + U*_F Im δ``; the frequency itself, ``ω_F = O(m^-1/2)``, tends to zero
    (reduced frequency k → 0), not the ratio ω_F/ω_θ."""
    omega, zeta, r = 0.8, 0.05, 0.289
    lift, moment = -2 * math.pi, math.pi / 2
    beta = 1 - omega**2
    u_limit = r * math.sqrt((beta**2 + 4 * zeta**2 * omega**2) / (beta * moment))
    p = r**2 / u_limit**2
    d_theta = complex(beta * p - moment, 2 * zeta * omega * p)
    first_order = u_limit * (lift * moment * (1 / d_theta).imag / 2)  # ω_F U*_F - Ω ≈ first_order/√m
    results, residuals = {}, {}
    for m in (1e5, 1e6, 1e7):
        (point,) = flutter_points(PLATE.with_mass_ratio(m), (0.01, 1e4))
        results[m] = point
        correction = first_order / math.sqrt(m)
        residuals[m] = abs(point.frequency * point.reduced_velocity - omega - correction)
        assert residuals[m] < 0.5 * abs(correction)
        assert point.boundary == "onset"
    # the first-order term is the whole O(m^-1/2) deviation: what is left decays faster
    # (m^-1/2 would give a ratio 0.1 over two decades; O(log m / m) gives ~0.014)
    assert residuals[1e7] / residuals[1e5] < 0.05
    deviation = abs(results[1e7].reduced_velocity / math.sqrt(1e7) / u_limit - 1)
    assert deviation < 1e-3  # O(m^-1/2) = 3e-4 times a constant of order one
    assert results[1e7].frequency / results[1e5].frequency == pytest.approx(0.1, rel=0.01)
    # at m = 1000 the asymptote already gives the flutter boundary within a few per cent
    (at_1000,) = flutter_points(PLATE)
    assert abs(at_1000.reduced_velocity / (u_limit * math.sqrt(1000)) - 1) < 0.05


# --- p-k branches -------------------------------------------------------------------------------


def test_pk_branches_start_at_the_added_mass_corrected_solid_frequencies():
    limits = small_velocity_limit(PLATE)
    m, r2, zeta = 1000.0, 0.289**2, 0.05
    # heave: (m + π/2) Ŝ² + m Ω² = 0; pitch: (m r² + π/64) Ŝ² + 2 m r² ζ Ŝ + m r² = 0
    assert limits["heave"] == pytest.approx(0.8j * math.sqrt(m / (m + math.pi / 2)), abs=1e-14)
    inertia = m * r2 + math.pi / 64
    pitch = (-m * r2 * zeta + 1j * math.sqrt(inertia * m * r2 - (m * r2 * zeta) ** 2)) / inertia
    assert limits["pitch"] == pytest.approx(pitch, abs=1e-14)
    # Moulin & Marquet 2021 (m = 1000): 0.8i and -0.05 + 0.999i within the O(1/m) added mass
    assert abs(limits["heave"] - 0.8j) < 1e-3 and abs(limits["pitch"] - (-0.05 + 0.999j)) < 1e-3
    # in vacuo as m → ∞: iΩ and -ζ_θ + i√(1 - ζ_θ²)
    heavy = small_velocity_limit(PLATE.with_mass_ratio(1e9))
    assert abs(heavy["heave"] - 0.8j) < 1e-8
    assert abs(heavy["pitch"] - complex(-zeta, math.sqrt(1 - zeta**2))) < 1e-8
    # U* σ converges to the limits, linearly in U*
    errors = []
    for u in (1e-2, 1e-3):
        ds = pk_branches(PLATE, [u])
        sigma = ds.growth_rate.values[0] + 1j * ds.frequency.values[0]
        errors.append(max(abs(u * sigma[j] - limits[name]) for j, name in enumerate(ds.branch.values)))
    assert errors[1] < errors[0] / 5 and errors[1] < 1e-4


def test_pk_branches_cross_at_the_flutter_boundary():
    (flutter,) = flutter_points(PLATE)
    velocities = np.linspace(1.0, 7.0, 61)
    ds = pk_branches(PLATE, velocities)
    assert list(ds.branch.values) == ["heave", "pitch"] and ds.growth_rate.dims == (
        "reduced_velocity",
        "branch",
    )
    heave = ds.growth_rate.sel(branch="heave").values
    crossing = np.nonzero(np.diff(np.sign(heave)))[0]
    assert len(crossing) == 1
    assert velocities[crossing[0]] < flutter.reduced_velocity < velocities[crossing[0] + 1]
    assert np.all(ds.growth_rate.sel(branch="pitch").values < 0)


# --- neutral curves -----------------------------------------------------------------------------


def test_neutral_curves_dataset():
    masses = np.array([4.0, 100.0, 1000.0])
    ds = neutral_curves(PLATE, masses)
    assert ds.reduced_velocity.dims == ("mass_ratio", "boundary")
    assert np.isnan(ds.reduced_velocity.values[0]).all() and ds.onset.values[0, 0] == -1
    for i, m in enumerate(masses[1:], start=1):
        (point,) = flutter_points(PLATE.with_mass_ratio(m))
        assert ds.reduced_velocity.values[i, 0] == point.reduced_velocity
        assert ds.frequency.values[i, 0] == point.frequency
        assert ds.onset.values[i, 0] == 1
    assert np.allclose(ds.divergence_velocity.values, np.sqrt(masses * 0.289**2 / (math.pi / 2)), rtol=1e-14)
    for key in ("conventions", "freq_ratio", "zeta_theta", "r_theta", "elastic_axis", "static_unbalance"):
        assert key in ds.attrs
    assert "chord" in ds.attrs["conventions"] and "elastic axis" in ds.attrs["conventions"]


def test_lower_envelope_leaves_out_the_upper_part_of_a_folded_curve():
    folded = ([10.0, 5.0, 4.0, 5.0, 10.0], [1.0, 1.5, 3.0, 6.0, 9.0])
    assert lower_envelope([folded]) == [(4.0, 3.0), (5.0, 1.5), (10.0, 1.0)]


# --- bad input ----------------------------------------------------------------------------------

bad_positive = st.one_of(
    st.floats(max_value=0.0, allow_nan=False), st.just(math.nan), st.just(math.inf), st.just(-math.inf)
)


@settings(max_examples=40, deadline=None)
@given(value=bad_positive)
def test_bad_mass_ratio_or_velocity_is_refused(value):
    with pytest.raises(InputError):
        TypicalSection.create(mass_ratio=value)
    with pytest.raises(InputError):
        pk_root(PLATE, value, 0.1j)
    with pytest.raises(InputError):
        flutter_points(PLATE, (value, 10.0))
    with pytest.raises(InputError):
        flutter_determinant(PLATE, 0.1, value)


@settings(max_examples=40, deadline=None)
@given(value=st.one_of(st.just(math.nan), st.just(math.inf), st.floats(min_value=0.5, exclude_min=True)))
def test_bad_elastic_axis_or_unbalance_is_refused(value):
    with pytest.raises(InputError):
        TypicalSection.create(elastic_axis=value)
    with pytest.raises(InputError):
        TypicalSection.create(static_unbalance=value)  # |x_θ| must stay below r_θ = 0.289


def test_other_bad_sections():
    with pytest.raises(InputError, match="heave and pitch"):
        TypicalSection(Solid(dofs=("pitch",)))
    with pytest.raises(InputError, match="static unbalance"):
        TypicalSection.create(r_theta=0.2, static_unbalance=-0.2)
    with pytest.raises(InputError, match="lift slope"):
        AirfoilSlopes(lift=math.nan)
    with pytest.raises(InputError):
        pk_branches(PLATE, [2.0, 1.0])
    with pytest.raises(InputError):
        neutral_curves(PLATE, [0.0, 10.0])


# --- command line -------------------------------------------------------------------------------

runner = CliRunner()


def _run(args, tmp_path):
    return runner.invoke(
        app, ["theodorsen", *args, "--out", str(tmp_path / "out"), "--cache", str(tmp_path / "c")]
    )


def test_cli_table_and_json(tmp_path):
    result = _run(["--mass-ratio", "1000", "--slopes", "thin-airfoil"], tmp_path)
    assert result.exit_code == 0, result.output
    assert "flutter" in result.stdout and "divergence" in result.stdout and "onset" in result.stdout
    result = _run(["--mass-ratio", "1000", "--json"], tmp_path)
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)  # one JSON object and nothing else
    assert payload["mass_ratio"] == 1000
    expected = critical_points(PLATE)
    assert [p["kind"] for p in payload["critical_points"]] == [p.kind for p in expected]
    for got, want in zip(payload["critical_points"], expected, strict=True):
        assert got["reduced_velocity"] == want.reduced_velocity and got["frequency"] == want.frequency


def test_cli_elastic_axis_and_given_slopes(tmp_path):
    args = ["--json", "--slopes", "given", "--lift-slope-alpha", "5.98", "--moment-slope-alpha", "1.562"]
    result = _run([*args, "--elastic-axis", "-0.1", "--static-unbalance", "0.05"], tmp_path)
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    divergence = [p for p in payload["critical_points"] if p["kind"] == "divergence"]
    assert divergence[0]["reduced_velocity"] == pytest.approx(
        math.sqrt(1000 * 0.289**2 / (1.562 - 0.1 * 5.98)), rel=1e-13
    )
    assert payload["slopes"]["moment_slope_elastic_axis"] == pytest.approx(1.562 - 0.1 * 5.98, rel=1e-14)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--mass-ratio", "0"], "mass ratio must be positive"),
        (["--mass-ratio", "nan"], "mass ratio must be finite"),
        (["--slopes", "magic"], "unknown --slopes"),
        (["--slopes", "given", "--lift-slope-alpha", "6"], "needs both"),
        (["--lift-slope-alpha", "6"], "need --slopes given"),
        (["--static-unbalance", "0.3"], "static unbalance"),
        (["--elastic-axis", "0.7"], "elastic axis"),
        (["--reduced-velocity-range", "5", "1"], "--reduced-velocity-range"),
        (["--mass-ratio-range", "10", "1"], "--mass-ratio-range"),
        (["--zeta-theta", "-1"], "pitch damping ratio"),
    ],
)
def test_cli_bad_input_one_line_error(tmp_path, args, message):
    result = _run([*args, "--json"], tmp_path)
    assert result.exit_code == 2
    assert result.stdout == ""
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and message in lines[0]
    assert not (tmp_path / "out").exists()


def _write_viscous_curves(cache, factor):
    """Stand-in for `fsistab neutral`'s map stored in the cache (its map dataset, written by either
    method): the Theodorsen flutter boundary × factor."""
    from fsistab.neutral_map import NeutralCurve, NeutralMap, NeutralPoint, neutral_map_dataset
    from fsistab.store import write_dataset
    from fsistab.workflows import stored_map_path

    attrs = {"reynolds": 2900.0, "alpha0_deg": 0.0, "freq_ratio": 0.8, "zeta_h": 0.0, "zeta_theta": 0.05}
    attrs |= {"r_theta": 0.289}
    points = tuple(
        NeutralPoint(
            m, factor * flutter_points(PLATE.with_mass_ratio(m))[0].reduced_velocity, 0.2, mode=np.zeros(2)
        )
        for m in (100.0, 300.0, 1000.0, 3000.0)
    )
    curve = NeutralCurve(
        points, kind="flutter", seed_mass_ratio=1000.0, boundary="onset", stops=("m_bound", "m_bound")
    )
    masses = np.geomspace(10.0, 1e4, 20)
    result = NeutralMap((curve,), masses, np.sqrt(masses * 0.289**2 / 1.562), 1.562, (), 0)
    write_dataset(neutral_map_dataset(result, attrs), stored_map_path(cache, "plate_Re2900_a0"))


def test_cli_neutral_curves_and_viscous_comparison(tmp_path):
    out = tmp_path / "out"
    result = _run(["--mass-ratio-range", "10", "1000", "--points", "5", "--json"], tmp_path)
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert payload["comparison"] is None and len(payload["mass_ratio"]) == 5
    assert (out / "theodorsen_plate_Re2900_a0_thin-airfoil.nc").is_file()
    assert (out / "theodorsen_plate_Re2900_a0_thin-airfoil.png").stat().st_size > 10_000
    _write_viscous_curves(tmp_path / "c", factor=1.1)
    result = _run(["--mass-ratio-range", "10", "1e4", "--points", "5", "--json"], tmp_path)
    assert result.exit_code == 0, result.output
    comparison = json.loads(result.stdout)["comparison"]
    assert sorted(c["mass_ratio"] for c in comparison) == [100.0, 300.0, 1000.0, 3000.0]
    for c in comparison:
        assert c["relative_error"] == pytest.approx(1 / 1.1 - 1, rel=1e-9)
    result = _run(["--mass-ratio-range", "10", "1e4", "--points", "5"], tmp_path)
    assert result.exit_code == 0, result.output
    assert "relative error" in result.stdout
    # other solid parameters: no comparison
    result = _run(
        ["--mass-ratio-range", "10", "1e4", "--points", "3", "--zeta-theta", "0.1", "--json"], tmp_path
    )
    assert json.loads(result.stdout)["comparison"] is None


@pytest.mark.slow
def test_cli_calibrated_slopes_coarse_mesh(tmp_path):
    """Viscous slopes of docs/model.md §9 (coarse mesh, Re = 2900) in the Theodorsen model: close to the
    viscous thresholds of Moulin & Marquet 2021 (U*_F ≈ 4.5, U*_D ≈ 7.3–7.4)."""
    args = ["--mass-ratio", "1000", "--slopes", "calibrated", "--Re", "2900", "--mesh", "coarse", "--json"]
    result = _run(args, tmp_path)
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert payload["slopes"]["source"].startswith("viscous Re=2900")
    flutter, divergence = payload["critical_points"]
    assert abs(flutter["reduced_velocity"] - 4.5) / 4.5 < 0.05
    assert abs(divergence["reduced_velocity"] - 7.3) / 7.3 < 0.02
