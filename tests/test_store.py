"""The store (fsistab.store): checksummed datasets, damaged entries reported and recomputed, one
encoding of complex data, atomic writes, recorded writes, writable directories, resumable tables.

Cached kinds checked here: transfer samples, reduced models, resumable neutral curves, and any
dataset; steady states and meshes in test_steady / test_mesh. The fluid is the coarse cylinder at
Re 40 (a few seconds).
"""

import logging
import os
import stat
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from damage import KINDS, damage
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from fsistab import store
from fsistab.errors import CacheError, InputError
from fsistab.linalg import FactorCounter

LOGGER = "fsistab"
CHECKSUM = store.CHECKSUM_ATTR
# the store's mechanics are tested on synthetic variable names, which the data dictionary
# (fsistab.schema, tested in test_schema.py) does not describe
pytestmark = pytest.mark.filterwarnings("ignore::fsistab.schema.UndescribedVariableWarning")


def _dataset() -> xr.Dataset:
    rng = np.random.default_rng(3)
    return xr.Dataset(
        {
            "state": ("dof", rng.standard_normal(3000)),
            "count": ("dof", np.arange(3000)),
            "label": ("mode", ["fluid", "solid"]),
            "mode": store.complex_variable("mode", [1 + 2j, -0.5j]),
        },
        coords={"frequency": ("mode", [0.1, 0.2])},
        # a one-element list comes back from NetCDF as a scalar: the checksum is of what is read
        attrs={"reynolds": 40.0, "case": "cylinder", "ndof": 3000, "shifts": [1.0, 2.0], "one": [0.5]},
    )


# --- checksums ---------------------------------------------------------------------------------


def test_a_dataset_round_trips_with_its_checksum(tmp_path):
    ds = _dataset()
    path = store.write_dataset(ds, tmp_path / "a.nc")
    back = store.read_dataset(path, expect={"case": "cylinder", "reynolds": 40.0})
    assert CHECKSUM in back.attrs and CHECKSUM not in ds.attrs  # the caller's dataset is not changed
    assert np.array_equal(back.state.values, ds.state.values)
    assert list(back.label.values) == ["fluid", "solid"]
    with pytest.raises(CacheError, match="does not match the request: case"):
        store.read_dataset(path, expect={"case": "plate"})


def test_the_checksum_depends_on_every_value_name_dtype_and_attribute():
    ds = _dataset()
    base = store.dataset_checksum(ds)
    changed = [
        ds.assign(state=ds.state.copy(data=np.where(np.arange(3000) == 7, 0.0, ds.state.values))),
        ds.assign(count=ds["count"].astype(np.int32)),
        ds.rename({"state": "state2"}),
        ds.assign_attrs(reynolds=41.0),
        ds.assign_coords(frequency=("mode", [0.1, 0.3])),
        ds.assign(label=("mode", ["fluid", "solld"])),
    ]
    for other in changed:
        assert store.dataset_checksum(other) != base
    # the checksum attribute itself does not enter
    assert store.dataset_checksum(ds.assign_attrs({CHECKSUM: "x"})) == base


@pytest.mark.parametrize("kind", KINDS)
def test_a_damaged_dataset_is_refused_in_one_line(tmp_path, kind):
    path = store.write_dataset(_dataset(), tmp_path / "a.nc")
    damage(path, kind, variable="state")
    with pytest.raises(CacheError) as error:
        store.read_dataset(path)
    message = str(error.value)
    assert "\n" not in message and str(path) in message and "delete it" in message


