"""The outflow condition (fsistab.params.OUTLETS, docs/model.md §4 "Outlet"): the gradient outlet's
boundary term against the identity it rests on, the operators against finite differences of the
residual that contains it, the steady state and the march on it, and the keys that keep results
with either outlet apart."""

import dataclasses

import numpy as np
import pytest

from fsistab.bodies import Cylinder, Plate
from fsistab.coupled import CoupledResidual, CoupledSystem
from fsistab.errors import InputError
from fsistab.forces import reaction_loads
from fsistab.mesh import build_mesh, mesh_spec
from fsistab.operators import FluidResidual, fluid_operators
from fsistab.params import Flow, Solid
from fsistab.simulation import InertialFluidResidual
from fsistab.steady import outlet_integral, solve_steady, steady_key, taylor_hood_space


def _with_outlet(spec, outlet):
    return dataclasses.replace(spec, outlet=outlet)


@pytest.fixture(scope="module")
def gradient_40(cylinder_coarse_40):
    """The cylinder at Re 40 (coarse) with the gradient outlet, by Newton from the stress outlet's."""
    spec = _with_outlet(cylinder_coarse_40.mesh_spec, "gradient")
    return solve_steady(spec, Flow(40), initial=cylinder_coarse_40)


def _applied(form, space, values):
    from ngsolve import BilinearForm, GridFunction

    bilinear = BilinearForm(space)
    bilinear += form
    state, result = GridFunction(space), GridFunction(space)
    state.vec.FV().NumPy()[:] = values
    bilinear.Apply(state.vec, result.vec)
    return result.vec.FV().NumPy().copy()


def test_outlet_term_turns_the_stress_condition_into_the_gradient_one():
    """For a divergence-free linear ``U = (y, 2x)`` (exact in P2 on straight elements, ∇U constant
    and not symmetric) and every test
    function that vanishes off the outlet (the free dofs), ``(Re⁻¹(∇U + ∇Uᵀ), ∇v)`` plus the outlet
    term equals ``(Re⁻¹∇U, ∇v)``: ``(∇Uᵀ, ∇v) = ∫_∂Ω (∇Uᵀn)·v − (∇(∇·U), v)``. Without the term
    the two differ on the outlet's rows."""
    from ngsolve import CF, Grad, GridFunction, InnerProduct, dx, x, y

    mesh = build_mesh(mesh_spec(Plate(), "coarse", 100, curve_order=1))
    space = taylor_hood_space(mesh)
    (u, _), (v, _) = space.TnT()
    inv_reynolds = 0.01
    field = space.components[0]
    velocity = GridFunction(field)
    velocity.Set(CF((y, 2 * x)))
    values = np.zeros(space.ndof)
    values[: field.ndof] = velocity.vec.FV().NumPy()
    free = np.array(list(space.FreeDofs()), dtype=bool)
    free[field.ndof :] = False  # the momentum rows

    stress = inv_reynolds * InnerProduct(Grad(u) + Grad(u).trans, Grad(v)) * dx
    gradient = _applied(inv_reynolds * InnerProduct(Grad(u), Grad(v)) * dx, space, values)[free]
    with_outlet = _applied(stress + outlet_integral("gradient", u, v, inv_reynolds), space, values)[free]
    without = _applied(stress, space, values)[free]
    assert np.abs(with_outlet - gradient).max() < 1e-12 * np.abs(gradient).max()
    assert np.abs(without - gradient).max() > 1e-3 * np.abs(gradient).max()
    assert outlet_integral("stress", u, v, inv_reynolds) is None


def test_gradient_outlet_operators_match_finite_differences(gradient_40):
    """``J`` with the gradient outlet minus ``J`` with the stress outlet, at the gradient outlet's
    steady state, against central differences of the two residuals along directions of the fluid
    unknowns near the outlet (the only rows the term touches), and the residual's equilibrium."""
    steady = gradient_40
    stress = dataclasses.replace(steady, mesh_spec=_with_outlet(steady.mesh_spec, "stress"))
    solid = Solid(mass_ratio=5.0, reduced_velocity=5.0, dofs=("heave",))
    plain = CoupledSystem(fluid_operators(stress), solid)
    other = CoupledSystem(fluid_operators(steady), solid)
    residuals = CoupledResidual(plain), CoupledResidual(other)
    q0 = residuals[1].point()
    assert np.abs(residuals[1](q0)).max() < 1e-10  # the gradient outlet's equilibrium
    assert np.abs(residuals[0](q0)).max() > 1e-6  # not the stress outlet's
    difference = (other.jacobian - plain.jacobian).tocsr()
    rows = np.unique(difference.nonzero()[0])
    assert 0 < len(rows) < 0.05 * plain.size  # the outlet's rows alone
    rng = np.random.default_rng(5)
    direction = np.zeros(plain.size)
    direction[rows] = rng.standard_normal(len(rows))
    direction[: plain.n_solid] = 0.0
    eps = 1e-5
    plus, minus = q0 + eps * direction, q0 - eps * direction
    fd = (residuals[1](plus) - residuals[0](plus) - residuals[1](minus) + residuals[0](minus)) / (2 * eps)
    exact = difference @ direction
    assert np.linalg.norm(exact) > 1e-3 * np.linalg.norm(plain.jacobian @ direction)
    assert np.linalg.norm(fd - exact) < 1e-7 * np.linalg.norm(exact)


