"""The full typical section (docs/model.md §3.1): an elastic axis away from mid-chord and a centre
of mass away from it. The new solid blocks and the time-discrete inertia against finite differences
of the nonlinear residual, the centripetal term against Lagrange's equations written independently,
and two limits: the in-vacuo frequencies of the 2-dof mass–spring system and the torsional
divergence with the slopes moved to the elastic axis."""

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fsistab.bodies import Pivoted, Plate
from fsistab.coupled import CoupledResidual, CoupledSystem, solid_energies, solid_inertia
from fsistab.eigen import eigenpairs_near
from fsistab.errors import InputError
from fsistab.mesh import build_mesh, mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Solid
from fsistab.simulation import TimeStepper
from fsistab.slopes import static_slopes
from fsistab.steady import solve_steady
from fsistab.theodorsen import AirfoilSlopes

AXIS, UNBALANCE = 0.1, 0.05  # a and x_θ in chords: the axis aft of mid-chord, so that it diverges


def _operators(body, alpha0: float = 0.0):
    return fluid_operators(solve_steady(mesh_spec(body, "coarse", 500), Flow(500, alpha0)))


@pytest.fixture(scope="module", params=[0.0, 5.0], ids=["alpha0=0", "alpha0=5"])
def pivoted(request):
    return _operators(Pivoted(Plate(), AXIS), request.param)


@pytest.fixture(scope="module")
def mid_chord():
    return _operators(Plate())


def _solid(**changes) -> Solid:
    base = {"mass_ratio": 3.0, "reduced_velocity": 2.0, "elastic_axis": AXIS, "static_unbalance": UNBALANCE}
    return Solid(**{**base, **changes})


def _fd(function, q0, direction, eps=1e-5):
    return (function(q0 + eps * direction) - function(q0 - eps * direction)) / (2 * eps)


def test_the_mesh_is_in_the_frame_of_the_elastic_axis():
    """The wall spans ``X ∈ [-1/2 - a, 1/2 - a]``, curved onto the translated corner arcs: the
    fluid area equals the mid-chord mesh's (same domain, same body) to the curving's accuracy."""
    from ngsolve import BND, Integrate

    meshes = {
        a: build_mesh(mesh_spec(Pivoted(Plate(), a) if a else Plate(), "coarse", 500)) for a in (0, AXIS)
    }
    mesh = meshes[AXIS]
    wall = [mesh[v].point[0] for e in mesh.Elements(BND) if e.mat == "wall" for v in e.vertices]
    assert min(wall) == pytest.approx(-0.5 - AXIS, abs=1e-12)
    assert max(wall) == pytest.approx(0.5 - AXIS, abs=1e-12)
    areas = [Integrate(1.0, m) for m in meshes.values()]
    plate = Plate()
    corner_gap = (4 - math.pi) * (plate.corner_radius * plate.thickness) ** 2  # square corners' excess
    assert abs(areas[1] - areas[0]) < 1e-3 * corner_gap


def test_elastic_axis_of_solid_and_mesh_must_agree(pivoted):
    with pytest.raises(InputError, match="elastic axis"):
        CoupledSystem(pivoted, _solid(elastic_axis=0.0))
    CoupledSystem(pivoted, _solid(elastic_axis=0.0, dofs=("heave",)))  # heave alone: no pitch axis


@pytest.mark.parametrize(
    "changes",
    [
        {"elastic_axis": 0.5},
        {"static_unbalance": 0.3},  # x_θ ≥ r_θ: no positive inertia about G
        {"elastic_axis": 0.3, "static_unbalance": 0.25},  # the centre of mass off the chord
    ],
)
def test_bad_typical_sections_are_refused(changes):
    with pytest.raises(InputError):
        _solid(**changes)


def test_jacobian_with_unbalance_matches_finite_differences(pivoted):
    """Every block of ``J`` about the elastic axis, with the unbalance, against the nonlinear
    residual (solid, fluid and mixed directions)."""
    system = CoupledSystem(pivoted, _solid())
    residual = CoupledResidual(system)
    q0 = residual.point()
    assert np.abs(residual(q0)).max() < 1e-10
    rng = np.random.default_rng(3)
    ns = system.n_solid
    for part in (slice(0, ns), slice(ns, None), slice(None)):
        direction = np.zeros(system.size)
        direction[part] = rng.standard_normal(direction[part].shape)
        direction /= np.linalg.norm(direction)
        exact = system.jacobian @ direction
        assert np.linalg.norm(_fd(residual, q0, direction) - exact) < 1e-6 * np.linalg.norm(exact)


