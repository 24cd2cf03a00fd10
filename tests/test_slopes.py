"""Static slopes (docs/model.md §9) against finite differences of steady solutions at α0 ± δ."""

import math

import pytest

from fsistab.bodies import Plate
from fsistab.forces import aerodynamic_coefficients
from fsistab.linalg import FactorCounter
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow
from fsistab.slopes import static_slopes
from fsistab.steady import solve_steady


@pytest.mark.parametrize("alpha0", [0.0, 4.0])
def test_slopes_match_finite_differences_of_steady_states(alpha0):
    spec = mesh_spec(Plate(), "coarse", 200)
    base = solve_steady(spec, Flow(200, alpha0))
    counter = FactorCounter()
    slopes = static_slopes(fluid_operators(base), counter)
    assert counter.count == 1  # one factorisation of J_ff
    delta = 0.05  # degrees
    plus = aerodynamic_coefficients(solve_steady(spec, Flow(200, alpha0 + delta), initial=base))
    minus = aerodynamic_coefficients(solve_steady(spec, Flow(200, alpha0 - delta), initial=base))
    d_theta = -2 * math.radians(delta)  # θ = -α
    assert slopes.lift == pytest.approx((plus.lift - minus.lift) / d_theta, rel=1e-4)
    assert slopes.moment == pytest.approx((plus.moment - minus.moment) / d_theta, rel=1e-4)
    if alpha0 == 0:
        assert abs(slopes.drag) < 1e-10  # drag is even in α
    else:
        assert slopes.drag == pytest.approx((plus.drag - minus.drag) / d_theta, rel=1e-3)
    # viscous slopes are below the thin-airfoil values at Re = 200, and of the same sign
    assert 0.4 * 2 * math.pi < slopes.lift_slope_alpha < 2 * math.pi
    assert 0.4 * math.pi / 2 < slopes.moment_slope_alpha < math.pi / 2


def test_slopes_command_prints_json_and_draws_the_figure(tmp_path, monkeypatch):
    import json

    from typer.testing import CliRunner

    from fsistab.cli import app

    monkeypatch.setenv("FSISTAB_CACHE", str(tmp_path / "cache"))
    args = ["slopes", "--Re", "2900", "1000", "--mesh", "coarse", "--out", str(tmp_path), "--json"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert [s["reynolds"] for s in payload["slopes"]] == [1000.0, 2900.0]
    for entry in payload["slopes"]:
        # viscous slopes lie below the thin-airfoil values, by a few per cent at these Re
        assert 0.85 * 2 * math.pi < entry["lift_slope_alpha"] < 2 * math.pi
        assert 0.85 * math.pi / 2 < entry["moment_slope_alpha"] < 1.05 * math.pi / 2
    assert (tmp_path / "slopes_plate_a0_coarse.png").is_file()
