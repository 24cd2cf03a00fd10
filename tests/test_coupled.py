"""The coupled Jacobian against finite differences of the nonlinear residual (docs/model.md §5, §7),
and the eigen-solver against analytic limits (docs/validation.md, heaving cylinder)."""

import dataclasses
import math

import numpy as np
import pytest

from fsistab import operators
from fsistab.bodies import Cylinder, Plate
from fsistab.coupled import CoupledResidual, CoupledSystem
from fsistab.eigen import eigenpairs_near
from fsistab.errors import ConvergenceError, InputError
from fsistab.linalg import FluidFactor, ShiftedSolver
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators, wall_coefficients, wall_coefficients_jacobian
from fsistab.params import Flow, Solid
from fsistab.steady import solve_steady


@pytest.fixture(scope="module", params=[0.0, 5.0], ids=["alpha0=0", "alpha0=5"])
def plate_system(request):
    steady = solve_steady(mesh_spec(Plate(), "coarse", 500), Flow(500, request.param))
    system = CoupledSystem(fluid_operators(steady), Solid(mass_ratio=3.0, reduced_velocity=2.0))
    return system, CoupledResidual(system)


def _fd_error(residual, jacobian, q0, direction, rows, eps=1e-5):
    fd = (residual(q0 + eps * direction) - residual(q0 - eps * direction)) / (2 * eps)
    exact = jacobian @ direction
    return np.linalg.norm(fd[rows] - exact[rows]) / np.linalg.norm(exact[rows])


def test_steady_state_is_an_equilibrium(plate_system):
    system, residual = plate_system
    r = residual(residual.point())
    assert np.abs(r).max() < 1e-10


@pytest.mark.parametrize(
    ("perturbed", "rows", "block"),
    [
        ("solid", "solid", "J_ss"),
        ("solid", "fluid", "J_fs"),
        ("fluid", "solid", "J_sf"),
        ("fluid", "fluid", "J_ff"),
    ],
)
def test_jacobian_blocks_match_finite_differences(plate_system, perturbed, rows, block):
    system, residual = plate_system
    rng = np.random.default_rng(1)
    ns = system.n_solid
    parts = {"solid": slice(0, ns), "fluid": slice(ns, None)}
    for _ in range(2):
        direction = np.zeros(system.size)
        direction[parts[perturbed]] = rng.standard_normal(direction[parts[perturbed]].shape)
        direction /= np.linalg.norm(direction)
        error = _fd_error(residual, system.jacobian, residual.point(), direction, parts[rows])
        assert error < 1e-6, f"{block}: relative error {error:.2e}"


def test_whole_jacobian_matches_finite_differences(plate_system):
    system, residual = plate_system
    direction = np.random.default_rng(2).standard_normal(system.size)
    error = _fd_error(residual, system.jacobian, residual.point(), direction, slice(None))
    assert error < 1e-6


def test_wall_lifting_coefficients_derivative():
    q = np.array([0.3, -0.2, 0.4, 0.7])
    jac = wall_coefficients_jacobian(q)
    eps = 1e-6
    for k in range(4):
        e = np.zeros(4)
        e[k] = eps
        fd = (wall_coefficients(q + e) - wall_coefficients(q - e)) / (2 * eps)
        assert np.allclose(fd, jac[:, k], atol=1e-9)


def test_solid_parameters_do_not_touch_the_fluid(plate_system):
    system, _ = plate_system
    other = CoupledSystem(system.fluid, Solid(mass_ratio=50.0, reduced_velocity=7.0))
    assert other.fluid is system.fluid
    assert (other.jacobian[other.n_solid :, other.n_solid :] != system.fluid.jff).nnz == 0


def test_operators_assembled_on_every_core_equal_those_of_one_thread(plate_operators):
    """``fluid_operators`` runs its element loops in NGSolve's task manager: every block is that of
    the single-threaded assembly (the module's own function, outside any task manager) to the bit."""
    one_thread = operators._fluid_operators(plate_operators.steady, operators.TERMS)
    for name in ("jff", "mff", "load_f", "load_mass_f", "mff_near"):
        a, b = getattr(plate_operators, name), getattr(one_thread, name)
        assert a.shape == b.shape and (a != b).nnz == 0, name
    for name in ("jfs", "mfs", "load_s", "load_mass_s", "loads0"):
        assert np.array_equal(getattr(plate_operators, name), getattr(one_thread, name)), name


def test_operators_with_other_blocks_get_their_own_pencil(plate_operators):
    """The pencil ``J_ff + s M_f`` is kept on the operators it was made from: operators made from
    them with another ``J_ff`` (``dataclasses.replace``, as the time march does) factorise theirs."""
    jff, mff = plate_operators.jff, plate_operators.mff
    before = plate_operators.pencil
    other = dataclasses.replace(plate_operators, jff=(2.0 * jff).tocsr())
    assert other.pencil is not before and plate_operators.pencil is before
    assert abs(other.pencil.at(0.3j).matrix - (2.0 * jff + 0.3j * mff)).max() == 0
    assert abs(plate_operators.pencil.at(0.3j).matrix - (jff + 0.3j * mff)).max() == 0


def test_bordered_umfpack_equals_superlu_on_coupled_matrix(plate_system):
    system, _ = plate_system
    shift = 0.05 + 0.2j
    b = np.random.default_rng(3).standard_normal(system.size) + 0j
    x_bordered = ShiftedSolver(system, shift).solve(b)
    x_direct = ShiftedSolver(system, shift, backend="superlu").solve(b)
    assert np.linalg.norm(x_bordered - x_direct) < 1e-9 * np.linalg.norm(x_direct)
    residual = (system.jacobian + shift * system.mass) @ x_bordered - b
    assert np.linalg.norm(residual) < 1e-9 * np.linalg.norm(b)


