"""The outlet sponge of the linear operators (fsistab.params.Sponge): its terms against finite
differences of the nonlinear residual that contains it, its target against the turned steady field,
and the keys that keep results with and without it apart."""

import dataclasses
import json
import math

import ngsolve
import numpy as np
import pytest
from jacobian_checks import difference_matches_finite_differences

from fsistab.bodies import Plate
from fsistab.coupled import CoupledResidual, CoupledSystem
from fsistab.errors import InputError
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators, rotation_target, sponge_coefficient
from fsistab.params import Case, Domain, Solid, Sponge, parse_sponge
from fsistab.sensitivity import AdjointMode, base_flow_gradient
from fsistab.steady import steady_key
from fsistab.transfer import flow_identity

# strong and long on coarse's 40-chord outlet, so that its terms are not lost among the others
SPONGE = Sponge(sigma_max=1.0, zone=0.5)
# with a strong far-field layer over a short ramp (placed by _layered)
LAYER = Sponge(sigma_max=1.0, zone=0.5, far_sigma=1.0, far_ramp=3.0)


def _with_sponge(steady, sponge=SPONGE):
    return dataclasses.replace(steady, mesh_spec=dataclasses.replace(steady.mesh_spec, sponge=sponge))


def _layered(steady, sponge):
    """``steady`` with ``sponge`` and a middle box ``[-5, 10] × [-5, 5]`` and band ``[0, 40] × [-2, 2]``
    given to its sizes: they only place the far-field layer (the mesh is the steady state's), so
    that on coarse's domain the layer covers most of it and its terms are not lost among the others."""
    spec = steady.mesh_spec
    sizes = dataclasses.replace(spec.sizes, middle=1.0, middle_box=(5.0, 10.0, 5.0), middle_band=(40.0, 2.0))
    return dataclasses.replace(steady, mesh_spec=dataclasses.replace(spec, sizes=sizes, sponge=sponge))


@pytest.fixture(scope="module")
def sponged(plate_2900_alpha5):
    """Plate at Re 2900, α0 = 5 (coarse): the systems without and with the sponge."""
    solid = Solid(mass_ratio=3.0, reduced_velocity=2.0)
    plain = CoupledSystem(fluid_operators(plate_2900_alpha5), solid)
    return plain, CoupledSystem(fluid_operators(_with_sponge(plate_2900_alpha5)), solid)


def _difference_matches_finite_differences(plain, other):
    """``other.jacobian − plain.jacobian`` against central differences of their residuals
    (:func:`jacobian_checks.difference_matches_finite_differences`); the difference is returned."""
    residuals = CoupledResidual(plain), CoupledResidual(other)
    return difference_matches_finite_differences(plain, other, residuals, seed=3)


def test_sponge_terms_match_finite_differences(sponged):
    """``J`` with the sponge minus ``J`` without it against central differences of the residuals
    with and without ``σ (U − U⁰ − (θ − θ0) u_θ)``: every block, the θ column included."""
    plain, with_sponge = sponged
    difference = _difference_matches_finite_differences(plain, with_sponge)
    # the θ column's sponge part is the rotation target, nothing else
    theta = np.zeros(plain.size)
    theta[1] = 1.0
    assert np.linalg.norm(difference @ theta) > 0


def test_far_layer_terms_match_finite_differences(plate_2900_alpha5):
    """The far-field layer's part of ``J`` (the sponge with the layer minus the outlet sponge alone)
    against central differences of the residuals that contain ``σ_far (U − U⁰ − (θ − θ0) u_θ)``.
    Coarse mesh (``[-20, 40] × [-20, 20]``) with a middle box ``[-5, 10] × [-5, 5]`` and band
    ``[0, 40] × [-2, 2]`` given to its sizes (they only place the layer here; the mesh is coarse's),
    so that the layer covers most of the domain and its terms are not lost among the others."""
    solid = Solid(mass_ratio=3.0, reduced_velocity=2.0)

    def system(sponge):
        return CoupledSystem(fluid_operators(_layered(plate_2900_alpha5, sponge)), solid)

    outlet, layer = system(SPONGE), system(LAYER)
    difference = _difference_matches_finite_differences(outlet, layer)
    theta = np.zeros(outlet.size)
    theta[1] = 1.0
    assert np.linalg.norm(difference @ theta) > 0  # the layer's target turns with the body too