def test_time_discrete_inertia_linearises_to_the_mass(pivoted):
    """The equations of one BDF2 step of ``fsistab simulate`` (the nonlinear inertia ``M_s(θ) q̇``
    with the centripetal term, the fluid's inertia) from a resting history linearise to
    ``J + (3/(2Δt)) M``: the linear mass ``M_s(θ₀)`` with the unbalance's coupling (§3.1)."""
    system = CoupledSystem(pivoted, _solid())
    dt = 0.1
    stepper = TimeStepper(system, dt)
    q0 = stepper.steady_point()
    equations = stepper._equations(2, q0, q0)
    shifted = system.jacobian + (1.5 / dt) * system.mass
    rng = np.random.default_rng(4)
    for part in (slice(0, system.n_solid), slice(None)):
        direction = np.zeros(system.size)
        direction[part] = rng.standard_normal(direction[part].shape)
        direction /= np.linalg.norm(direction)
        exact = shifted @ direction
        assert np.linalg.norm(_fd(equations, q0, direction) - exact) < 1e-6 * np.linalg.norm(exact)


def test_nonlinear_inertia_is_lagranges():
    """The solid rows' inertia (:func:`fsistab.coupled.solid_inertia`) against Lagrange's equations
    ``d/dt ∂T/∂q' − ∂T/∂q`` of the kinetic energy per unit mass, ``T = ½|v_G|² + ½(r_θ² − x_θ²)θ'²``,
    ``v_G = (−1 − x_θ sin θ θ', h' + x_θ cos θ θ')``, differentiated numerically (fourth-order
    differences) along a trajectory, rows divided by 1 and by ``r_θ²`` as in §3."""
    solid = _solid(r_theta=0.3, static_unbalance=0.12)
    x, r2 = solid.static_unbalance, solid.r_theta**2

    def kinetic(q, v):
        theta = q[1]
        vx, vy = -1 - x * math.sin(theta) * v[1], v[0] + x * math.cos(theta) * v[1]
        return 0.5 * (vx * vx + vy * vy) + 0.5 * (r2 - x * x) * v[1] ** 2

    def path(t):  # h, θ and their rates and accelerations
        q = np.array([0.2 * math.sin(1.3 * t), 0.7 * math.sin(0.9 * t + 0.4)])
        v = np.array([0.26 * math.cos(1.3 * t), 0.63 * math.cos(0.9 * t + 0.4)])
        a = np.array([-0.338 * math.sin(1.3 * t), -0.567 * math.sin(0.9 * t + 0.4)])
        return q, v, a

    def derivative(f, h=1e-3):  # of f at 0
        return (-f(2 * h) + 8 * f(h) - 8 * f(-h) + f(-2 * h)) / (12 * h)

    def gradient(f, point):
        return np.array([derivative(lambda h, e=e: f(point + h * e)) for e in np.eye(2)])

    t = 0.8
    q, v, a = path(t)
    momentum_rate = derivative(lambda h: gradient(lambda w: kinetic(path(t + h)[0], w), path(t + h)[1]))
    lagrange = momentum_rate - gradient(lambda p: kinetic(p, v), q)
    rows = solid_inertia(solid, np.array([*q, *v]), np.array([*v, *a]))[2:]
    assert rows == pytest.approx([lagrange[0], lagrange[1] / r2], rel=1e-8)
    balanced = solid_inertia(_solid(static_unbalance=0.0), np.array([*q, *v]), np.array([*v, *a]))[2:]
    assert np.abs(rows - balanced).min() > 1e-2  # the unbalance's terms are there


_amplitude = st.complex_numbers(max_magnitude=10.0, allow_nan=False, allow_infinity=False)