def test_gradient_outlet_steady_state_and_march_residual(gradient_40, cylinder_coarse_40):
    """The steady state with the gradient outlet differs from the stress outlet's at the outlet,
    its drag by little (the outlet is 100 diameters behind the cylinder); the march's residual
    (compiled, :class:`InertialFluidResidual`) is the operators' residual, outlet term included."""
    drag = {s.mesh_spec.outlet: reaction_loads(s)["force_x"] for s in (gradient_40, cylinder_coarse_40)}
    assert drag["gradient"] != drag["stress"]
    assert abs(drag["gradient"] / drag["stress"] - 1) < 1e-3
    states = [s.state.vec.FV().NumPy() for s in (gradient_40, cylinder_coarse_40)]
    assert np.abs(states[0] - states[1]).max() > 1e-6
    march, residual = InertialFluidResidual(gradient_40), FluidResidual(gradient_40)
    march.set_rate(0.0, np.zeros(march.mass.shape[0]))
    q_solid, q_fluid = residual.steady_point()
    q_fluid = q_fluid + 1e-3 * np.random.default_rng(2).standard_normal(q_fluid.shape)
    expected, _ = residual(q_solid, q_fluid)
    found, _ = march(q_solid, q_fluid)
    assert np.abs(found - expected).max() < 1e-12 * np.abs(expected).max()
    stress, _ = FluidResidual(cylinder_coarse_40)(q_solid, q_fluid)
    assert np.abs(stress - expected).max() > 1e-6


def test_outlet_keys_and_refusal():
    """The default outlet keeps every key it had; the gradient outlet has its own steady key and
    linear identity, not its own mesh; an unknown outlet is refused in one line."""
    spec = mesh_spec(Cylinder(), "coarse", 40)
    gradient = _with_outlet(spec, "gradient")
    assert gradient.key() == spec.key()
    assert "outlet" not in spec.linear_identity() and spec.linear_key() == spec.key()
    assert gradient.linear_identity()["outlet"] == "gradient"
    assert gradient.linear_key() != spec.linear_key()
    assert steady_key(gradient, Flow(40)) != steady_key(spec, Flow(40))
    assert mesh_spec(Cylinder(), "coarse", 40, outlet="gradient") == gradient
    with pytest.raises(InputError, match="unknown outlet condition 'free'"):
        mesh_spec(Cylinder(), "coarse", 40, outlet="free")


def test_outlet_option(tmp_path, gradient_40, cylinder_coarse_40):
    """``--outlet gradient`` reaches the steady state (the library's, said in the output); an
    unknown outlet is refused in one line before any work."""
    import json

    from typer.testing import CliRunner

    from fsistab.cli import app
    from fsistab.forces import aerodynamic_coefficients

    runner = CliRunner()
    base = ["steady", "--body", "cylinder", "--Re", "40", "--mesh", "coarse", "--json"]
    files = ["--out", str(tmp_path / "out"), "--cache", str(tmp_path / "cache")]
    result = runner.invoke(app, [*base, "--outlet", "gradient", *files])
    assert result.exit_code == 0, result.output
    found = json.loads(result.stdout)
    assert found["outlet"] == "gradient"
    drag = {s.mesh_spec.outlet: aerodynamic_coefficients(s).drag for s in (gradient_40, cylinder_coarse_40)}
    assert abs(found["drag_coefficient"] - drag["gradient"]) < 1e-8 < abs(drag["gradient"] - drag["stress"])
    before = sorted((tmp_path / "cache").rglob("*"))
    refused = runner.invoke(app, [*base, "--outlet", "free", *files])
    assert refused.exit_code != 0
    assert "unknown outlet condition 'free'" in refused.output
    assert sorted((tmp_path / "cache").rglob("*")) == before


def test_reynolds_tangent_with_the_gradient_outlet_matches_steady_states(gradient_40):
    """``dq⁰/dRe`` (:func:`fsistab.sensitivity.flow_tangent`, (S2)) with the gradient outlet, whose
    term is ``Re⁻¹``-weighted too, against the central difference of its steady states at
    Re 40 ± 0.2 (Newton from Re 40), on the free dofs near the outlet and everywhere."""
    from fsistab.sensitivity import flow_tangent

    steady, step = gradient_40, 0.2
    tangent = flow_tangent(fluid_operators(steady), "reynolds").steady_tangent
    sides = [solve_steady(steady.mesh_spec, Flow(40 + s * step), initial=steady) for s in (-1, 1)]
    difference = (sides[1].state.vec.FV().NumPy() - sides[0].state.vec.FV().NumPy()) / (2 * step)
    free = np.array(list(steady.space.FreeDofs()), dtype=bool)
    error = np.abs(tangent - difference)[free].max()
    assert error < 1e-4 * np.abs(difference[free]).max()
