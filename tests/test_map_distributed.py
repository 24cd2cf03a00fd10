"""A transfer map's exact samples on dask.distributed workers (fsistab.map_distributed).

Plate, Re = 2900, coarse mesh, a small map (m in [500, 2000], ω in [0.12, 0.3], exact samples, 6
initial frequencies and refinement rounds up to 12). The map made on a 2-worker LocalCluster is
the serial map: the same frequencies, the same samples bit for bit, the same NetCDF variables, the
same factorisation counts; a rerun from its saved samples factorises nothing; the command hands
its workflow a client; bad execution options are refused in one line before any work. The same for
``fsistab critical``'s frequency sweep (m = 1000, U* in [2, 10]): on the cluster, the same
thresholds and modes bit for bit.
"""

import sys

import numpy as np
import pytest
from typer.testing import CliRunner

from fsistab.cli import app
from fsistab.errors import InputError
from fsistab.frequency_sweep import sweep_thresholds
from fsistab.linalg import FactorCounter
from fsistab.neutral_map import neutral_map_dataset
from fsistab.params import Solid
from fsistab.transfer_map import as_neutral_map, read_samples, samples_table, transfer_neutral_map

runner = CliRunner()
MAP = [
    "neutral", "--body", "plate", "--Re", "2900", "--mesh", "coarse", "--json",
    "--mass-ratio-range", "500", "2000", "--frequency-range", "0.12", "0.3",
    "--reduced-blocks", "0", "--max-frequencies", "12",
]  # fmt: skip
# a small map: 6 initial frequencies, then refinement rounds up to a budget of 12
SMALL_MAP = dict(
    mass_range=(500.0, 2000.0), omega_range=(0.12, 0.3), initial=6, max_samples=12, resonance_blocks=0
)


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal bit for bit (NaN included) for numbers, equal for strings."""
    if a.dtype.kind in "biufc":
        return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    return np.array_equal(a, b)


def _dataset(tmap):
    """The map's NetCDF variables, as ``fsistab neutral`` writes them."""
    return neutral_map_dataset(as_neutral_map(tmap, Solid()), {"method": "transfer"})


def test_a_map_on_a_local_cluster_is_the_serial_map(tmp_path, plate_operators, client):
    """The same map in this process (two threads) and on the 2-worker cluster: the same
    frequencies, samples (bit for bit, as saved), NetCDF variables and factorisation counts; a rerun
    on the cluster from the saved samples factorises nothing and draws the same map."""
    fluid = plate_operators
    counters = FactorCounter(), FactorCounter()
    paths = tmp_path / "serial.nc", tmp_path / "dask.nc"
    serial = transfer_neutral_map(fluid, Solid(), counter=counters[0], samples_path=paths[0], **SMALL_MAP)
    parallel = transfer_neutral_map(
        fluid, Solid(), counter=counters[1], samples_path=paths[1], client=client, **SMALL_MAP
    )
    assert counters[1].count == counters[0].count == serial.factorisations == parallel.factorisations > 8
    assert parallel.factorisations_total == serial.factorisations_total
    assert np.array_equal(parallel.frequencies, serial.frequencies)
    assert parallel.unresolved == serial.unresolved and len(serial.curves) >= 1
    a, b = _dataset(serial), _dataset(parallel)
    assert set(a.data_vars) == set(b.data_vars)
    for name in a.data_vars:
        assert _same_bits(a[name].values, b[name].values), name
    first, second = (read_samples(samples_table(p, fluid)) for p in paths)
    assert list(first) == list(second) and len(first) == serial.factorisations
    for w, x in first.items():
        assert _same_bits(x.transfer, second[w].transfer) and _same_bits(x.rate, second[w].rate)
    again = FactorCounter()
    rerun = transfer_neutral_map(
        fluid, Solid(), counter=again, samples_path=paths[1], client=client, **SMALL_MAP
    )
    assert again.count == rerun.factorisations == 0
    assert rerun.factorisations_total == serial.factorisations_total
    assert rerun.crossings_at(1000.0) == serial.crossings_at(1000.0)
    workers = client.run(lambda: dict(sys.modules["fsistab.map_distributed"]._WORKING))
    assert workers == {w: {} for w in client.scheduler_info()["workers"]}  # released after the map


