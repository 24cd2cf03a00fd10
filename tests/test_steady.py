import logging
import math
import shutil

import numpy as np
import pytest
from damage import KINDS, damage

from fsistab import store
from fsistab.bodies import Cylinder, Plate
from fsistab.errors import CacheError
from fsistab.forces import aerodynamic_coefficients, recirculation_length, surface_coefficients
from fsistab.mesh import mesh_spec
from fsistab.params import Flow
from fsistab.steady import load_steady, solve_steady, steady_key, steady_path


def test_symmetric_plate_has_no_lift_or_moment(plate_2900):
    """docs/model.md §6: at α0 = 0 the steady flow is symmetric."""
    c = aerodynamic_coefficients(plate_2900)
    assert abs(c.lift) < 1e-10
    assert abs(c.moment) < 1e-10
    assert 0.01 < c.drag < 0.2
    assert plate_2900.path, "Re = 2900 is reached by continuation"
    assert plate_2900.history[-1] < 1e-9


def test_positive_incidence_gives_lift_and_nose_up_moment(plate_2900_alpha5):
    c = aerodynamic_coefficients(plate_2900_alpha5)
    assert c.lift > 0.1  # thin-airfoil 2π·sin 5° = 0.55 is the inviscid bound
    assert c.moment < 0  # counter-clockwise positive: nose-up is negative


def test_reaction_and_surface_forces_agree(cylinder_coarse_40, plate_2900_alpha5):
    for steady, tol in [(cylinder_coarse_40, 5e-3), (plate_2900_alpha5, 2e-2)]:
        reaction, surface = aerodynamic_coefficients(steady), surface_coefficients(steady)
        assert surface.drag == pytest.approx(reaction.drag, rel=tol)
    reaction, surface = aerodynamic_coefficients(plate_2900_alpha5), surface_coefficients(plate_2900_alpha5)
    assert surface.lift == pytest.approx(reaction.lift, rel=tol)


def test_newton_converges_quadratically(cylinder_coarse_40):
    """r_{k+1} <= K r_k² with K bounded: a linear rate q would give K = q / r_k -> infinity."""
    r = np.array(cylinder_coarse_40.history)
    assert len(r) >= 4 and r[-1] < 1e-9
    k = r[1:] / r[:-1] ** 2
    assert k.max() < 100, k
    assert r[-1] < 1e-4 * r[-2]  # the last step gains more than four orders


def test_lift_is_smooth_in_alpha0():
    """C_L(α0) at Re = 100: centred differences with steps δ and δ/2 agree to O(δ²)."""
    spec = mesh_spec(Plate(), "coarse", 100)
    base = solve_steady(spec, Flow(100, 2.0))

    def lift(alpha):
        return aerodynamic_coefficients(solve_steady(spec, Flow(100, alpha), initial=base)).lift

    delta = 0.5
    slope_1 = (lift(2 + delta) - lift(2 - delta)) / (2 * math.radians(delta))
    slope_2 = (lift(2 + delta / 2) - lift(2 - delta / 2)) / math.radians(delta)
    assert slope_1 > 0
    assert slope_2 == pytest.approx(slope_1, rel=1e-3)


@pytest.fixture(scope="module")
def cylinder_cache(tmp_path_factory):
    """The coarse cylinder at Re 40 solved once into a cache: (spec, cache dir, steady state)."""
    cache = tmp_path_factory.mktemp("cache")
    spec = mesh_spec(Cylinder(), "coarse", 40)
    return spec, cache, solve_steady(spec, Flow(40), cache_dir=cache)


def test_cache_reuse(cylinder_cache):
    spec, cache, first = cylinder_cache
    again = solve_steady(spec, Flow(40), cache_dir=cache)
    assert again.from_cache and not first.from_cache
    assert np.array_equal(first.state.vec.FV().NumPy(), again.state.vec.FV().NumPy())
    assert aerodynamic_coefficients(again).drag == aerodynamic_coefficients(first).drag
    path = steady_path(spec, Flow(40), cache)
    assert [p.name for p in path.parent.iterdir()] == [path.name]  # no partial file


