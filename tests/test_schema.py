"""The data dictionary (fsistab.schema): every variable fsistab writes carries CF ``units`` and
``long_name``, every file its provenance; the values, dtypes and names are not changed, and files
written before the dictionary are still read.

The fast tests check the annotation on hand-made datasets; the slow one (``pytest -m slow``) runs
every command on the coarse mesh and checks every NetCDF file it leaves, results and cache entries.
Elsewhere in the suite, a dataset written with an undescribed variable raises
:class:`fsistab.schema.UndescribedVariableWarning`, which the suite turns into an error.
"""

import datetime
import json
import subprocess
import sys
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

from fsistab import __version__, schema, store

NOW = datetime.datetime(2026, 12, 2, 17, 3, 11, tzinfo=datetime.UTC)


def _spectrum_like() -> xr.Dataset:
    """Names as the spectrum, steady and transfer files have them, one of each role: a data
    variable, a dimension coordinate, a label coordinate, complex data, text."""
    return xr.Dataset(
        {
            "growth_rate": ("mode", np.array([-0.1, 0.02])),
            "frequency": ("mode", np.array([0.2, 0.7])),
            "label": ("mode", np.array(["fluid", "solid"])),
            "shift": store.complex_variable("mode", [0.5j, 1j]),
            "transfer": store.complex_variable(("frequency_index", "load", "state"), np.ones((1, 3, 4))),
        },
        coords={
            "mode": np.arange(2),
            "load": ["force_x", "force_y", "moment"],
            "state": ["h", "theta", "hdot", "thetadot"],
        },
        attrs={"body": "plate", "reynolds": 2900.0, "ndof": 15335},
    )


# --- annotation ---------------------------------------------------------------------------------


def test_every_variable_gets_units_and_long_name_from_the_dictionary():
    ds = _spectrum_like().drop_dims("frequency_index")
    out = schema.annotate(ds)
    assert schema.undescribed(out) == []
    assert out.growth_rate.attrs == schema.VARIABLES["growth_rate"].attrs()
    assert out["mode"].attrs["units"] == "1"
    # text carries a long name and no unit
    assert "units" not in out.label.attrs and out.label.attrs["long_name"]
    assert "units" not in out["part"].attrs
    # a dimension coordinate named like a data variable of another meaning: the coordinate's entry
    assert out["state"].attrs == schema.DIMENSION_COORDINATES["state"].attrs()
    steady = schema.annotate(xr.Dataset({"state": ("dof", np.zeros(4))}))
    assert steady.state.attrs == schema.VARIABLES["state"].attrs()


def test_annotation_keeps_the_values_the_names_and_the_caller_dataset():
    ds = _spectrum_like()
    ds["frequency"].attrs["units"] = "rad/s"  # a variable's own attributes win
    ds["growth_rate"].attrs["description"] = "kept"
    before = ds.copy(deep=True)
    out = schema.describe(ds, argv=["fsistab", "spectrum"])
    xr.testing.assert_identical(ds, before)  # the caller's dataset, attributes included
    assert list(out.variables) == list(ds.variables)
    for name, variable in ds.variables.items():
        assert out[name].dtype == variable.dtype and np.array_equal(out[name].values, variable.values)
    assert out.frequency.attrs["units"] == "rad/s"
    assert out.growth_rate.attrs["description"] == "kept" and out.growth_rate.attrs["units"] == "1"
    assert {k: out.attrs[k] for k in ds.attrs} == ds.attrs  # the case attributes, unchanged


def test_a_name_missing_from_the_dictionary_is_reported():
    ds = xr.Dataset(
        {"frequency": ("mode", [0.1]), "mystery": ("mode", [1.0]), "note": ("mode", ["x"])},
        coords={"mode": [0], "bin": ("mode", [3])},
    )
    assert schema.undescribed(ds) == ["bin", "frequency", "mode", "mystery", "note"]
    assert schema.undescribed(schema.annotate(ds)) == ["bin", "mystery", "note"]
    own = ds.assign(mystery=ds.mystery.assign_attrs(units="1", long_name="a test quantity"))
    own = own.assign(note=own.note.assign_attrs(long_name="a test note"))
    assert schema.undescribed(schema.annotate(own)) == ["bin"]  # text needs a long name only


