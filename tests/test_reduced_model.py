"""Reduced (rational Krylov) models of the fixed-body fluid (fsistab.reduced_model).

Plate, Re = 2900, α0 = 0, coarse mesh. Every certified value of ``G`` and ``dG/ds`` is checked
against the exact elimination (:func:`fsistab.transfer.exact_transfer`, one factorisation each),
the model's derivative against a difference of its values, the error estimate against the true
error, the saved models against a rerun that factorises nothing, and a neutral map built from the
models against the continuation method's Newton thresholds.
"""

from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg as sla
from damage import damage

from fsistab.coupled import CoupledSystem
from fsistab.critical import divergence_point, flutter_point, wake_mode_near
from fsistab.eigen import eigenpairs_near
from fsistab.errors import CacheError, InputError
from fsistab.linalg import FactorCounter
from fsistab.params import Solid
from fsistab.reduced_model import ReducedModels, krylov_model, reduced_cover, relative_error
from fsistab.transfer import exact_transfer
from fsistab.transfer_map import transfer_neutral_map

TOLERANCE = 1e-7


@pytest.fixture(scope="module")
def fluid(plate_operators):
    return plate_operators


@pytest.fixture(scope="module")
def cover(fluid, tmp_path_factory):
    """Models covering 0 ≤ ω ≤ 0.6, saved in a file, with the count of their factorisations."""
    path = tmp_path_factory.mktemp("reduced") / "models.nc"
    counter = FactorCounter()
    models = reduced_cover(fluid, 0.6, tolerance=TOLERANCE, blocks=24, path=path, counter=counter)
    return models, path, counter.count


def test_model_is_exact_at_its_shift_and_a_real_shift_gives_a_real_basis(fluid):
    """A moment-matching model reproduces G at its shift (1e-10); at s = 0 it is built in real
    arithmetic and gives the static loads of divergence."""
    model = krylov_model(fluid, 0.4j, blocks=8)
    assert relative_error(model.transfer(0.4j), exact_transfer(fluid, 0.4j)) < 1e-10
    static = krylov_model(fluid, 0.0, blocks=8)
    assert np.isrealobj(static.jr) and np.isrealobj(static.lf)
    assert relative_error(static.transfer(0.0), exact_transfer(fluid, 0.0)) < 1e-10


def test_certified_values_and_rates_agree_with_the_exact_elimination(fluid, cover):
    """Inside the certified intervals (the whole of [0, 0.6]) G is within the tolerance of the
    exact value and the error estimate is above the true error; dG/ds to 1e-5; the model's dG/ds
    is the derivative of its G (centred difference, 1e-7)."""
    models, _, factorisations = cover
    assert models.covered_to(0.0) >= 0.6
    assert factorisations == len(models.models)
    rng = np.random.default_rng(3)
    for omega in [*rng.uniform(0.0, 0.6, 5), *(m.interval[1] * 0.999 for m in models.models[:2])]:
        model = models.covering(omega)
        g, dg = models.transfer(omega)
        exact, exact_rate = exact_transfer(fluid, 1j * omega, derivative=True)
        error = relative_error(g, exact)
        assert error <= TOLERANCE
        assert error <= 1.5 * model.error_estimate(1j * omega) + 1e-12
        assert relative_error(dg, exact_rate) < 1e-5
        h = 1e-6  # poles 0.02 from the axis: truncation error ~ (h/0.02)² of the difference
        centred = (model.transfer(1j * (omega + h)) - model.transfer(1j * (omega - h))) / (2j * h)
        assert relative_error(centred, dg) < 1e-7


def test_estimate_exceeds_the_tolerance_just_outside_an_interval(cover):
    models, _, _ = cover
    model = models.models[1]
    assert model.error_estimate(1j * model.interval[1] * 1.05) > TOLERANCE