def test_the_march_s_iteration_matrix_carries_the_far_layer(plate_2900_alpha5):
    """The time march rebuilds ``J_ff`` by NGSolve's automatic differentiation of the residual's
    form (:meth:`fsistab.operators.FluidResidual.linearisation`), where ``σ_far``'s distance to the
    middle box must stay finite inside the box (a square root at 0 gave NaN there). At a pitching,
    heaving state off the steady flow, with the layer of the test above: finite, and equal to a
    central difference of the residual (quadratic in the fluid state: exact to round-off), of
    which the layer is a visible part."""
    from fsistab.operators import FluidResidual

    layer, outlet = (FluidResidual(_layered(plate_2900_alpha5, sponge)) for sponge in (LAYER, SPONGE))
    rng = np.random.default_rng(5)
    q_solid, fluid0 = np.array([0.1, 0.12, 0.05, 0.03]), layer.steady_point()[1]
    q_fluid = fluid0 + 1e-2 * rng.standard_normal(fluid0.size)
    direction, eps, index = rng.standard_normal(fluid0.size), 1e-4, layer.index

    def jff(form):
        return form.linearisation(q_solid, form.full_state(q_solid, q_fluid))[index][:, index]

    found = jff(layer)
    assert np.isfinite(found.data).all()
    plus, minus = (layer(q_solid, q_fluid + sign * eps * direction)[0] for sign in (1, -1))
    difference = (plus - minus) / (2 * eps)
    scale = np.max(np.abs(difference))
    assert np.max(np.abs(found @ direction - difference)) < 1e-8 * scale
    assert np.max(np.abs((found - jff(outlet)) @ direction)) > 1e-3 * scale


def test_rotation_target_is_the_turned_steady_field(plate_2900_alpha5):
    """``u_θ = d/dδ [R(δ)ᵀ U⁰(R(δ) X)]`` at δ = 0, by central differences at points of the wake."""
    steady = plate_2900_alpha5
    mesh, base, target = steady.mesh, steady.velocity, rotation_target(steady)
    delta = 1e-4
    checked = 0
    for x, y in [(2.0, 0.3), (6.0, -0.2), (12.0, 0.5), (25.0, 0.8), (3.0, 2.0)]:
        turned = []
        for d in (delta, -delta):
            c, s = math.cos(d), math.sin(d)
            value = np.array(base(mesh(c * x - s * y, s * x + c * y)))
            turned.append(np.array([c * value[0] + s * value[1], -s * value[0] + c * value[1]]))
        fd = (turned[0] - turned[1]) / (2 * delta)
        exact = np.array(target(mesh(x, y)))
        assert np.linalg.norm(fd - exact) < 1e-3 * max(np.linalg.norm(exact), 1e-3), (x, y, fd, exact)
        checked += np.linalg.norm(exact) > 1e-3
    assert checked >= 3


def test_sponge_profile(plate_2900):
    """``σ = 0`` before ``X_s = (1 − zone) X_out``, ``σ_max`` at the outlet, ``σ_max/2`` midway,
    uniform in ``Y``."""
    steady = _with_sponge(plate_2900, Sponge(0.3, 0.25))
    sigma, mesh = sponge_coefficient(steady), steady.mesh
    assert sponge_coefficient(plate_2900) is None
    assert sigma(mesh(29.0, 0.0)) == 0.0
    assert sigma(mesh(40.0, 5.0)) == pytest.approx(0.3, rel=1e-12)
    assert sigma(mesh(35.0, 0.0)) == pytest.approx(0.15, rel=1e-12)
    assert sigma(mesh(35.0, 10.0)) == pytest.approx(0.15, rel=1e-12)
    assert 0 < sigma(mesh(32.0, 0.0)) < 0.15