@pytest.mark.parametrize("kind", [*KINDS, "other_key", "wrong_size"])
def test_a_damaged_steady_state_is_reported_and_recomputed(cylinder_cache, tmp_path, caplog, kind):
    """The issue's example: 4 KiB zeroed in a cached state gave C_D = 3.03 instead of 0.405. Every
    damage is caught, reported, the entry moved aside and recomputed to the original state."""
    import h5py

    spec, cache, first = cylinder_cache
    shutil.copytree(cache, tmp_path, dirs_exist_ok=True)
    path = steady_path(spec, Flow(40), tmp_path)
    original = first.state.vec.FV().NumPy().copy()
    if kind in KINDS:
        damage(path, kind, variable="state")
    else:  # a well-formed file (valid checksum) that is not this computation's
        ds = store.read_dataset(path)
        if kind == "other_key":
            ds = ds.assign_attrs(key=steady_key(spec, Flow(41)))
        else:
            ds = ds.isel(dof=slice(0, 100))
        path.unlink()
        store.write_dataset(ds, path)
    if kind in ("flipped", "zeroed", "edited"):
        with h5py.File(path, "r") as f:  # the damage reaches the values a reader would use
            assert not np.array_equal(f["state"][...], original)
    with caplog.at_level(logging.WARNING, logger="fsistab"):
        again = solve_steady(spec, Flow(40), cache_dir=tmp_path)
    assert not again.from_cache
    (warning,) = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert str(path) in warning and "recomputing" in warning and "\n" not in warning
    assert np.allclose(again.state.vec.FV().NumPy(), original, rtol=0, atol=1e-10)
    drag = aerodynamic_coefficients(first).drag
    assert aerodynamic_coefficients(again).drag == pytest.approx(drag, abs=1e-10)
    assert path.with_name(path.name + ".damaged").exists()
    assert solve_steady(spec, Flow(40), cache_dir=tmp_path).from_cache  # the new entry is sound


def test_load_steady_refuses_a_damaged_file_in_one_line(cylinder_cache, tmp_path):
    spec, cache, _ = cylinder_cache
    shutil.copytree(cache, tmp_path, dirs_exist_ok=True)
    path = steady_path(spec, Flow(40), tmp_path)
    damage(path, "edited", variable="state")
    with pytest.raises(CacheError, match="checksum") as error:
        load_steady(path, spec, Flow(40), tmp_path)
    assert str(path) in str(error.value) and "\n" not in str(error.value)


def test_recirculation_behind_cylinder_grows_with_reynolds(cylinder_coarse_40):
    spec = mesh_spec(Cylinder(), "coarse", 40)
    at_50 = solve_steady(spec, Flow(50), initial=cylinder_coarse_40)
    l40, l50 = recirculation_length(cylinder_coarse_40), recirculation_length(at_50)
    assert 1.8 < l40 < l50 < 3.5


@pytest.mark.parametrize(
    ("reynolds", "drag_range", "length_range"),
    [(40, (1.50, 1.54), (2.2, 2.3)), (50, None, (2.9, 3.0))],
)
def test_cylinder_against_reference_medium_mesh(reynolds, drag_range, length_range):
    """docs/validation.md (fixed cylinder, steady flow) on the medium mesh, default domain
    [-50, 100] × [-50, 50]."""
    steady = solve_steady(mesh_spec(Cylinder(), "medium", reynolds), Flow(reynolds))
    if drag_range:
        assert drag_range[0] <= aerodynamic_coefficients(steady).drag <= drag_range[1]
    assert length_range[0] <= recirculation_length(steady) <= length_range[1]


def _random_state(space, seed: int):
    from ngsolve import GridFunction

    state = GridFunction(space)
    state.vec.FV().NumPy()[:] = np.random.default_rng(seed).standard_normal(space.ndof)
    return state


def test_written_linearisation_is_the_derivative_of_the_residual():
    """momentum_linearisation (assembled by the Newton solver) against NGSolve's automatic
    differentiation of momentum_form, entry by entry, at a random state and incidence."""
    from fsistab.mesh import build_mesh
    from fsistab.steady import SteadyProblem

    problem = SteadyProblem.on(build_mesh(mesh_spec(Plate(), "coarse", 100)))
    problem.set_flow(Flow(250, 7.0))
    state = _random_state(problem.space, 3)
    problem.form.AssembleLinearization(state.vec)
    problem.base.vec.data = state.vec
    problem.jacobian.Assemble()
    rows, cols, derived = problem.form.mat.COO()
    rows_w, cols_w, written = problem.jacobian.mat.COO()
    assert np.array_equal(np.asarray(rows), np.asarray(rows_w))
    assert np.array_equal(np.asarray(cols), np.asarray(cols_w))
    derived, written = np.asarray(derived), np.asarray(written)
    assert np.abs(written - derived).max() < 1e-12 * np.abs(derived).max()