def test_a_threshold_sweep_on_a_local_cluster_is_the_serial_sweep(plate_operators, client):
    """``fsistab critical``'s sweep (m = 1000, U* in [2, 10]) in this process (two threads) and with
    its samples on the 2-worker cluster: the same frequencies, thresholds and modes bit for bit,
    the same factorisations; the operators are released from the workers afterwards."""
    solid = Solid(mass_ratio=1000.0, reduced_velocity=2.0)
    counters = FactorCounter(), FactorCounter()
    serial = sweep_thresholds(plate_operators, solid, (2.0, 10.0), counter=counters[0], threads=2)
    parallel = sweep_thresholds(plate_operators, solid, (2.0, 10.0), counter=counters[1], client=client)
    assert counters[1].count == counters[0].count == serial.factorisations > 6
    assert _same_bits(parallel.frequencies, serial.frequencies)
    assert [t.kind for t in serial.thresholds] == ["flutter", "divergence"]
    for a, b in zip(serial.thresholds, parallel.thresholds, strict=True):
        assert (a.kind, a.reduced_velocity, a.frequency) == (b.kind, b.reduced_velocity, b.frequency)
        assert _same_bits(a.mode, b.mode)
    workers = client.run(lambda: dict(sys.modules["fsistab.map_distributed"]._WORKING))
    assert workers == {w: {} for w in client.scheduler_info()["workers"]}


CRITICAL = ["critical", "--body", "plate", "--mesh", "coarse", "--mass-ratio", "1000"]


@pytest.mark.parametrize("command, name", [(MAP, "stability_map"), (CRITICAL, "critical_points")])
@pytest.mark.parametrize("option", ["--workers", "--scheduler"])
def test_the_command_hands_the_workflow_a_client(tmp_path, monkeypatch, client, option, command, name):
    """``fsistab neutral`` or ``fsistab critical`` with ``--workers 2`` (a new LocalCluster) or
    ``--scheduler ADDRESS`` (the module's cluster): the workflow gets a client of two workers (the
    workflow itself is replaced here: what it makes is the tests above)."""
    from fsistab import workflows

    seen = []

    def workflow(*args, client=None):
        seen.append(len(client.scheduler_info()["workers"]))
        raise InputError("stopped after the client was seen")

    monkeypatch.setattr(workflows, name, workflow)
    value = "2" if option == "--workers" else client.scheduler.address
    result = runner.invoke(
        app, [*command, option, value, "--out", str(tmp_path / "o"), "--cache", str(tmp_path)]
    )
    assert "stopped after the client was seen" in result.output and seen == [2]


def test_critical_refuses_the_options_with_tracking_in_one_line(tmp_path):
    out = tmp_path / "out"
    result = runner.invoke(app, [*CRITICAL, "--method", "tracking", "--workers", "2", "--out", str(out)])
    assert result.exit_code == 2 and "--method transfer only" in result.output
    assert result.output.count("\n") == 1 and not out.exists()


@pytest.mark.parametrize(
    "args, message",
    [
        (["--workers", "2", "--scheduler", "tcp://h:1"], "not both"),
        (["--workers", "0"], "--workers must be an integer in [1, 256]"),
        (["--scheduler", "garbage"], "missing port number"),
        (["--scheduler", "udp://localhost:8786"], "unknown address scheme 'udp'"),
        (["--method", "continuation", "--workers", "2"], "--method transfer only"),
    ],
)
def test_bad_execution_options_are_refused_in_one_line(tmp_path, args, message):
    out = tmp_path / "out"
    result = runner.invoke(app, [*MAP, *args, "--out", str(out), "--cache", str(tmp_path / "c")])
    assert result.exit_code == 2 and message in result.output and result.output.count("\n") == 1
    assert not out.exists()  # refused before anything was created


def test_without_dask_the_options_say_what_to_install(tmp_path, monkeypatch):
    for name in ("dask", "distributed"):
        monkeypatch.setitem(sys.modules, name, None)
    result = runner.invoke(
        app, [*MAP, "--workers", "2", "--out", str(tmp_path / "o"), "--cache", str(tmp_path)]
    )
    assert result.exit_code == 2 and result.output.count("\n") == 1
    assert "need dask.distributed: pip install 'fsistab[cluster]'" in result.output