@pytest.mark.parametrize("backend", ["umfpack", "ngsolve"])
@pytest.mark.parametrize("shift", [0.0, 0.3, 0.05 + 0.2j])
def test_fluid_factor_inverts_the_assembled_blocks(plate_system, shift, backend):
    """The factorised ``J_ff + s M_f`` (from the SciPy blocks through fsistab.umfpack, or assembled
    anew by operators.shifted_fluid_matrix for NGSolve's solver; real for a real shift) is the
    matrix of the SciPy blocks of fluid_operators: its solution has a residual at round-off level
    in them."""
    system, _ = plate_system
    fluid = system.fluid
    factor = FluidFactor(fluid, shift, backend=backend)
    assert factor.dtype is (complex if complex(shift).imag else float)
    b = np.random.default_rng(5).standard_normal(fluid.n_fluid)
    x = factor.solve(b)
    residual = (fluid.jff + shift * fluid.mff) @ x - b
    assert np.linalg.norm(residual) < 1e-9 * np.linalg.norm(b)


def test_eigenvalues_equal_with_either_umfpack(plate_system):
    """The shift-invert Arnoldi on unrefined ctypes-UMFPACK solves (the default) finds the
    eigenvalues that NGSolve's UMFPACK, with its iterative refinement, finds (to 1e-10)."""
    system, _ = plate_system
    shift = 0.01 + 0.2j
    pairs = {
        backend: eigenpairs_near(
            system, [shift], 6, fluid_factors={shift: FluidFactor(system.fluid, shift, backend=backend)}
        )
        for backend in ("umfpack", "ngsolve")
    }
    ours = sorted((p.value for p in pairs["umfpack"]), key=lambda z: (z.imag, z.real))
    theirs = sorted((p.value for p in pairs["ngsolve"]), key=lambda z: (z.imag, z.real))
    assert len(ours) == len(theirs) >= 4
    for a, b in zip(ours, theirs, strict=True):
        assert abs(a - b) < 1e-10 * abs(b)


def test_unknown_backend_refused(plate_system):
    system, _ = plate_system
    with pytest.raises(InputError, match="backend"):
        ShiftedSolver(system, 1j, backend="magic")


@pytest.fixture(scope="module")
def cylinder_60():
    steady = solve_steady(mesh_spec(Cylinder(), "coarse", 60), Flow(60))
    return fluid_operators(steady)


def test_fixed_cylinder_wake_mode_coarse(cylinder_60):
    """docs/validation.md, fixed cylinder's leading global mode, Re = 60: 0.0468 + 0.745i (coarse mesh
    here: a loose check)."""
    pairs = eigenpairs_near(CoupledSystem(cylinder_60, Solid(dofs=())), [0.75j], 3)
    leading = pairs[0]
    assert leading.label == "fluid" and leading.residual < 1e-8
    assert leading.growth_rate == pytest.approx(0.0468, abs=0.01)
    assert leading.frequency == pytest.approx(0.745, rel=0.03)


def test_heaving_cylinder_limits(cylinder_60):
    """docs/validation.md, heaving cylinder (Re = 60, m = 20): as U* -> 0 the fluid mode tends to the
    fixed-cylinder mode and the solid mode to iω_n √(m/(m + C_m)). ``C_m = 1`` (potential flow) is the
    high-frequency limit; at finite Stokes number ``β = D²f/ν = Re ω/2π`` Stokes' oscillating cylinder
    gives ``C_m = 1 + 4(πβ)^-1/2 + (πβ)^-3/2`` (Sarpkaya 1986), which at U* = 3 (β ≈ 19) lowers the
    frequency by 1.2 %."""
    fixed = eigenpairs_near(CoupledSystem(cylinder_60, Solid(dofs=())), [0.75j], 3)[0].value
    reduced_velocity = 3.0
    omega_n = 2 * math.pi / reduced_velocity
    system = CoupledSystem(cylinder_60, Solid.cylinder(20, reduced_velocity))
    fluid = min(eigenpairs_near(system, [fixed + 0.01j], 2), key=lambda p: abs(p.value - fixed))
    # shifted at the in-vacuo frequency: the nearest eigenvalue must be the structure mode
    solid = min(eigenpairs_near(system, [1j * omega_n], 2), key=lambda p: abs(p.value - 1j * omega_n))
    assert abs(fluid.value - fixed) < 2e-3
    assert solid.label == "heave"
    beta = 60 * solid.frequency / (2 * math.pi)
    added_mass = 1 + 4 / math.sqrt(math.pi * beta) + (math.pi * beta) ** -1.5
    assert solid.frequency / omega_n == pytest.approx(math.sqrt(20 / (20 + added_mass)), rel=0.01)
    assert solid.frequency / omega_n < math.sqrt(20 / 21)  # more than the potential added mass
    assert solid.growth_rate < 0  # viscous damping of the structure mode


def test_shift_far_from_spectrum_reports_clearly(cylinder_60):
    system = CoupledSystem(cylinder_60, Solid(dofs=()))
    with pytest.raises(ConvergenceError, match="shift"):
        eigenpairs_near(system, [0.75j], 2, max_residual=1e-300)


def test_unknown_fluid_factorisation_refused(plate_system):
    system, _ = plate_system
    with pytest.raises(InputError, match="fluid factorisation"):
        FluidFactor(system.fluid, 1j, backend="magic")
