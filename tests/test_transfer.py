"""Aerodynamic transfer functions (fsistab.transfer): exact elimination of the fluid, its derivative,
the rational approximation and its linearisation, the viscous Theodorsen function."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from fsistab.cli import app
from fsistab.coupled import CoupledSystem
from fsistab.critical import flutter_point
from fsistab.eigen import eigenpairs_near
from fsistab.errors import InputError
from fsistab.linalg import FluidFactor
from fsistab.operators import fluid_operators
from fsistab.params import Solid
from fsistab.slopes import static_slopes
from fsistab.theodorsen import theodorsen_function
from fsistab.transfer import (
    TransferFunction,
    _solid_parts,
    aaa,
    aerodynamic_loads,
    characteristic_matrix,
    coupled_eigenvalues,
    default_frequencies,
    exact_transfer,
    sample_transfer,
    transfer_flutter_point,
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
    """G(0) is the quasi-static response: the pitch column of the loads gives MODEL.md §9's slopes."""
    fluid = request.getfixturevalue(fixture)
    factor = FluidFactor(fluid, 0.0)  # one factorisation of J_ff serves both
    loads = aerodynamic_loads(exact_transfer(fluid, 0.0, factor=factor), fluid.theta0, fluid.loads0, 0.0)
    slopes = static_slopes(fluid, factor=factor)
    assert loads[0, 1] == pytest.approx(slopes.lift, rel=1e-10)
    assert loads[1, 1] == pytest.approx(slopes.moment, rel=1e-10)
    assert np.abs(loads[:, 0]).max() < 1e-12  # translation invariance: a steady heave changes nothing


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
    """Newton on det T(iω; U*) = 0 (4 × 4) and on the augmented sparse system (MODEL.md §8) find the
    same neutral point, and the former converges quadratically."""
    solid = Solid(1000.0, 4.5)
    point = transfer_flutter_point(plate_operators, solid, 0.18)
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


def test_aaa_recovers_theodorsen_function():
    """Theodorsen's C(k) (a branch cut on the negative real s axis) is smooth on the imaginary axis:
    AAA on s = iω, k = ω/2 reproduces it between samples."""
    omega = np.geomspace(1e-3, 40.0, 120)
    values = theodorsen_function(omega / 2)[:, None, None] * np.ones((1, 3, 4))
    fit = aaa(np.concatenate([1j * omega, -1j * omega]), np.concatenate([values, values.conj()]), 1e-13)
    test = np.random.default_rng(1).uniform(2e-3, 35.0, 50)
    error = np.abs(fit(1j * test)[:, 0, 0] - theodorsen_function(test / 2)).max()
    assert error < 1e-8
    assert len(fit.support) < 60


def test_rational_model_eigenvalues_match_a_state_space_realisation():
    """With G(s) = G0 + R/(s - p) + conj(R)/(s - p̄) (exactly rational), the eigenvalues of the
    linearised T(σ) equal those of the equivalent state-space pencil; poles of G are not returned."""
    rng = np.random.default_rng(7)
    g0 = rng.normal(size=(3, 4))
    g0[:, 0] = 0.0
    u, v = rng.normal(size=3) + 1j * rng.normal(size=3), rng.normal(size=4) + 1j * rng.normal(size=4)
    v[0] = 0.0
    pole = -0.1 + 2.0j
    theta0, loads0 = 0.0, np.array([0.3, 0.0, 0.0])

    def transfer(s):
        return g0 + np.outer(u, v) / (s - pole) + np.outer(u.conj(), v.conj()) / (s - pole.conjugate())

    omega = np.linspace(0.0, 10.0, 80)
    tf = TransferFunction(
        omega, np.array([transfer(1j * w) for w in omega]), loads0, theta0, {"tolerance": 1e-10}
    )
    assert np.abs(tf(0.3 + 1.7j) - transfer(0.3 + 1.7j)).max() < 1e-8
    solid = Solid(mass_ratio=2.0, reduced_velocity=1.5)
    p0, coupling, a = _solid_parts(solid, theta0, loads0)
    n = len(a)
    # x' part: (P0 - E G0 + sI) x - E u ξ1 - E ū ξ2 = 0,  (s - p) ξ1 = vᵀx,  (s - p̄) ξ2 = v̄ᵀx
    k0 = np.zeros((n + 2, n + 2), dtype=complex)
    k0[:n, :n] = p0 - coupling @ g0[:, a]
    k0[:n, n] = -coupling @ u
    k0[:n, n + 1] = -coupling @ u.conj()
    k0[n, :n], k0[n, n] = -v[a], -pole
    k0[n + 1, :n], k0[n + 1, n + 1] = -v.conj()[a], -pole.conjugate()
    expected = np.linalg.eigvals(-k0)
    expected = np.sort_complex(expected[expected.imag >= -1e-9])
    found = np.sort_complex(coupled_eigenvalues(tf, solid, radius=50.0))
    assert len(found) == len(expected)
    assert np.abs(found - expected).max() < 1e-7


def test_sampled_transfer_reports_its_prediction_errors(plate_operators):
    """Adaptive sampling stops at max_samples and records a measured error for every added sample."""
    tf = sample_transfer(plate_operators, omega_max=2.0, tolerance=1e-6, max_samples=12)
    assert len(tf.frequencies) == 12
    assert len(tf.attrs["prediction_errors"]) == 12 - 10
    assert tf.attrs["factorisations"] == 12
    exact = exact_transfer(plate_operators, 1j * tf.frequencies[3])
    assert np.abs(tf(1j * tf.frequencies[3]) - exact).max() < 1e-8 * np.abs(exact).max()


def test_bad_input_is_refused_before_any_factorisation(plate_operators):
    with pytest.raises(InputError, match="tolerance"):
        sample_transfer(plate_operators, tolerance=2.0)
    with pytest.raises(InputError, match="largest frequency"):
        default_frequencies(-1.0)


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