def test_saved_models_are_reused_and_a_mismatch_is_refused(fluid, cover, tmp_path):
    models, path, _ = cover
    counter = FactorCounter()
    again = reduced_cover(fluid, 0.6, tolerance=TOLERANCE, blocks=24, path=path, counter=counter)
    assert counter.count == 0 and len(again.models) == len(models.models)
    assert relative_error(again.transfer(0.33)[0], models.transfer(0.33)[0]) < 1e-14
    for saved, built in zip(again.models, models.models, strict=True):  # sizes differ: ragged records
        assert saved.shift == built.shift and saved.ends == built.ends and saved.interval == built.interval
        for name in ("jr", "mr", "br0", "br1", "lf", "lm", "load_s", "load_mass_s"):
            assert np.array_equal(getattr(saved, name), getattr(built, name)), name
    with pytest.raises(CacheError, match="blocks"):
        ReducedModels(fluid, tolerance=TOLERANCE, blocks=25, path=path)
    bad = tmp_path / "models.nc"
    bad.write_bytes(b"not netcdf")
    assert ReducedModels(fluid, path=bad).models == []  # damaged: reported, rebuilt (test_store)


def test_models_lost_from_a_damaged_file_are_rebuilt_where_they_were(fluid, cover, tmp_path):
    """A copy of the cover's file, damaged: read back it is reported and moved aside (no model);
    :meth:`ReducedModels.restore` rebuilds every model from the index beside it, one factorisation
    each, at the same shifts with the same intervals and the same matrices to the bit, and saves
    them: the file is valid again. An intact file restores nothing."""
    models, path, built = cover
    copy = tmp_path / "models.nc"
    copy.write_bytes(path.read_bytes())
    (tmp_path / "models_index.nc").write_bytes(path.with_name("models_index.nc").read_bytes())
    damage(copy, "flipped")
    counter = FactorCounter()
    lost = ReducedModels(fluid, tolerance=TOLERANCE, blocks=24, path=copy, counter=counter)
    assert lost.models == [] and (tmp_path / "models.nc.damaged").exists()
    assert lost.restore() == len(models.models) == built == counter.count
    again = ReducedModels(fluid, tolerance=TOLERANCE, blocks=24, path=copy, counter=counter)
    assert again.restore() == 0 and counter.count == built
    for restored in (lost.models, again.models):
        for saved, original in zip(restored, models.models, strict=True):
            assert saved.shift == original.shift and saved.interval == original.interval
            for name in ("jr", "mr", "br0", "br1", "lf", "lm", "load_s", "load_mass_s"):
                assert np.array_equal(getattr(saved, name), getattr(original, name)), name


def test_bad_input_is_refused_before_any_factorisation(fluid):
    counter = FactorCounter()
    for kwargs in ({"tolerance": 0.0}, {"tolerance": 0.1}, {"blocks": 2}):
        with pytest.raises(InputError):
            ReducedModels(fluid, counter=counter, **kwargs)
    for omega_max in (0.0, -1.0, float("inf")):
        with pytest.raises(InputError):
            reduced_cover(fluid, omega_max, counter=counter)
    with pytest.raises(InputError):
        krylov_model(fluid, 0.3j, blocks=1, counter=counter)
    assert counter.count == 0


def test_map_from_reduced_models_agrees_with_newton_with_fewer_factorisations(fluid, tmp_path):
    """The map of test_transfer_map (m ∈ [300, 3000], ω ∈ [0.05, 0.5]) with reduced models: the
    same flutter and divergence thresholds at m = 1000 as the augmented Newton (1e-6, 1e-8), from
    fewer than half the factorisations of exact samples (7 against 57 when written; exact samples
    only, ``resonance_blocks=0``: no model at s = 0 either)."""
    settings_ = dict(mass_range=(300.0, 3000.0), omega_range=(0.05, 0.5), initial=16)
    exact = FactorCounter()
    transfer_neutral_map(fluid, Solid(), counter=exact, resonance_blocks=0, **settings_)
    counter = FactorCounter()
    reduced = ReducedModels(fluid, tolerance=TOLERANCE, blocks=40, counter=counter)
    tmap = transfer_neutral_map(fluid, Solid(), reduced=reduced, counter=counter, **settings_)
    assert tmap.factorisations == counter.count < exact.count / 2
    start = Solid(mass_ratio=1000, reduced_velocity=4.7)
    pairs = eigenpairs_near(CoupledSystem(fluid, start), [0.003 + 0.17j], 4)
    guess = max((p for p in pairs if p.label != "fluid"), key=lambda p: p.growth_rate)
    flutter = flutter_point(fluid, replace(start, reduced_velocity=4.56), guess.frequency, guess.vector)
    divergence = divergence_point(fluid, replace(start, reduced_velocity=7.2))
    onsets = [(u, kind) for u, rate, kind in tmap.crossings_at(1000.0) if rate > 0]
    assert onsets[0][1] == "flutter" and onsets[0][0] == pytest.approx(flutter.reduced_velocity, rel=1e-6)
    assert onsets[1][1] == "divergence"
    assert onsets[1][0] == pytest.approx(divergence.reduced_velocity, rel=1e-8)