@given(
    st.floats(0.1, 1e4),
    st.floats(0.05, 0.5),
    st.floats(-0.99, 0.99),
    st.floats(-1.5, 1.5),
    _amplitude,
    _amplitude,
)
def test_mode_energies_split_the_kinetic_energy_of_the_section(mass_ratio, r_theta, ratio, theta, hdot, pdot):
    """:func:`fsistab.coupled.solid_energies` against the kinetic energy of §3.1 written from the
    velocity of the centre of mass, ``v_G = (−x_θ sin θ θ', ḣ + x_θ cos θ θ')`` (perturbation, complex
    amplitudes), ``E = (m/2)(½|v_G|² + ½(r_θ² − x_θ²)|θ'|²)`` in units ``ρL²U∞²``: the two parts add up
    to it, the heave part is G's vertical motion, neither is negative, and without unbalance they
    are ``(m/4)|ḣ|²`` and ``(m/4) r_θ²|θ'|²`` to the last bit."""
    x = ratio * r_theta
    solid = Solid(mass_ratio=mass_ratio, reduced_velocity=2.0, r_theta=r_theta, static_unbalance=x)
    vx, vy = -x * math.sin(theta) * pdot, hdot + x * math.cos(theta) * pdot
    kinetic = (
        0.5 * mass_ratio * (0.5 * (abs(vx) ** 2 + abs(vy) ** 2) + 0.5 * (r_theta**2 - x * x) * abs(pdot) ** 2)
    )
    heave, pitch = solid_energies(solid, (hdot, pdot), theta)
    scale = 0.25 * mass_ratio * (abs(hdot) ** 2 + r_theta**2 * abs(pdot) ** 2) + 1e-300
    assert abs(heave + pitch - kinetic) <= 1e-12 * scale
    assert abs(heave - 0.25 * mass_ratio * abs(vy) ** 2) <= 1e-12 * scale
    assert heave >= 0 and pitch >= 0
    balanced = solid_energies(replace(solid, static_unbalance=0.0), (hdot, pdot), theta)
    assert balanced == (0.25 * mass_ratio * abs(hdot) ** 2, 0.25 * mass_ratio * r_theta**2 * abs(pdot) ** 2)


def test_labels_weigh_the_heave_of_the_centre_of_mass():
    """A motion whose centre of mass heaves twice as fast as the elastic axis (``ḣ = x_θ θ'``) holds
    most of its kinetic energy in heave (``4x_θ²`` against ``r_θ² − x_θ²``), though the axis alone
    (``x_θ²`` against ``r_θ²``) would call it pitch: the eigenvalue labels and the threshold's branch
    read the same energies."""
    from fsistab.eigen import label_mode
    from fsistab.frequency_sweep import _branch

    solid = _solid(r_theta=0.15, static_unbalance=0.1, elastic_axis=0.0)
    motion = np.array([0.0, 0.0, 0.1, 1.0])  # (h, θ, ḣ, θ')
    assert label_mode(motion, solid, 0.0)[0] == "heave"
    assert _branch(motion, solid, 0.0) == "heave"
    assert _branch(motion, replace(solid, static_unbalance=0.0), 0.0) == "pitch"


def test_in_vacuo_frequencies_of_the_unbalanced_section(pivoted):
    """At a very large mass ratio the coupled eigenvalues are the solid's undamped in-vacuo ones,
    the roots of ``(Ω² − w²)(1 − w²) − (x_θ²/r_θ²) w⁴ = 0`` (frequencies in ``1/U*``) of the
    2-dof mass–spring system, not ``Ω`` and 1, approached like ``1/m``."""
    if pivoted.theta0 != 0:
        pytest.skip("the closed form is at α0 = 0")
    omega_ratio, r_theta, x, velocity = 0.5, 0.3, 0.2, 4.0
    solid = _solid(
        mass_ratio=1e7,
        reduced_velocity=velocity,
        freq_ratio=omega_ratio,
        zeta_theta=0.0,
        r_theta=r_theta,
        static_unbalance=x,
    )
    beta = 1 - x * x / r_theta**2
    b, c = omega_ratio**2 + 1, omega_ratio**2
    expected = [math.sqrt((b + s * math.sqrt(b * b - 4 * beta * c)) / (2 * beta)) / velocity for s in (-1, 1)]
    assert abs(expected[0] - omega_ratio / velocity) > 0.05 * expected[0]  # the unbalance matters
    assert abs(expected[1] - 1 / velocity) > 0.25 * expected[1]

    def errors(mass_ratio):
        system = CoupledSystem(pivoted, replace(solid, mass_ratio=mass_ratio))
        nearest = [
            min(eigenpairs_near(system, [1j * w], 2), key=lambda p: abs(p.value - 1j * w)) for w in expected
        ]
        return np.array([abs(p.value - 1j * w) / w for p, w in zip(nearest, expected, strict=True)])

    large, larger = errors(1e7), errors(1e8)
    assert np.all(large < 1e-4)
    assert np.all(larger < large / 5)  # the fluid's share vanishes like 1/m