def test_base_flow_gradient_with_a_sponge_matches_finite_differences(sponged):
    """``∂(q†ᴴ J q)/∂q⁰`` for any pair of vectors (the formula is bilinear in them) against central
    differences of operators re-assembled about a perturbed steady state, the sponge's target
    ``θ̂ u_θ(U⁰)`` included."""
    plain, system = sponged
    steady = system.fluid.steady
    rng = np.random.default_rng(4)
    q = rng.standard_normal(system.size) + 1j * rng.standard_normal(system.size)
    adjoint = rng.standard_normal(system.size) + 1j * rng.standard_normal(system.size)
    mode = AdjointMode(0j, q, adjoint, 0.0, 0.0, 0j, 0.0, 0, 0j)
    gradient = base_flow_gradient(system, mode)
    index = system.fluid.free_dofs
    # a smooth perturbation of the base velocity, inside the sponge (X > 20) only
    field = ngsolve.GridFunction(steady.space)
    x, y = ngsolve.x, ngsolve.y
    ramp = ngsolve.IfPos(x - 20, (x - 20) / 20, 0)
    field.components[0].Set(ngsolve.CF((ramp * ngsolve.sin(y), 0.5 * ramp * ngsolve.cos(y))))
    direction = np.zeros(steady.space.ndof)
    direction[index] = 1e-2 * field.vec.FV().NumPy()[index]
    eps = 1e-3

    def bilinear(sign):
        state = ngsolve.GridFunction(steady.space)
        state.vec.data = steady.state.vec
        state.vec.FV().NumPy()[:] += sign * eps * direction
        fluid = fluid_operators(dataclasses.replace(steady, state=state))
        return np.conj(adjoint) @ (CoupledSystem(fluid, system.solid).jacobian @ q)

    fd = (bilinear(1) - bilinear(-1)) / (2 * eps)
    exact = gradient @ direction[index]
    assert abs(fd - exact) < 1e-6 * abs(exact)
    # the sponge's own part is not negligible: without it the gradient is different
    without = base_flow_gradient(CoupledSystem(plain.fluid, system.solid), mode) @ direction[index]
    assert abs(without - exact) > 1e-2 * abs(exact)


def test_sponge_keys_linear_results_apart(plate_2900):
    plain, sponged = plate_2900, _with_sponge(plate_2900)
    assert sponged.mesh_spec.key() == plain.mesh_spec.key()  # the mesh is the same
    assert steady_key(sponged.mesh_spec, sponged.flow) == steady_key(plain.mesh_spec, plain.flow)
    assert sponged.mesh_spec.linear_identity() != plain.mesh_spec.linear_identity()
    assert sponged.mesh_spec.linear_key() != plain.mesh_spec.linear_key()
    assert json.loads(sponged.mesh_spec.linear_identity()["sponge"]) == {"sigma_max": 1.0, "zone": 0.5}
    identities = [flow_identity(fluid_operators(s)) for s in (plain, sponged)]
    assert identities[0] != identities[1]


def test_preset_sponges():
    """The converged plate presets carry a sponge on their own domain, none on another domain;
    ``coarse`` and the cylinder carry none."""
    medium = mesh_spec(Plate(), "medium", 2900)
    assert medium.sponge == Sponge(0.2, 0.25, far_sigma=0.2, far_ramp=10.0)
    assert medium.sponge.start(medium.domain) == 120.0
    assert mesh_spec(Plate(), "medium", 2900, Domain(40, 80, 40)).sponge is None
    assert mesh_spec(Plate(), "medium", 2900, Domain(40, 80, 40), sponge=Sponge(0.2, 0.5)).sponge.zone == 0.5
    assert mesh_spec(Plate(), "medium", 2900, sponge=None).sponge is None
    assert mesh_spec(Plate(), "coarse", 2900).sponge is None
    case = Case.create("plate", 2900, preset="medium", sponge="none")
    assert case.sponge is None