@pytest.mark.parametrize("offset", [-24, -8, 0, 3])
def test_a_damaged_header_is_refused_without_a_foreign_traceback(tmp_path, capfd, monkeypatch, offset):
    """One byte flipped in the root object's header (near the name of a root attribute): h5netcdf
    used to fail half-way through opening it and, when its half-built file was collected, print an
    ``Exception ignored`` traceback (an "unraisable" exception) after the one-line report."""
    import gc
    import sys

    # few attributes: HDF5 keeps them in the root object's header (more go to a heap further on)
    ds = xr.Dataset({"state": ("dof", np.arange(3000.0))}, attrs={"case": "cylinder"})
    path = store.write_dataset(ds, tmp_path / "a.nc")
    data = bytearray(path.read_bytes())
    where = data.find(b"case")  # the root attribute's name, in the header at the file's start
    assert 0 < where < 1024
    data[where + offset] ^= 0xFF
    path.write_bytes(bytes(data))
    unraisable = []
    monkeypatch.setattr(sys, "unraisablehook", unraisable.append)
    try:
        store.read_dataset(path)
    except CacheError as exc:
        message = str(exc)
    else:
        pytest.fail("the damaged file was read")
    gc.collect()  # whatever the failed read left behind is collected here, under the hook
    assert "\n" not in message and str(path) in message
    assert [str(u.exc_value) for u in unraisable] == []
    assert capfd.readouterr() == ("", "")


def test_a_dataset_without_checksum_is_refused(tmp_path):
    path = tmp_path / "plain.nc"
    _dataset().to_netcdf(path, engine=store.NETCDF_ENGINE)
    with pytest.raises(CacheError, match="no content checksum"):
        store.read_dataset(path)


def test_a_damaged_cache_entry_is_reported_moved_aside_and_not_used(tmp_path, caplog):
    path = store.write_dataset(_dataset(), tmp_path / "a.nc")
    assert store.read_cached(path) is not None
    damage(path, "edited", variable="state")
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        assert store.read_cached(path) is None
    (record,) = caplog.records
    assert str(path) in record.getMessage() and "recomputing" in record.getMessage()
    assert not path.exists() and (tmp_path / "a.nc.damaged").exists()
    assert store.read_cached(path) is None  # missing: nothing to report
    assert len(caplog.records) == 1


# --- complex data ------------------------------------------------------------------------------

finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=40, deadline=None)
@given(
    arrays(
        np.complex128,
        st.tuples(st.integers(0, 4), st.integers(1, 3)),
        elements=st.builds(complex, finite, finite),
    )
)
def test_complex_values_round_trip_through_a_file(tmp_path_factory, values):
    path = tmp_path_factory.mktemp("complex") / "c.nc"
    array = store.complex_variable(("row", "column"), values, {"units": "1"})
    assert array.dims == ("row", "column", "part") and array.attrs == {"units": "1"}
    assert np.array_equal(store.complex_values(array), values)
    store.write_dataset(xr.Dataset({"z": array}), path)
    back = store.read_dataset(path)["z"]
    assert np.array_equal(store.complex_values(back), values)
    # the part order is read from the coordinate, not assumed
    assert np.array_equal(store.complex_values(back.isel(part=[1, 0])), values)


def test_complex_values_refuses_real_data():
    with pytest.raises(CacheError, match="no 'part' dimension"):
        store.complex_values(xr.DataArray(np.zeros(3), dims="x", name="x"))
    with pytest.raises(ValueError, match="do not fit"):
        store.complex_variable(("a", "b"), np.zeros(3, complex))


def test_complex_values_decode_exactly_what_was_encoded():
    assert np.array_equal(store.complex_values(store.complex_variable("x", [1j, 2.0])), np.array([1j, 2.0]))


# --- atomic writes, recording ------------------------------------------------------------------


def test_an_exception_inside_a_write_leaves_no_file_and_no_temporary(tmp_path):
    target = tmp_path / "out" / "a.bin"
    with pytest.raises(RuntimeError), store.atomic_path(target) as tmp:
        tmp.write_bytes(b"half")
        raise RuntimeError("interrupted")
    assert list((tmp_path / "out").iterdir()) == []
    # an older file stays as it was
    store.atomic_write_bytes(target, b"old")
    with pytest.raises(RuntimeError), store.atomic_path(target) as tmp:
        tmp.write_bytes(b"new")
        raise RuntimeError("interrupted")
    assert target.read_bytes() == b"old" and [p.name for p in target.parent.iterdir()] == ["a.bin"]
    # a dataset NetCDF cannot hold (boolean attribute): no file, no temporary
    with pytest.raises(Exception, match="boolean"):
        store.write_dataset(xr.Dataset(attrs={"flag": True}), tmp_path / "b" / "b.nc")
    assert list((tmp_path / "b").iterdir()) == []