def test_divergence_about_the_elastic_axis(pivoted, mid_chord):
    """The static slopes on the mesh about the elastic axis are the mid-chord mesh's moved to the
    axis — the moment by the normal force's slope ``dC_L/dθ − C_D`` (docs/model.md §3.1,
    :meth:`fsistab.theodorsen.AirfoilSlopes.moment_about`), not the lift's — and the coupled system
    about the axis has a real eigenvalue crossing zero at the torsional divergence of that slope,
    ``U*_D = √(m r_θ² / (dC_M/dθ)_EA)``, with an unbalance. The two meshes are one translated, to
    netgen's meshing of a moved domain. At α0 = 5° the moment is moved by the normal force's own
    slope (the divergence formula holds at α0 = 0 only)."""
    incidence = pivoted.theta0 != 0
    mid = static_slopes(_operators(Plate(), 5.0) if incidence else mid_chord)
    about_axis = static_slopes(pivoted)
    moved = AirfoilSlopes.from_static(mid).moment_about(AXIS)
    assert about_axis.lift == pytest.approx(mid.lift, rel=2e-3)
    assert about_axis.moment == pytest.approx(moved, rel=2e-3)
    if incidence:  # the normal force's slope of the steady state at 5°, not dC_L/dθ − C_D
        return
    assert mid.normal == pytest.approx(mid.lift - mid.steady_drag, rel=1e-12)  # its value at θ₀ = 0
    without_drag = mid.moment - AXIS * mid.lift  # the thin-airfoil rule would be off by a C_D
    assert abs(without_drag - moved) > 3 * 2e-3 * moved
    solid = _solid(mass_ratio=1000.0)
    divergence = math.sqrt(solid.mass_ratio * solid.r_theta**2 / moved)
    for velocity in (0.99 * divergence, 1.01 * divergence):
        system = CoupledSystem(pivoted, replace(solid, reduced_velocity=velocity))
        real = min(eigenpairs_near(system, [0.0], 3), key=lambda p: abs(p.value)).value
        assert abs(real.imag) < 1e-12
        assert (real.real > 0) == (velocity > divergence)


@pytest.mark.parametrize(
    "extra",
    [
        ["--body", "cylinder", "--elastic-axis", "0.1"],
        ["--elastic-axis", "0.3", "--static-unbalance", "0.25"],
    ],
    ids=["cylinder", "centre-of-mass-off-the-chord"],
)
def test_the_commands_refuse_a_bad_typical_section_in_one_line(extra, tmp_path):
    from typer.testing import CliRunner

    from fsistab.cli import app

    args = ["critical", "--mesh", "coarse", *extra, "--out", str(tmp_path / "out"), "--cache", str(tmp_path)]
    result = CliRunner().invoke(app, args)
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.exit_code == 2 and len(lines) == 1 and lines[0].startswith("error: "), result.output
    assert not (tmp_path / "out").exists()