def test_coupled_eigenvalues_of_the_models_are_those_of_the_full_problem(fluid, cover):
    """m = 1000: the certified unstable eigenvalues of the reduced coupled problem — none at
    U* = 4, flutter at 5.5, flutter and divergence at 8 (the counts of test_transfer_map) — and
    the flutter eigenvalue at U* = 5.5 equal to the full eigen-solver's (1e-8)."""
    models, _, _ = cover
    counts = [
        len(models.unstable_eigenvalues(Solid(mass_ratio=1000, reduced_velocity=u))) for u in (4.0, 5.5, 8.0)
    ]
    assert counts == [0, 1, 2]
    solid = Solid(mass_ratio=1000, reduced_velocity=5.5)
    (reduced,) = models.unstable_eigenvalues(solid)
    pairs = eigenpairs_near(CoupledSystem(fluid, solid), [reduced], 1)
    assert abs(pairs[0].value - reduced) < 1e-8


def test_a_model_at_the_wake_frequency_carries_the_wake_mode_pole(fluid):
    """The pole of G that drives VIV: the fixed-body wake mode (Arnoldi) is an eigenvalue of the
    reduced fluid ``K_r(σ) y = 0`` of a model built near it (1e-8), and the model is certified on an
    interval around it."""
    wake = wake_mode_near(fluid, 11.0)
    models = ReducedModels(fluid, tolerance=TOLERANCE, blocks=20)
    model = models.build(round(wake.frequency, 1))
    poles = sla.eigvals(-model.jr, model.mr)
    assert np.min(np.abs(poles - wake.value)) < 1e-8
    assert model.covers(wake.frequency)


@pytest.mark.parametrize("dtype", [complex, float])
def test_projection_in_column_chunks_equals_the_dense_product(dtype):
    """``Vᴴ A V`` formed 32 columns at a time, a real sparse ``A`` split over the real and imaginary
    parts of ``V``, and ``Vᴴ X`` as ``conj(Vᵀ conj(X))``, against the dense products (70 columns:
    three chunks, the last one partial)."""
    import scipy.sparse as sp

    from fsistab.reduced_model import PROJECTION_COLUMNS, _adjoint_product, _projected

    rng = np.random.default_rng(3)
    n, k = 400, 2 * PROJECTION_COLUMNS + 6
    operator = sp.random(n, n, density=0.02, random_state=4, format="csr") + sp.identity(n, format="csr")
    basis = rng.standard_normal((n, k))
    if dtype is complex:
        basis = basis + 1j * rng.standard_normal((n, k))
    basis = np.asfortranarray(basis)  # as krylov_model's store
    inputs = rng.standard_normal((n, 4))
    dense = operator.toarray()
    expected = basis.conj().T @ dense @ basis
    assert _projected(basis, operator).dtype == basis.dtype
    assert np.abs(_projected(basis, operator) - expected).max() <= 1e-12 * np.abs(expected).max()
    assert np.abs(_adjoint_product(basis, inputs) - basis.conj().T @ inputs).max() <= 1e-12 * n