@pytest.mark.parametrize(("umask", "mode"), [(0o022, 0o644), (0o027, 0o640), (0o077, 0o600)])
def test_files_are_created_with_the_process_umask(tmp_path, umask, mode):
    """Every output and cache file (datasets, raw bytes, checksum sidecars) gets ``0666`` less
    the umask, as a file the user creates; written atomically all the same."""
    previous = os.umask(umask)
    try:
        written = [
            store.write_dataset(_dataset(), tmp_path / "a.nc"),
            store.atomic_write_bytes(tmp_path / "b.bin", b"b"),
            store.write_sidecar(tmp_path / "b.bin"),
        ]
        store.write_dataset(_dataset(), tmp_path / "a.nc")  # replacing a file: the same mode
    finally:
        os.umask(previous)
    assert {p.name: stat.S_IMODE(p.stat().st_mode) for p in written} == dict.fromkeys(
        ["a.nc", "b.bin", "b.bin.sha256.json"], mode
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.nc", "b.bin", "b.bin.sha256.json"]
    assert store.read_dataset(tmp_path / "a.nc").state.size == 3000


def test_an_atomic_write_syncs_the_file_before_renaming_it(tmp_path, monkeypatch):
    """The data reach the disk before the rename publishes them (a crash leaves the old file or
    the whole new one), and the directory entry after it."""
    events = []
    real_fsync, real_replace = os.fsync, os.replace
    monkeypatch.setattr(
        os, "fsync", lambda fd: events.append(("fsync", os.readlink(f"/proc/self/fd/{fd}"))) or real_fsync(fd)
    )
    monkeypatch.setattr(os, "replace", lambda a, b: events.append(("replace", str(b))) or real_replace(a, b))
    target = store.atomic_write_bytes(tmp_path / "a.bin", b"data")
    kinds = [kind for kind, _ in events]
    assert kinds == ["fsync", "replace", "fsync"]
    assert Path(events[0][1]).parent == tmp_path and Path(events[0][1]).name.startswith(".a.bin.")
    assert events[1][1] == str(target) and events[2][1] == str(tmp_path)


def test_a_failed_figure_leaves_no_file(tmp_path):
    import matplotlib.pyplot as plt

    from fsistab.plots import save_figure

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    path = save_figure(fig, tmp_path / "fig.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    from matplotlib.artist import Artist

    class Broken(Artist):  # fails half-way through the drawing, as an interrupted savefig would
        def draw(self, renderer):
            raise RuntimeError("drawing failed")

    fig, ax = plt.subplots()
    ax.add_artist(Broken())
    with pytest.raises(RuntimeError, match="drawing failed"):
        save_figure(fig, tmp_path / "bad.png")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig.png"]
    assert not plt.fignum_exists(fig.number)  # closed all the same


def test_recording_collects_the_paths_written(tmp_path):
    store.write_dataset(_dataset(), tmp_path / "before.nc")
    with store.recording() as outer:
        store.write_dataset(_dataset(), tmp_path / "a.nc")
        with store.recording() as inner:
            store.atomic_write_bytes(tmp_path / "b.bin", b"b")
        with pytest.raises(RuntimeError), store.atomic_path(tmp_path / "c.bin") as tmp:
            tmp.write_bytes(b"c")
            raise RuntimeError("not written")
    store.atomic_write_bytes(tmp_path / "after.bin", b"x")
    assert outer == [tmp_path / "a.nc", tmp_path / "b.bin"]
    assert inner == [tmp_path / "b.bin"]


def test_recording_is_per_thread(tmp_path):
    import threading

    seen = []
    with store.recording() as mine:

        def other():
            seen.append(store.atomic_write_bytes(tmp_path / "x", b"x"))

        thread = threading.Thread(target=other)
        thread.start()
        thread.join()
    assert seen and mine == []


# --- writable directories ----------------------------------------------------------------------


def test_a_writable_directory_is_created(tmp_path):
    path = store.ensure_writable_dir(tmp_path / "a" / "b", "--out")
    assert path.is_dir() and list(path.iterdir()) == []  # the probe file is gone


@pytest.mark.parametrize("where", ["file", "under_file", "proc"])
def test_an_unwritable_directory_is_refused_in_one_line(tmp_path, where):
    regular = tmp_path / "regular"
    regular.write_text("x")
    path = {"file": regular, "under_file": regular / "sub", "proc": Path("/proc/x")}[where]
    with pytest.raises(InputError) as error:
        store.ensure_writable_dir(path, "--out")
    message = str(error.value)
    assert message.startswith(f"--out {path} is not a writable directory: ") and "\n" not in message
    assert regular.read_text() == "x"


# --- resumable tables --------------------------------------------------------------------------


def test_a_resumable_table_resumes_its_records(tmp_path):
    path = tmp_path / "t.nc"
    identity = {"reynolds": 40.0, "mesh_key": "abc"}
    table = store.ResumableTable(path, identity)
    assert table.records == []
    records = [{"frequency": w, "transfer": np.full((2, 3), w * (1 + 1j))} for w in (0.5, 0.1, 2.0)]
    for record in records[:2]:
        table.append(record)
    again = store.ResumableTable(path, identity)
    assert len(again) == 2
    for got, want in zip(again.records, records[:2], strict=True):
        assert got["frequency"] == want["frequency"] and np.array_equal(got["transfer"], want["transfer"])
    again.append(records[2])
    assert [r["frequency"] for r in store.ResumableTable(path, identity).records] == [0.5, 0.1, 2.0]
    with pytest.raises(CacheError, match="another computation") as error:
        store.ResumableTable(path, {**identity, "reynolds": 41.0})
    assert "\n" not in str(error.value) and path.exists()  # refused, not overwritten


@pytest.mark.parametrize("kind", ["truncated", "edited"])
def test_a_damaged_resumable_table_starts_afresh(tmp_path, caplog, kind):
    path = tmp_path / "t.nc"
    table = store.ResumableTable(path, {"case": "x"})
    table.append({"value": np.arange(600.0)})
    damage(path, kind, variable="value")
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        fresh = store.ResumableTable(path, {"case": "x"})
    assert len(fresh) == 0 and "recomputing" in caplog.text and str(path) in caplog.text


def test_records_of_several_kinds_state_and_finish_survive_a_rerun(tmp_path):
    """A curve-like table: points and folds along their own dimensions, the last mode replaced (not
    appended), ``finish`` marks it complete with its stop; appending again reopens it."""
    path = tmp_path / "t.nc"
    fields = {"point": ("mass", "velocity"), "fold": ("fold_mass", "fold_index")}
    table = store.ResumableTable(path, {"case": "x"}, fields, state=("mode",))
    for i, m in enumerate((1.0, 2.0, 3.0)):
        table.append({"mass": m, "velocity": 10 * m}, kind="point", state={"mode": np.full(4, m * 1j)})
        if i == 1:
            table.append({"fold_mass": 2.5, "fold_index": 1}, kind="fold", save=False)
    assert not store.ResumableTable(path, {"case": "x"}, fields, state=("mode",)).complete
    table.finish({"stop": "max_points"})
    again = store.ResumableTable(path, {"case": "x"}, fields, state=("mode",))
    assert again.complete and again.final_attrs == {"stop": "max_points"} and len(again) == 4
    assert [(r["mass"], r["velocity"]) for r in again.records_of("point")] == [(1, 10), (2, 20), (3, 30)]
    assert [(r["fold_mass"], r["fold_index"]) for r in again.records_of("fold")] == [(2.5, 1)]
    assert np.array_equal(again.state["mode"], np.full(4, 3j))
    ds = store.read_dataset(path, expect={"case": "x", "complete": 1, "stop": "max_points"})
    assert ds.sizes["point"] == 3 and ds.sizes["fold"] == 1 and ds["mass"].dims == ("point",)
    again.append({"mass": 4.0, "velocity": 40.0}, kind="point")
    reopened = store.ResumableTable(path, {"case": "x"}, fields, state=("mode",))
    assert not reopened.complete and reopened.final_attrs == {} and len(reopened.records_of("point")) == 4
    assert np.array_equal(reopened.state["mode"], np.full(4, 3j))  # not given: kept
    with pytest.raises(ValueError, match="record names"):
        again.append({"mass": 5.0}, kind="point")
    with pytest.raises(ValueError, match="kind"):
        again.append({"mass": 5.0, "velocity": 1.0}, kind="other")
    with pytest.raises(ValueError, match="state"):
        again.append({"mass": 5.0, "velocity": 1.0}, kind="point", state={"speed": 1.0})
    with pytest.raises(ValueError, match="clash"):
        again.finish({"case": "y"})


def test_finishing_again_with_nothing_new_leaves_the_file_as_it_is(tmp_path):
    """A complete table read back and finished with the same attributes, nothing appended: the
    file keeps its bytes (a march started from it is fingerprinted by them). Other attributes, or
    a record appended, write it anew."""
    path = tmp_path / "t.nc"
    table = store.ResumableTable(path, {"case": "x"}, state=("mode",))
    table.append({"value": 1.0}, state={"mode": np.zeros(3)})
    table.finish({"stop": "duration"})
    written = path.read_bytes()
    again = store.ResumableTable(path, {"case": "x"}, state=("mode",))
    assert again.finish({"stop": "duration"}) == path and path.read_bytes() == written
    again.finish({"stop": "interrupted"})
    reread = store.ResumableTable(path, {"case": "x"}, state=("mode",))
    assert path.read_bytes() != written and reread.final_attrs == {"stop": "interrupted"}
    again.append({"value": 2.0})
    again.finish({"stop": "interrupted"})
    assert len(store.ResumableTable(path, {"case": "x"}, state=("mode",))) == 2


@given(
    shapes=st.lists(st.tuples(st.integers(0, 4), st.integers(1, 3)), min_size=1, max_size=4),
    complex_=st.booleans(),
)
@settings(max_examples=15, deadline=None)
def test_ragged_records_come_back_with_their_own_shapes(tmp_path_factory, shapes, complex_):
    """Fields whose shape differs between records (reduced models' matrices) are padded on disk
    and cut back on reading: every value equal to what was appended, dtype kind included."""
    path = tmp_path_factory.mktemp("ragged") / "t.nc"
    rng = np.random.default_rng(len(shapes))
    records = []
    for n, k in shapes:
        matrix = rng.standard_normal((n, k)) + (1j * rng.standard_normal((n, k)) if complex_ else 0)
        records.append({"matrix": matrix, "ends": np.arange(1, k + 1), "size": n})
    table = store.ResumableTable(path, {"case": "ragged"}, {"model": ("matrix", "ends", "size")})
    for record in records:
        table.append(record)
    back = store.ResumableTable(path, {"case": "ragged"}, {"model": ("matrix", "ends", "size")}).records
    for got, want in zip(back, records, strict=True):
        assert got["matrix"].shape == want["matrix"].shape and np.array_equal(got["matrix"], want["matrix"])
        assert np.iscomplexobj(got["matrix"]) == complex_
        assert np.array_equal(got["ends"], want["ends"]) and got["size"] == want["size"]


def test_a_table_of_another_layout_is_refused_and_an_older_file_recomputed(tmp_path, caplog):
    """Same identity, other fields: another computation's table (CacheError, kept). A checksummed
    file with no table layout (written before the tables) is reported and started afresh."""
    path = tmp_path / "t.nc"
    store.ResumableTable(path, {"case": "x"}, {"point": ("mass",)}).append({"mass": 1.0})
    with pytest.raises(CacheError, match="another computation") as error:
        store.ResumableTable(path, {"case": "x"}, {"point": ("mass", "velocity")})
    assert "\n" not in str(error.value) and path.exists()
    old = tmp_path / "old.nc"
    store.write_dataset(xr.Dataset({"mass": ("point", [1.0, 2.0])}, attrs={"case": "x"}), old)
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        fresh = store.ResumableTable(old, {"case": "x"}, {"point": ("mass",)})
    assert len(fresh) == 0 and "older layout" in caplog.text and "recomputing" in caplog.text
    assert not old.exists() and (tmp_path / "old.nc.damaged").exists()
    with pytest.raises(ValueError):
        store.ResumableTable(path, {"complete": 1})
    with pytest.raises(ValueError):
        store.ResumableTable(path, {"case": "x"}, {"point": ("mass",), "fold": ("mass",)})


# --- cached kinds on a real fluid: transfer samples, reduced models ----------------------------


@pytest.fixture(scope="module")
def cylinder_fluid(cylinder_coarse_40):
    from fsistab.operators import fluid_operators

    return fluid_operators(cylinder_coarse_40)


def test_modes_vtk_is_written_atomically_under_its_full_name(cylinder_coarse_40, cylinder_fluid, tmp_path):
    """VTKOutput appends ".vtu" itself: the file is written under a temporary name and renamed; a
    name with a dot (α0 = 2.5) keeps it."""
    from fsistab.vtk import write_modes_vtk

    mode = np.exp(1j * np.arange(len(cylinder_fluid.free_dofs)) / 7.0)
    with store.recording() as written:
        path = write_modes_vtk(
            cylinder_coarse_40, cylinder_fluid.free_dofs, {"m0": mode}, tmp_path / "modes_a2.5"
        )
    assert path == tmp_path / "modes_a2.5.vtu" and written == [path]
    assert [p.name for p in tmp_path.iterdir()] == ["modes_a2.5.vtu"]  # no temporary left
    data = path.read_bytes()  # XML header, binary appended data
    assert data.startswith(b"<?xml") and b"m0_velocity_re" in data and b"m0_pressure_im" in data
    assert data.rstrip().endswith(b"</VTKFile>")


OMEGA = (0.1, 0.5)


@pytest.fixture(scope="module")
def transfer_reference(cylinder_fluid, tmp_path_factory):
    """``G(iω)`` computed once with its samples file, and how many factorisations that took."""
    from fsistab.transfer import viscous_theodorsen_dataset

    path = tmp_path_factory.mktemp("transfer") / "samples.nc"
    counter = FactorCounter()
    ds = viscous_theodorsen_dataset(cylinder_fluid, OMEGA, counter=counter, samples_path=path)
    return ds, path.read_bytes(), counter.count


@pytest.mark.parametrize("kind", ["truncated", "flipped", "edited"])
def test_damaged_transfer_samples_are_recomputed(cylinder_fluid, transfer_reference, tmp_path, caplog, kind):
    """The issue's example: samples shifted by 1 would change the loads by 50 %."""
    from fsistab.transfer import viscous_theodorsen_dataset

    first, saved, factorisations = transfer_reference
    path = tmp_path / "transfer" / "samples.nc"
    path.parent.mkdir()
    path.write_bytes(saved)
    repeat_count, damaged_count = FactorCounter(), FactorCounter()
    repeat = viscous_theodorsen_dataset(cylinder_fluid, OMEGA, counter=repeat_count, samples_path=path)
    assert repeat_count.count == factorisations - len(OMEGA)  # the samples were reused
    damage(path, kind, variable="transfer")
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        again = viscous_theodorsen_dataset(cylinder_fluid, OMEGA, counter=damaged_count, samples_path=path)
    assert damaged_count.count == factorisations  # every sample recomputed
    assert str(path) in caplog.text and "recomputing" in caplog.text
    for name in ("transfer", "viscous_loads"):
        want = store.complex_values(first[name])
        assert np.allclose(store.complex_values(repeat[name]), want, rtol=1e-12, atol=0)
        assert np.allclose(store.complex_values(again[name]), want, rtol=1e-10, atol=1e-14)


def test_transfer_samples_of_another_flow_are_refused(cylinder_fluid, tmp_path):
    from fsistab.transfer import viscous_theodorsen_dataset

    path = tmp_path / "samples.nc"
    store.ResumableTable(path, {"reynolds": 100.0, "alpha0_deg": 0.0, "mesh_key": "x"}).save()
    counter = FactorCounter()
    with pytest.raises(CacheError, match="another computation"):
        viscous_theodorsen_dataset(cylinder_fluid, [0.1], counter=counter, samples_path=path)
    assert counter.count == 0


@pytest.mark.parametrize("kind", ["truncated", "edited"])
def test_damaged_reduced_models_are_rebuilt(cylinder_fluid, tmp_path, caplog, kind):
    from fsistab.reduced_model import ReducedModels

    path = tmp_path / "models.nc"
    settings_ = dict(tolerance=1e-4, blocks=8, path=path)
    model = ReducedModels(cylinder_fluid, **settings_).build(0.5)
    reused = ReducedModels(cylinder_fluid, **settings_).models
    assert len(reused) == 1 and np.array_equal(reused[0].jr, model.jr) and reused[0].shift == 0.5j
    damage(path, kind, variable="jr")
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        models = ReducedModels(cylinder_fluid, **settings_)
    assert models.models == [] and str(path) in caplog.text and "recomputing" in caplog.text
    if kind == "edited":  # the rebuilt model is the original (once is enough: a few seconds)
        rebuilt = models.build(0.5)
        assert rebuilt.interval == model.interval
        assert np.allclose(rebuilt.jr, model.jr, rtol=1e-10, atol=1e-12 * np.abs(model.jr).max())


# --- resumable neutral curves ------------------------------------------------------------------


def _curve_points():
    from fsistab.neutral_map import NeutralPoint

    mode = np.array([1 + 2j, -0.5j, 3.0])
    return [NeutralPoint(m, 5.0 + m / 100, 0.2, mode=mode * m, iterations=2) for m in (10.0, 20.0, 30.0)]


def _saved_curve(path, attrs, points, stop=None, folds=()):
    """A curve table as trace_curve_resumable leaves it: finished with ``stop``, or interrupted."""
    from fsistab.neutral import curve_table

    table = curve_table(path, attrs)
    for point in points:
        record = {"mass_ratio": point.mass_ratio, "reduced_velocity": point.reduced_velocity}
        table.append({**record, "frequency": point.frequency}, kind="point", state={"last_mode": point.mode})
    for fold in folds:
        record = {"fold_mass_ratio": fold.mass_ratio, "fold_reduced_velocity": fold.reduced_velocity}
        record |= {"fold_frequency": fold.frequency, "fold_index": fold.index, "fold_localised": 1}
        table.append(record, kind="fold")
    if stop is not None:
        table.finish({"stop": stop})


def test_a_finished_curve_is_read_back_with_its_complex_mode(tmp_path):
    from fsistab.neutral import trace_curve_resumable

    path = tmp_path / "curve.nc"
    points = _curve_points()
    _saved_curve(path, {"case": "a"}, points, stop="mass_range")
    # complete: nothing is computed (no fluid needed), the last mode decoded from its ``part`` encoding
    back = trace_curve_resumable(None, None, None, path, {"case": "a"})
    assert [p.mass_ratio for p in back] == [10.0, 20.0, 30.0]
    assert np.array_equal(back[-1].mode, points[-1].mode)
    with pytest.raises(CacheError, match="another computation"):
        trace_curve_resumable(None, None, None, path, {"case": "b"})


def test_an_interrupted_curve_continues_from_its_last_point(tmp_path, monkeypatch):
    """The continuation restarts at the last saved point with its mode, in the direction of the
    last step, for the points still wanted; its turning points are numbered along the whole curve
    and the table ends complete with the new stop."""
    import fsistab.neutral as neutral
    import fsistab.neutral_map as neutral_map

    path, attrs = tmp_path / "curve.nc", {"case": "a"}
    points = _curve_points()
    fold = neutral_map.TurningPoint(9.0, 5.05, 0.2, index=0, localised=True)
    _saved_curve(path, attrs, points, folds=[fold])
    calls = []

    class Curve:
        stops = ("max_points",)

    def continue_neutral_curve(fluid, start, template, on_point, on_fold, **options):
        calls.append((start, options))
        on_fold(neutral_map.TurningPoint(35.0, 5.4, 0.2, index=1, localised=False))
        on_point(neutral_map.NeutralPoint(40.0, 5.4, 0.2, mode=start.mode * 2, iterations=3))
        return Curve()

    monkeypatch.setattr(neutral, "continue_neutral_curve", continue_neutral_curve)
    traced = neutral.trace_curve_resumable(None, None, None, path, attrs, max_points=5)
    ((start, options),) = calls
    assert (start.mass_ratio, start.reduced_velocity) == (30.0, 5.3)
    assert np.array_equal(start.mode, points[-1].mode)
    assert options["max_points"] == 3  # 5 wanted, 3 saved: the last one is the new start
    assert options["initial_direction"] == pytest.approx((0.1, np.log(1.5)))
    assert [p.mass_ratio for p in traced] == [10.0, 20.0, 30.0, 40.0]
    table = neutral.curve_table(path, attrs)
    assert table.complete and table.final_attrs["stop"] == "max_points"
    assert [t.index for t in neutral.saved_turning_points(table)] == [0, 3]
    assert np.array_equal(table.state["last_mode"], points[-1].mode * 2)


@pytest.mark.parametrize("kind", ["truncated", "edited"])
def test_a_damaged_curve_is_reported_and_traced_afresh(tmp_path, caplog, monkeypatch, kind):
    """The damaged file is not resumed: tracing restarts from the given start point."""
    import fsistab.neutral as neutral
    import fsistab.neutral_map as neutral_map
    from fsistab.neutral_point import NeutralPoint

    path = tmp_path / "curve.nc"
    points = _curve_points()
    attrs = {"case": "a"}
    _saved_curve(path, attrs, points)  # interrupted
    damage(path, kind, variable="mass_ratio")
    started = []

    class Curve:
        stops = ("mass_range",)

    def continue_neutral_curve(fluid, start, template, on_point, on_fold, **options):
        started.append(start)
        on_point(neutral_map.NeutralPoint(start.mass_ratio * 2, 6.0, 0.3, mode=start.mode, iterations=1))
        return Curve()

    monkeypatch.setattr(neutral, "continue_neutral_curve", continue_neutral_curve)
    start = NeutralPoint(7.0, 4.0, 0.25, kind="flutter", mode=np.array([1j, 2.0]))
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        traced = neutral.trace_curve_resumable(None, start, None, path, attrs)
    assert started == [start] and str(path) in caplog.text and "recomputing" in caplog.text
    assert [p.mass_ratio for p in traced] == [7.0, 14.0]
    saved = store.read_dataset(path, expect=attrs)
    assert saved.mass_ratio.values.tolist() == [7.0, 14.0] and saved.attrs["complete"] == 1


def test_a_cache_variable_naming_a_file_is_refused_in_one_line(tmp_path, monkeypatch):
    """``FSISTAB_CACHE`` pointing at a file: a one-line InputError, not a traceback from the first
    write; a directory, or one still to be made, is accepted as it is."""
    from fsistab.errors import InputError

    a_file = tmp_path / "cache-file"
    a_file.write_text("not a directory")
    monkeypatch.setenv("FSISTAB_CACHE", str(a_file))
    with pytest.raises(InputError, match="FSISTAB_CACHE=.* is not a directory") as refused:
        store.default_cache_dir()
    assert "\n" not in str(refused.value)
    for directory in (tmp_path, tmp_path / "to-be-made"):
        monkeypatch.setenv("FSISTAB_CACHE", str(directory))
        assert store.default_cache_dir() == directory