def test_writing_an_undescribed_variable_warns_and_still_writes(tmp_path):
    ds = xr.Dataset({"mystery": ("point", [1.0, 2.0])})
    with pytest.warns(schema.UndescribedVariableWarning, match="no units or long_name for mystery "):
        path = store.write_dataset(ds, tmp_path / "m.nc")
    assert np.array_equal(store.read_dataset(path).mystery.values, [1.0, 2.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        store.write_dataset(_spectrum_like().drop_dims("frequency_index"), tmp_path / "s.nc")


def test_a_flow_parameter_value_has_the_parameter_unit():
    for parameter, units in (("reynolds", "1"), ("alpha0", "degree")):
        ds = xr.Dataset(
            {"growth_rate": ("iterate", [0.1]), "fold_parameter_value": ("fold", [3.0])},
            coords={"iterate": [0], "value": ("iterate", [5.0]), "fold": [0]},
            attrs={"parameter": parameter},
        )
        out = schema.annotate(ds)
        assert out.value.attrs["units"] == units and out.fold_parameter_value.attrs["units"] == units
    # without a known parameter the value is not described (rather than described wrongly)
    assert "value" in schema.undescribed(schema.annotate(ds.assign_attrs(parameter="mach")))


def test_families_of_names_are_described():
    ds = xr.Dataset(
        {
            "viscous_flutter0_mass_ratio": ("viscous_point0", [1.0]),
            "viscous_flutter12_reduced_velocity": ("viscous_point12", [4.0]),
            "jr_shape": (("model", "jr_axis"), np.array([[2, 2]])),
        }
    )
    out = schema.annotate(ds)
    assert schema.undescribed(out) == []
    assert "curve 12" in out.viscous_flutter12_reduced_velocity.attrs["long_name"]
    assert "jr" in out.jr_shape.attrs["long_name"]


def test_every_unit_survives_a_file_with_the_dtype_unchanged(tmp_path):
    """xarray decodes a variable whose unit is a time unit ("seconds", "days since ...") into
    times: no unit of the dictionary may be one."""
    entries = {**schema.VARIABLES, **{f"coordinate_{k}": v for k, v in schema.DIMENSION_COORDINATES.items()}}
    numeric = {name: field for name, field in entries.items() if field.units is not None}
    ds = xr.Dataset(
        {
            f"v{i}": ("n", np.arange(3, dtype=float) + i, field.attrs())
            for i, field in enumerate(numeric.values())
        }
    )
    back = store.read_dataset(store.write_dataset(ds, tmp_path / "units.nc"))
    for name, variable in ds.data_vars.items():
        assert back[name].dtype == np.float64 and np.array_equal(back[name].values, variable.values)
        assert back[name].attrs["units"] == variable.attrs["units"]


# --- provenance --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("argv", "command"),
    [
        (["/venv/bin/fsistab", "neutral", "--mesh", "coarse"], "fsistab neutral --mesh coarse"),
        (["/src/fsistab/cli.py", "steady", "--out", "my dir"], "fsistab steady --out 'my dir'"),
        (["run_map.py", "--fast"], "python run_map.py --fast"),
        ([""], "python"),
        ([], "python"),
    ],
)
def test_the_history_names_the_command_line(argv, command):
    attrs = schema.provenance(argv, NOW)
    assert attrs["history"] == f"2026-12-02T17:03:11Z {command}"


def test_provenance_says_conventions_and_versions():
    attrs = schema.provenance(["fsistab", "steady"], NOW)
    assert attrs["Conventions"] == "CF-1.10"
    assert attrs["fsistab_version"] == __version__ == "0.5.0"
    assert attrs["source"] == f"fsistab {__version__}"
    versions = json.loads(attrs["software_versions"])
    assert versions["fsistab"] == __version__ and versions["xarray"] == xr.__version__
    assert versions["h5py"] == h5py.__version__ and versions["numpy"] == np.__version__
    assert set(attrs) == set(schema.PROVENANCE_ATTRS)


def test_the_history_reads_the_command_line_at_each_write(monkeypatch):
    monkeypatch.setattr(sys, "argv", ["/venv/bin/fsistab", "spectrum", "--Re", "60"])
    assert schema.describe(xr.Dataset()).attrs["history"].endswith(" fsistab spectrum --Re 60")
    monkeypatch.setattr(sys, "argv", ["/venv/bin/fsistab", "steady"])
    assert schema.describe(xr.Dataset()).attrs["history"].endswith(" fsistab steady")


def test_a_file_written_again_keeps_its_history_below_the_new_line():
    first = schema.describe(xr.Dataset(), argv=["fsistab", "neutral"])
    second = schema.describe(first, argv=["fsistab", "neutral", "--max-points", "9"])
    new, old = second.attrs["history"].split("\n")
    assert new.endswith("fsistab neutral --max-points 9") and old == first.attrs["history"]


def test_a_written_file_describes_itself(tmp_path):
    path = store.write_dataset(_spectrum_like(), tmp_path / "s.nc")
    with h5py.File(path, "r") as f:  # as any NetCDF reader sees it, without xarray's decoding
        assert f.attrs["Conventions"] == "CF-1.10" and f.attrs["fsistab_version"] == __version__
        assert f["growth_rate"].attrs["units"] == "1"
        assert f["growth_rate"].attrs["long_name"] == schema.VARIABLES["growth_rate"].long_name
        assert f.attrs["body"] == "plate" and f.attrs["ndof"] == 15335
    back = store.read_dataset(path, expect={"body": "plate"})
    assert back.history.startswith(datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d"))


def test_a_file_written_before_the_dictionary_is_still_read(tmp_path):
    """A cache entry of an earlier fsistab: no units, no provenance, its checksum over what it
    holds; read as it is (variable attributes never entered the checksum)."""
    ds = _spectrum_like()
    path = tmp_path / "old.nc"
    ds.to_netcdf(path, engine=store.NETCDF_ENGINE)
    with xr.open_dataset(path, engine=store.NETCDF_ENGINE) as written:
        checksum = store.dataset_checksum(written.load())
    with h5py.File(path, "r+") as f:
        f.attrs[store.CHECKSUM_ATTR] = checksum
    back = store.read_dataset(path, expect={"body": "plate"})
    assert "units" not in back.growth_rate.attrs and "history" not in back.attrs
    assert np.array_equal(back.growth_rate.values, ds.growth_rate.values)
    # the checksum ignores variable attributes: describing a dataset does not change it
    assert store.dataset_checksum(schema.annotate(ds)) == store.dataset_checksum(ds)


def test_a_resumed_table_keeps_the_history_of_each_run(tmp_path):
    path = tmp_path / "curve.nc"
    identity = {"reynolds": 2900.0}
    fields = {"point": ("mass_ratio", "reduced_velocity")}
    table = store.ResumableTable(path, identity, fields)
    table.append({"mass_ratio": 1.0, "reduced_velocity": 4.0})
    first = store.read_dataset(path).history
    resumed = store.ResumableTable(path, identity, fields)
    resumed.append({"mass_ratio": 2.0, "reduced_velocity": 4.5})
    resumed.finish({"stop": "max_points"})
    lines = store.read_dataset(path).history.split("\n")
    assert len(lines) == 2 and lines[1] == first  # one line per run, however many saves
    again = store.ResumableTable(path, identity, fields)
    assert again.final_attrs == {"stop": "max_points"}  # provenance is not a final attribute
    with pytest.raises(ValueError, match="clash"):
        again.finish({"history": "mine"})


# --- every file of every command -----------------------------------------------------------------

# each command on the coarse mesh with the smallest settings that still write every file it writes
COMMANDS = {
    "steady": ["steady", "--body", "cylinder", "--Re", "40"],
    "spectrum": ["spectrum", "--body", "cylinder", "--Re", "60", "--mass-ratio", "20", "--no-vtk"],
    "slopes": ["slopes", "--Re", "2900"],
    "critical": ["critical", "--Re", "2900", "--mass-ratio", "1000", "--reduced-velocity-range", "4", "5"],
    "neutral": [
        "neutral", "--Re", "2900", "--method", "transfer", "--mass-ratio-range", "500", "2000",
        "--frequency-range", "0.1", "0.3",
    ],
    "neutral-continuation": [
        "neutral", "--Re", "2900", "--method", "continuation", "--mass-ratio-range", "500", "2000",
        "--reduced-velocity-range", "4", "5", "--points", "3", "--max-points", "2",
    ],
    "flow-neutral": [
        "flow-neutral", "--parameter", "reynolds", "--range", "2000", "2900", "--Re", "2900",
        "--mass-ratio", "1000", "--reduced-velocity-range", "4", "5", "--points", "3", "--max-points", "2",
    ],
    "theodorsen": ["theodorsen", "--Re", "2900", "--mass-ratio-range", "500", "2000", "--points", "3"],
    "transfer": ["transfer", "--Re", "2900", "--points", "3"],
    "onset": ["onset", "--body", "cylinder", "--guess", "47"],
    "study": ["study", "--body", "cylinder", "--Re", "40", "--slopes", "--modes"],
    "study-thresholds": [
        "study", "--Re", "2900", "--thresholds", "1000", "--reduced-velocity-range", "4", "5",
        "--points", "3",
    ],
    "sensitivity": [
        "sensitivity", "--Re", "2900", "--mass-ratio", "1000", "--reduced-velocity-range", "4", "5",
        "--points", "4", "--wake-shift", "0+11i",
    ],
}  # fmt: skip


@pytest.mark.slow
def test_every_file_of_every_command_describes_itself(tmp_path):
    """Every NetCDF file the commands write (results in ``--out``, entries in ``--cache``): every
    variable has units (text: a long name), the file its provenance with the command line."""
    out, cache = tmp_path / "out", tmp_path / "cache"
    for name, args in COMMANDS.items():
        command = [sys.executable, "-m", "fsistab.cli", *args, "--mesh", "coarse"]
        command += ["--out", str(out / name), "--cache", str(cache)]
        done = subprocess.run(command, capture_output=True, text=True, timeout=1200)
        assert done.returncode == 0, f"{name}: {done.stderr[-3000:]}"
        assert "UndescribedVariableWarning" not in done.stderr, done.stderr
    files = sorted(Path(tmp_path).rglob("*.nc"))
    assert len(files) > len(COMMANDS)
    for path in files:
        ds = store.read_dataset(path)
        assert schema.undescribed(ds) == [], path
        assert ds.attrs["Conventions"] == "CF-1.10", path
        assert " fsistab " in ds.attrs["history"] + " ", path