@pytest.fixture(scope="module")
def plate_100_by_backend():
    """The coarse plate at Re = 100, α0 = 5° from rest (Newton at Re 40, then continuation) with
    each factorisation: fsistab.umfpack, NGSolve's UMFPACK (the former factorisation), and the
    fallback when the library exports no UMFPACK."""
    from fsistab import umfpack

    spec = mesh_spec(Plate(), "coarse", 100)
    results = {
        backend: solve_steady(spec, Flow(100, 5.0), backend=backend) for backend in ("umfpack", "ngsolve")
    }
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(umfpack, "available", lambda: False)
        patch.setattr(umfpack, "LU", None)  # a call would fail: the fallback must not use it
        results["fallback"] = solve_steady(spec, Flow(100, 5.0), backend="umfpack")
    return results


@pytest.mark.parametrize("other", ["ngsolve", "fallback"])
def test_factorisation_backends_give_the_same_steady_state(plate_100_by_backend, other):
    ours, theirs = plate_100_by_backend["umfpack"], plate_100_by_backend[other]
    x, y = ours.state.vec.FV().NumPy(), theirs.state.vec.FV().NumPy()
    assert np.linalg.norm(x - y) < 1e-8 * np.linalg.norm(y)
    assert ours.path == theirs.path
    assert ours.factorisations == theirs.factorisations > sum(n for *_, n in ours.path)  # + Newton at Re 40
    assert ours.history[-1] < 1e-9 and theirs.history[-1] < 1e-9


def test_one_symbolic_analysis_per_mesh(monkeypatch):
    """Every Newton step of a continuation from rest reuses one UMFPACK symbolic analysis: the
    library's Analysis is counted where it is made, whoever makes it (LU makes its own when
    handed none or a mismatched one)."""
    from fsistab import umfpack

    if not umfpack.available():
        pytest.skip("NGSolve's wheel exports no UMFPACK")
    made, factorised = [], []
    analysis_init, lu_init = umfpack.Analysis.__init__, umfpack.LU.__init__

    def counting_analysis(self, *args, **kwargs):
        made.append(self)
        analysis_init(self, *args, **kwargs)

    def counting_lu(self, *args, **kwargs):
        lu_init(self, *args, **kwargs)
        factorised.append(self.analysis)

    monkeypatch.setattr(umfpack.Analysis, "__init__", counting_analysis)
    monkeypatch.setattr(umfpack.LU, "__init__", counting_lu)
    spec = mesh_spec(Plate(), "coarse", 400)
    steady = solve_steady(spec, Flow(400))
    assert len(steady.path) >= 2  # Newton at Re 40 and at least two continuation steps
    assert len(factorised) == steady.factorisations > 10
    assert len(made) == 1
    assert all(analysis is made[0] for analysis in factorised)
    again = solve_steady(mesh_spec(Cylinder(), "coarse", 40), Flow(40))  # another mesh: its own analysis
    assert len(made) == 2 and len(factorised) == steady.factorisations + again.factorisations


def test_unknown_factorisation_is_refused_before_any_work(tmp_path):
    from fsistab.errors import InputError

    with pytest.raises(InputError, match="unknown steady factorisation 'mumps'") as error:
        solve_steady(mesh_spec(Plate(), "coarse", 100), Flow(100), cache_dir=tmp_path, backend="mumps")
    assert "\n" not in str(error.value)
    assert not any(tmp_path.iterdir())  # no mesh built


def test_loose_intermediate_steps_reach_the_same_state(plate_2900):
    """Continuation whose intermediate steps stop at a residual of 1e-6 reaches the state of the
    default path (every step at NEWTON_TOL) at Re = 2900, within the accuracy of NEWTON_TOL."""
    from ngsolve import GridFunction

    from fsistab.steady import NEWTON_TOL, START_REYNOLDS, SteadyProblem, continuation

    problem = SteadyProblem.on(plate_2900.mesh)
    state = GridFunction(problem.space)
    start = Flow(START_REYNOLDS)
    problem.newton(state, start, maxit=15)
    history, path = continuation(problem, state, start, Flow(2900), path_tol=1e-6)
    assert history[-1] < NEWTON_TOL and path[-1][0] == 2900
    assert len(path) < len(plate_2900.path)  # two different paths, else this compared a run with itself
    loose, strict = state.vec.FV().NumPy(), plate_2900.state.vec.FV().NumPy()
    assert np.linalg.norm(loose - strict) < 1e-8 * np.linalg.norm(strict)