@pytest.mark.parametrize(
    ("text", "expected"),
    [("preset", "preset"), ("none", None), (" 0.1,0.3 ", Sponge(0.1, 0.3)), ("NONE", None)],
)
def test_parse_sponge(text, expected):
    assert parse_sponge(text) == expected


@pytest.mark.parametrize("text", ["0.2", "0.2,0.25,1", "-1,0.25", "0.2,0.8", "abc,0.2", "0,0.25"])
def test_parse_sponge_refuses_bad_input(text):
    with pytest.raises(InputError):
        parse_sponge(text)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("0.2,0.25,0.3,8", Sponge(0.2, 0.25, far_sigma=0.3, far_ramp=8.0)),
        ("0.2,0.25,0,10", Sponge(0.2, 0.25)),
    ],
)
def test_parse_sponge_with_far_layer(text, expected):
    assert parse_sponge(text) == expected


@pytest.mark.parametrize("text", ["0.2,0.25,-0.1,10", "0.2,0.25,0.2,0", "0.2,0.25,0.2", "0.2,0.25,0.2,10,1"])
def test_parse_sponge_refuses_bad_far_layer(text):
    with pytest.raises(InputError):
        parse_sponge(text)


def test_far_layer_keys_and_meshes():
    """Without a far-field layer the sponge's key is what it was before the layer existed (cached
    results keep their keys); with one, the key differs; a mesh without a middle box refuses it."""
    medium = mesh_spec(Plate(), "medium", 2900, sponge=Sponge(0.2, 0.25))
    assert json.loads(medium.linear_identity()["sponge"]) == {"sigma_max": 0.2, "zone": 0.25}
    far = mesh_spec(Plate(), "medium", 2900)
    assert json.loads(far.linear_identity()["sponge"]) == {
        "sigma_max": 0.2,
        "zone": 0.25,
        "far_sigma": 0.2,
        "far_ramp": 10.0,
    }
    assert far.linear_key() != medium.linear_key()
    with pytest.raises(InputError, match="middle box"):
        mesh_spec(Plate(), "coarse", 2900, sponge=Sponge(0.2, 0.25, far_sigma=0.2))


def test_far_layer_profile():
    """``σ_far`` is 0 in the middle box and the band, ``far_sigma`` beyond ``far_ramp`` of them, and
    the smooth step ``3t² − 2t³`` of the distance to the nearer of the two in between."""
    from netgen.occ import OCCGeometry, Rectangle

    from fsistab.operators import far_layer

    sizes = mesh_spec(Plate(), "medium", 2900).sizes
    assert sizes.middle_box == (40.0, 80.0, 40.0) and sizes.middle_band == (160.0, 20.0)
    face = Rectangle(240, 160).Face().Move((-80, -80, 0))
    mesh = ngsolve.Mesh(OCCGeometry(face, dim=2).GenerateMesh(maxh=40))
    sponge = Sponge(0.2, 0.25, far_sigma=0.5, far_ramp=10.0)
    sigma = far_layer(sponge, sizes)

    def step(d):
        t = min(d / 10.0, 1.0)
        return 0.5 * t * t * (3 - 2 * t)

    points = {
        (0.0, 0.0): 0.0,  # the body
        (-40.0, 39.0): 0.0,  # the box's corner
        (150.0, -19.0): 0.0,  # the band near the outlet
        (-44.0, 0.0): step(4.0),  # upstream of the box
        (30.0, 47.0): step(7.0),  # beside the box
        (100.0, 25.0): step(5.0),  # beside the band, nearer to it than to the box
        (83.0, 30.0): step(3.0),  # behind the box, 3 from it, 10 from the band
        (-70.0, -70.0): 0.5,  # far corner
    }
    for (px, py), expected in points.items():
        assert sigma(mesh(px, py)) == pytest.approx(expected, abs=1e-12), (px, py)
