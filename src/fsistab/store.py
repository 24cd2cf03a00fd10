"""Results store: cache keys, atomic writes and NetCDF I/O (ARCHITECTURE.md, `store`).

A cache entry is written under a temporary name in its final directory and renamed, so an
interrupted run never leaves a partial file behind. Its key is a hash of every input that changes
it, including the discretisation's software versions; a corrupt or mismatched entry is refused
with a :class:`~fsistab.errors.CacheError`.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

import xarray as xr

from fsistab.errors import CacheError

NETCDF_ENGINE = "h5netcdf"


def software_versions() -> dict[str, str]:
    """Versions that change the discretisation (dof numbering, meshing, solver defaults)."""
    import ngsolve

    from fsistab import __version__

    return {"fsistab": __version__, "ngsolve": ngsolve.__version__}


def default_cache_dir() -> Path:
    """``$FSISTAB_CACHE`` if set, else ``~/.cache/fsistab``."""
    env = os.environ.get("FSISTAB_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "fsistab"


def cache_key(kind: str, inputs: dict) -> str:
    """Stable hash of a JSON-serialisable description of every input of a cache entry."""
    payload = json.dumps({"kind": kind, "inputs": inputs, "versions": software_versions()}, sort_keys=True)
    return hashlib.sha256(payload.encode()).hexdigest()[:20]


@contextlib.contextmanager
def atomic_path(path: Path, suffix: str = "") -> Iterator[Path]:
    """Yield a temporary path next to ``path``; rename it to ``path`` only if the block succeeds."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # the suffix stays last: some writers (Netgen) append their own extension otherwise
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part" + suffix, dir=path.parent)
    os.close(fd)
    tmp = Path(tmp)
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def write_dataset(ds: xr.Dataset, path: Path) -> Path:
    """Write ``ds`` as NetCDF-4 atomically."""
    path = Path(path)
    with atomic_path(path, ".nc") as tmp:
        ds.to_netcdf(tmp, engine=NETCDF_ENGINE)
    return path


def read_dataset(path: Path, expect: dict | None = None) -> xr.Dataset:
    """Read a NetCDF file fully into memory, checking that its attributes match ``expect``.

    Raises :class:`CacheError` naming the file when it is missing, unreadable or mismatched.
    """
    path = Path(path)
    if not path.is_file():
        raise CacheError(f"file not found: {path}")
    try:
        with xr.open_dataset(path, engine=NETCDF_ENGINE) as ds:
            ds = ds.load()
    except Exception as exc:  # h5py/netCDF raise many types for a damaged file
        raise CacheError(f"cannot read {path} (corrupt or not NetCDF): {type(exc).__name__}") from None
    for name, value in (expect or {}).items():
        if ds.attrs.get(name) != value:
            raise CacheError(
                f"{path} does not match the request: {name} is {ds.attrs.get(name)!r}, expected {value!r}"
            )
    return ds


def json_attr(value) -> str:
    """Encode structured metadata as a JSON string attribute (NetCDF attributes are flat)."""
    return json.dumps(value, sort_keys=True)