def test_the_maps_characteristic_function_is_det_t_at_the_steady_pitch(pivoted):
    """The maps' ``F = det(m W − A)`` (:mod:`fsistab.map_roots`) with the unbalance's coupling taken
    at the steady pitch, ``x_θ cos θ₀`` (:func:`fsistab.map_roots.linear_solid`), is ``det T``
    times ``m² r_θ²``, ``T`` from the first-order solid mass ``M_s(θ₀)`` (docs/model.md §3.1) — at
    α0 = 5° as at 0; with ``x_θ`` itself it is not (at 5°); and the maps' roots at one frequency
    are neutral points of ``det T``."""
    from fsistab.map_roots import (
        AxisSample,
        characteristic_function,
        linear_solid,
        neutral_roots,
        second_order_loads,
    )
    from fsistab.transfer import characteristic_matrix, exact_transfer

    solid = _solid(mass_ratio=37.0, reduced_velocity=2.3, zeta_h=0.02, r_theta=0.3, static_unbalance=0.1)
    omega, theta0, loads0 = 0.3, pivoted.theta0, pivoted.loads0
    g, dg = exact_transfer(pivoted, 1j * omega, derivative=True)
    sample = AxisSample(omega, g, dg)
    loads, rate = second_order_loads(sample, theta0, loads0)
    s, m, u = 1j * omega, solid.mass_ratio, 1 / solid.reduced_velocity

    def det_t(solid):
        return np.linalg.det(characteristic_matrix(g, solid, s, theta0, loads0)) * m * m * solid.r_theta**2

    exact = det_t(solid)
    f = characteristic_function(loads, rate, linear_solid(solid, theta0), s, m, u)[0]
    assert abs(f - exact) < 1e-12 * abs(exact)
    if theta0 != 0:
        level = characteristic_function(loads, rate, solid, s, m, u)[0]
        assert abs(level - exact) > 1e-6 * abs(exact)
    roots = neutral_roots(sample, solid, theta0, loads0, (1.0, 1e4))
    assert roots
    for root in roots:
        at = replace(solid, mass_ratio=root.mass_ratio, reduced_velocity=root.reduced_velocity)
        scale = abs(np.linalg.det(characteristic_matrix(np.zeros((3, 4)), at, s, theta0, loads0)))
        assert abs(np.linalg.det(characteristic_matrix(g, at, s, theta0, loads0))) < 1e-9 * scale


def test_solid_parameter_derivatives_with_unbalance(pivoted):
    """``dσ/dp`` of the adjoint formula (S1) for the solid parameters, whose solid rows now carry the
    unbalance's mass coupling (``(x_θ/r_θ²) cos θ₀`` depends on r_θ), against centred differences of
    the eigenvalue."""
    from fsistab.sensitivity import adjoint_mode, eigenvalue_derivatives

    solid = _solid(mass_ratio=100.0, reduced_velocity=2.3, freq_ratio=0.5, r_theta=0.25, static_unbalance=0.1)
    system = CoupledSystem(pivoted, solid)
    start = min(eigenpairs_near(system, [0.4j], 3), key=lambda p: abs(p.value - 0.4j))
    mode = adjoint_mode(system, start.value, start.vector)
    parameters = ("mass_ratio", "r_theta", "reduced_velocity", "freq_ratio")
    derivatives = eigenvalue_derivatives(system, mode, parameters)
    for name in parameters:
        step = 1e-4 * getattr(solid, name)
        values = [
            min(
                eigenpairs_near(
                    CoupledSystem(pivoted, replace(solid, **{name: getattr(solid, name) + s * step})),
                    [mode.value],
                    3,
                ),
                key=lambda p: abs(p.value - mode.value),
            ).value
            for s in (1, -1)
        ]
        difference = (values[0] - values[1]) / (2 * step)
        assert abs(difference - derivatives[name]) < 1e-4 * abs(derivatives[name]), name


def test_a_small_perturbation_of_the_unbalanced_section_grows_at_its_eigenvalue(pivoted):
    """``fsistab simulate``'s nonlinear march (the inertia ``M_s(θ) q̇`` with the centripetal term,
    docs/model.md §3.1, §12) from the steady state plus 1e-4 of a coupled mode: heave and pitch
    follow that mode's eigenvalue, as BDF2 maps it (``(3/2 − σΔt) g² − 2g + 1/2 = 0``)."""
    from fsistab.simulation import MarchState, damped_oscillation, march, perturbed_state

    if pivoted.theta0 != 0:
        pytest.skip("one incidence suffices")
    solid = _solid(mass_ratio=100.0, reduced_velocity=2.3, freq_ratio=0.5, r_theta=0.25, static_unbalance=0.1)
    system = CoupledSystem(pivoted, solid)
    pair = min(eigenpairs_near(system, [0.4j], 3), key=lambda p: abs(p.value - 0.4j))
    dt = 0.1
    roots = np.roots([1.5 - pair.value * dt, -2.0, 0.5])
    image = complex(np.log(roots[np.argmax(np.abs(roots))]) / dt)
    stepper = TimeStepper(system, dt)
    state = MarchState(0.0, 0, perturbed_state(stepper, pair.vector, 1e-4))
    samples = [sample for _, sample in march(stepper, state, 20 * dt)][2:]  # the BDF1 start decayed
    for index in (0, 1):  # heave, pitch
        fit = damped_oscillation([s.time for s in samples], [s.solid[index] for s in samples])
        assert abs(fit - image) < 1e-5 * abs(pair.value)
