"""Results store: cache keys, atomic writes, checksummed NetCDF I/O, complex data, resumable tables
(ARCHITECTURE.md, `store`).

Every output (NetCDF, PNG, VTK, mesh) is written under a temporary name in its final directory and
renamed, so an interrupted run never leaves a partial file behind; :func:`recording` collects the
paths written. A cache entry's key is a hash of every input that changes it, including the
discretisation's software versions. Every dataset carries a content checksum (attribute
``fsistab_checksum``) verified on load: a damaged file is refused with a one-line
:class:`~fsistab.errors.CacheError`, and a cache entry that can be recomputed is reported and
recomputed (:func:`read_cached`), never used.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import gzip
import hashlib
import json
import logging
import os
import secrets
import tempfile
import warnings
import zlib
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path

import numpy as np
import xarray as xr

from fsistab.errors import CacheError, InputError
from fsistab.schema import PROVENANCE_ATTRS, UndescribedVariableWarning, describe, undescribed

NETCDF_ENGINE = "h5netcdf"
CHECKSUM_ATTR = "fsistab_checksum"
DELETE_AND_RERUN = "; delete it and rerun"
PART = ("real", "imag")  # the trailing dimension ``part`` of complex data

log = logging.getLogger("fsistab")

# the lists of the active `recording()` blocks, innermost last (a context variable: per thread/task)
_RECORDINGS: contextvars.ContextVar[tuple[list[Path], ...]] = contextvars.ContextVar(
    "fsistab_recordings", default=()
)


def software_versions() -> dict[str, str]:
    """Versions that change the discretisation (dof numbering, meshing, solver defaults)."""
    import ngsolve

    from fsistab import __version__

    return {"fsistab": __version__, "ngsolve": ngsolve.__version__}


def default_cache_dir() -> Path:
    """``$FSISTAB_CACHE`` if set, else ``~/.cache/fsistab``; a one-line :class:`InputError` if
    ``$FSISTAB_CACHE`` names something that exists and is not a directory (before any work)."""
    env = os.environ.get("FSISTAB_CACHE")
    if env and Path(env).exists() and not Path(env).is_dir():
        raise InputError(f"FSISTAB_CACHE={env} is not a directory: unset it or point it to a directory")
    return Path(env) if env else Path.home() / ".cache" / "fsistab"


def cache_key(kind: str, inputs: dict) -> str:
    """Stable hash of a JSON-serialisable description of every input of a cache entry."""
    payload = json.dumps({"kind": kind, "inputs": inputs, "versions": software_versions()}, sort_keys=True)
    return hashlib.sha256(payload.encode()).hexdigest()[:20]


# --- writes: atomic, recorded ------------------------------------------------------------------


@contextlib.contextmanager
def recording() -> Iterator[list[Path]]:
    """Collect, in the list yielded, every path written atomically while the block is active.

    Nested blocks each see the writes made inside them. The state lives in a context variable, so
    threads and asyncio tasks record separately.
    """
    written: list[Path] = []
    token = _RECORDINGS.set((*_RECORDINGS.get(), written))
    try:
        yield written
    finally:
        _RECORDINGS.reset(token)


def _record(path: Path) -> None:
    for written in _RECORDINGS.get():
        written.append(path)


def _new_temporary(path: Path, suffix: str) -> Path:
    """Create an empty file of a fresh name beside ``path`` (``.<name>.<random>.part<suffix>``)
    with mode ``0666`` less the process's umask, as any file the user creates: ``mkstemp`` would
    make it 0600 whatever the umask, which breaks shared caches and group folders. The kernel
    applies the umask at creation, so no thread ever reads or changes it."""
    for _ in range(100):
        tmp = path.parent / f".{path.name}.{secrets.token_hex(6)}.part{suffix}"
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:  # pragma: no cover - 48 random bits
            continue
        os.close(fd)
        return tmp
    raise FileExistsError(f"no free temporary name beside {path}")  # pragma: no cover


def _sync_file(path: Path) -> None:
    """Flush ``path``'s data to the disk (before the rename that publishes it)."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _sync_directory(path: Path) -> None:
    """Flush directory ``path``'s entries to the disk (after a rename in it), where the system
    allows it: some file systems and platforms cannot open or sync a directory."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_path(path: Path, suffix: str = "") -> Iterator[Path]:
    """Yield a temporary path next to ``path``; rename it to ``path`` only if the block succeeds.

    The file is synced to the disk before the rename and the directory after it, so ``path`` is
    either the old file or the whole new one, also after a crash. It is created with the process's
    umask (``0644`` under umask 022; a writer that recreates it gets the same). On an exception
    nothing is left behind: neither ``path`` (an older file there is untouched) nor the temporary.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # the suffix stays last: some writers (Netgen) append their own extension otherwise
    tmp = _new_temporary(path, suffix)
    try:
        yield tmp
        _sync_file(tmp)
        os.replace(tmp, path)
        _sync_directory(path.parent)
        _record(path)
    finally:
        if tmp.exists():
            tmp.unlink()


def atomic_write_bytes(path: Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def ensure_writable_dir(path: Path, what: str) -> Path:
    """Create directory ``path`` and check a file can be written in it (created and deleted).

    ``what`` names it for the user (``"--out"``); a failure raises :class:`InputError` with one line
    ``"<what> <path> is not a writable directory: <reason>"``.
    """
    path = Path(path).expanduser()

    def refuse(reason: str) -> InputError:
        return InputError(f"{what} {path} is not a writable directory: {reason}")

    if path.exists() and not path.is_dir():
        raise refuse("it is a file")
    try:
        path.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".fsistab-write-test.", dir=path)
        try:
            os.write(fd, b"x")
        finally:
            os.close(fd)
            os.unlink(probe)
    except OSError as exc:
        raise refuse(exc.strerror or type(exc).__name__) from None
    return path


# --- checksums ---------------------------------------------------------------------------------


def _plain(value):
    """An attribute value as plain JSON data: NetCDF returns numpy scalars and arrays for numbers."""
    if isinstance(value, np.ndarray):
        return [_plain(v) for v in value.tolist()]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, bytes):
        return value.decode()
    return value


def _variable_bytes(variable: xr.Variable) -> tuple[str, bytes]:
    """A canonical (dtype, bytes) of a variable's values; strings are hashed as their text (NetCDF
    returns them as objects whatever the width written)."""
    values = np.asarray(variable.values)
    if values.dtype.kind in "OUS":
        text = json.dumps([str(_plain(v)) for v in values.ravel().tolist()])
        return "str", text.encode()
    values = np.ascontiguousarray(values)
    return values.dtype.newbyteorder("<").str, values.astype(values.dtype.newbyteorder("<")).tobytes()


def dataset_checksum(ds: xr.Dataset) -> str:
    """sha256 over every variable's (data and coordinate) name, dims, shape, dtype and bytes in
    sorted name order, and the dataset attributes other than the checksum itself."""
    digest = hashlib.sha256()
    for name in sorted(map(str, ds.variables)):
        variable = ds.variables[name]
        dtype, data = _variable_bytes(variable)
        header = json.dumps([name, list(map(str, variable.dims)), list(variable.shape), dtype])
        digest.update(header.encode())
        digest.update(hashlib.sha256(data).digest())
    attrs = {str(k): _plain(v) for k, v in ds.attrs.items() if k != CHECKSUM_ATTR}
    digest.update(json.dumps(attrs, sort_keys=True, default=str).encode())
    return digest.hexdigest()


def file_checksum(path: Path) -> str:
    """sha256 of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


# --- NetCDF ------------------------------------------------------------------------------------


def write_dataset(ds: xr.Dataset, path: Path) -> Path:
    """Write ``ds`` as NetCDF-4 atomically, described and with its content checksum in attribute
    ``fsistab_checksum``: every result and cache file goes through here.

    The file describes itself (:func:`fsistab.schema.describe`): ``units`` and ``long_name`` on
    every variable from the data dictionary, and the provenance attributes (``Conventions``,
    versions, ``history`` with the command line); the caller's dataset is not changed. The
    checksum is that of the file as a reader decodes it (NetCDF turns a one-element list attribute
    into a scalar, fixed-width strings into objects, ...), added to the temporary file before it is
    renamed, so :func:`read_dataset` finds it equal unless the file changed.
    """
    import h5py

    path = Path(path)
    ds = describe(ds)
    missing = undescribed(ds)
    if missing:
        warnings.warn(
            f"{path.name}: no units or long_name for {', '.join(missing)} (add them to fsistab.schema)",
            UndescribedVariableWarning,
            stacklevel=2,
        )
    ds.attrs = {k: v for k, v in ds.attrs.items() if k != CHECKSUM_ATTR}
    with atomic_path(path, ".nc") as tmp:
        ds.to_netcdf(tmp, engine=NETCDF_ENGINE)
        with xr.open_dataset(tmp, engine=NETCDF_ENGINE) as written:
            checksum = dataset_checksum(written.load())
        with h5py.File(tmp, "r+") as f:
            f.attrs[CHECKSUM_ATTR] = checksum
    return path


def _check_root_attributes(path: Path) -> None:
    """Open ``path`` with h5py and decode its root attributes, raising what h5py raises when the
    file or its header is damaged. h5netcdf reads a root attribute half-way through opening a file
    and, when that fails, its half-built file object prints an ``Exception ignored`` traceback
    when collected; failing here first keeps the report to one line."""
    import h5py

    with h5py.File(path, "r") as f:
        dict(f.attrs)


def read_dataset(path: Path, expect: dict | None = None) -> xr.Dataset:
    """Read a NetCDF file written by :func:`write_dataset` fully into memory, verify its content
    checksum and that its attributes match ``expect``.

    Raises :class:`CacheError` (one line naming the file and what to do) when it is missing,
    unreadable, has no checksum, fails the checksum or does not match.
    """
    path = Path(path)
    if not path.is_file():
        raise CacheError(f"file not found: {path}")
    try:
        _check_root_attributes(path)
        with xr.open_dataset(path, engine=NETCDF_ENGINE) as ds:
            ds = ds.load()
    except Exception as exc:  # h5py/netCDF raise many types for a damaged file
        raise CacheError(
            f"cannot read {path} (damaged or not NetCDF: {type(exc).__name__})" + DELETE_AND_RERUN
        ) from None
    stored = ds.attrs.get(CHECKSUM_ATTR)
    if stored is None:
        raise CacheError(f"{path} has no content checksum (not written by this fsistab)" + DELETE_AND_RERUN)
    if stored != dataset_checksum(ds):
        raise CacheError(f"{path} is damaged (content checksum mismatch)" + DELETE_AND_RERUN)
    for name, value in (expect or {}).items():
        if _plain(ds.attrs.get(name)) != _plain(value):
            raise CacheError(
                f"{path} does not match the request: {name} is {ds.attrs.get(name)!r}, expected {value!r}"
            )
    return ds


def read_attributes(path: Path) -> dict:
    """The global attributes of the NetCDF file ``path``, its header only and unverified (a cheap
    look among many files before :func:`read_dataset` verifies the one chosen); empty when the
    file cannot be read."""
    try:
        with xr.open_dataset(path, engine=NETCDF_ENGINE) as ds:
            return dict(ds.attrs)
    except Exception:  # h5py/netCDF raise many types for a damaged file
        return {}


def discard_damaged(path: Path, problem: CacheError | str) -> Path:
    """Report a damaged cache entry in one warning line and move it aside (``<name>.damaged``, which
    replaces an older one); returns where it went."""
    path = Path(path)
    aside = path.with_name(path.name + ".damaged")
    message = str(problem).removesuffix(DELETE_AND_RERUN)
    try:
        os.replace(path, aside)
    except OSError:
        with contextlib.suppress(OSError):
            path.unlink()
    log.warning("%s; moved aside to %s, recomputing", message, aside.name)
    return aside


def read_cached(path: Path, expect: dict | None = None) -> xr.Dataset | None:
    """A cache entry that can be recomputed: its dataset, or None when it is missing or damaged.

    A damaged or mismatched entry is reported and moved aside (:func:`discard_damaged`), so the
    caller recomputes it; it is never used.
    """
    path = Path(path)
    if not path.exists():
        return None
    try:
        return read_dataset(path, expect)
    except CacheError as exc:
        discard_damaged(path, exc)
        return None


def read_resumable(path: Path, identity: Mapping) -> xr.Dataset | None:
    """A partial result to resume: its dataset, or None when there is none or it is damaged
    (reported and moved aside: the work restarts). One whose ``identity`` attributes differ is
    another computation's: :class:`CacheError` (one line), so that it is not overwritten."""
    path = Path(path)
    if not path.exists():
        return None
    try:
        ds = read_dataset(path)
    except CacheError as exc:
        discard_damaged(path, exc)
        return None
    for name, value in identity.items():
        if _plain(ds.attrs.get(name)) != _plain(value):
            raise CacheError(
                f"{path} does not match this run, it holds another computation ({name} = "
                f"{ds.attrs.get(name)!r}, this run has {value!r}); move it away or choose another output"
            )
    return ds


def json_attr(value) -> str:
    """Encode structured metadata as a JSON string attribute (NetCDF attributes are flat)."""
    return json.dumps(value, sort_keys=True)


# --- complex data ------------------------------------------------------------------------------


def complex_variable(dims, values, attrs: dict | None = None) -> xr.DataArray:
    """Complex ``values`` on ``dims`` as a real array with a trailing dimension ``part`` =
    ("real", "imag") — the one encoding of complex data in fsistab's files."""
    dims = (dims,) if isinstance(dims, str) else tuple(dims)
    values = np.asarray(values, dtype=complex)
    if values.ndim != len(dims):
        raise ValueError(f"complex values of shape {values.shape} do not fit dims {dims}")
    return xr.DataArray(
        np.stack([values.real, values.imag], axis=-1),
        dims=(*dims, "part"),
        coords={"part": list(PART)},
        attrs=dict(attrs or {}),
    )


def complex_values(array: xr.DataArray) -> np.ndarray:
    """The complex values of an array written by :func:`complex_variable`."""
    if "part" not in array.dims:
        raise CacheError(f"variable {array.name!r} has no 'part' dimension: not complex data")
    parts = array.transpose(..., "part")
    labels = [str(p) for p in parts["part"].values] if "part" in parts.coords else list(PART)
    real = parts.isel(part=labels.index("real")).values
    imag = parts.isel(part=labels.index("imag")).values
    return real + 1j * imag


# --- meshes and other files with a checksum sidecar --------------------------------------------


@contextlib.contextmanager
def entry_lock(path: Path) -> Iterator[None]:
    """Hold an exclusive lock on the cache entry ``path`` (``<name>.lock`` beside it, POSIX
    ``flock``) for the block: processes sharing a cache (the workers of a dask cluster) build and
    check an entry one at a time. Without it a worker could find another's mesh renamed into place
    but its sidecar not yet written, take it for damaged and move it aside under the writer. The
    lock file is left behind (removing it would race with the next holder). Where ``fcntl`` is
    missing the block runs unlocked."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield
        return
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.with_name(path.name + ".lock"), "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def sidecar_path(path: Path) -> Path:
    return Path(path).with_name(Path(path).name + ".sha256.json")


def write_sidecar(path: Path) -> Path:
    """Record ``path``'s sha256 and size in a JSON sidecar, written atomically."""
    path = Path(path)
    payload = {"file": path.name, "sha256": file_checksum(path), "bytes": path.stat().st_size}
    return atomic_write_bytes(sidecar_path(path), json.dumps(payload, sort_keys=True).encode())


def verify_sidecar(path: Path) -> None:
    """Check ``path`` against its sidecar checksum, and a ``.gz`` file's whole gzip stream.

    Raises :class:`CacheError` (one line) when the sidecar is missing or unreadable, or the file
    differs from it or is not a complete gzip stream.
    """
    path = Path(path)
    side = sidecar_path(path)
    try:
        payload = json.loads(side.read_text())
        expected = payload["sha256"]
    except (OSError, ValueError, KeyError, TypeError):
        raise CacheError(f"{path} has no valid checksum file {side.name}" + DELETE_AND_RERUN) from None
    if file_checksum(path) != expected:
        raise CacheError(f"{path} is damaged (checksum mismatch)" + DELETE_AND_RERUN)
    if path.name.endswith(".gz"):
        try:
            with gzip.open(path, "rb") as f:
                while f.read(1 << 20):
                    pass
        except (OSError, EOFError, zlib.error) as exc:  # BadGzipFile is an OSError
            raise CacheError(f"{path} is not a complete gzip file ({exc})" + DELETE_AND_RERUN) from None


# --- resumable tables --------------------------------------------------------------------------

TABLE_ATTR = "fsistab_table"  # the layout of a resumable table (JSON): kinds, their fields, state, ragged
COMPLETE_ATTR = "complete"
DEFAULT_KIND = "record"
# the layout's and the provenance's attributes (fsistab.schema), never part of a record's identity
_RESERVED = {"part", COMPLETE_ATTR, TABLE_ATTR, CHECKSUM_ATTR, *PROVENANCE_ATTRS}


class ResumableTable:
    """The one resumable dataset: finished records, saved atomically as they come, that a rerun
    resumes (every resumed computation of fsistab: transfer samples, reduced models, neutral curves).

    ``identity`` (flat JSON-able attributes) says what the table is a table of: an existing file at
    ``path`` is resumed only if its identity attributes and its layout match — else
    :class:`CacheError` (one line, the file named) — and only if its checksum holds and it is a
    table — else a warning and a fresh start (a file of an older layout counts as damaged).

    ``fields`` maps each kind of record (e.g. ``point`` and ``fold`` of a curve) to the names of its
    fields; field names are unique across kinds, and a kind's records are stacked along a dimension
    named after it. Without ``fields`` the table has one kind, ``record``, whose fields are those
    of its first record. A field's values are scalars or arrays, complex allowed; when their shapes
    differ between records (a reduced model's matrices) they are padded and each record's shape is
    kept (variable ``<field>_shape``), so records come back exactly as appended. ``state`` names
    arrays that are replaced rather than appended (the last point's mode, to resume a curve).
    :meth:`finish` marks the table complete with the run's final attributes (how it stopped);
    appending to a finished table reopens it.
    """

    def __init__(
        self,
        path: Path,
        identity: Mapping,
        fields: Mapping[str, Sequence[str]] | None = None,
        state: Sequence[str] = (),
    ):
        self.path = Path(path)
        self.identity = {str(k): _plain(v) for k, v in identity.items()}
        self.fields = None if fields is None else {str(k): tuple(map(str, v)) for k, v in fields.items()}
        self.state_names = tuple(map(str, state))
        _check_layout(self.identity, self.fields, self.state_names)
        self.clear()
        if self.path.exists():
            self._load()

    @property
    def kinds(self) -> tuple[str, ...]:
        return tuple(self.fields) if self.fields is not None else (DEFAULT_KIND,)

    def clear(self) -> None:
        """Forget every record, the state and the final attributes (the file is untouched until the
        next save): the computation restarts."""
        self._records: dict[str, list[dict[str, np.ndarray]]] = {kind: [] for kind in self.kinds}
        self._state: dict[str, np.ndarray] = {}
        self._final: dict | None = None
        self._history = ""

    def _load(self) -> None:
        ds = read_resumable(self.path, self.identity)
        if ds is None:
            return
        try:
            layout = json.loads(ds.attrs[TABLE_ATTR])
            stored_fields = {str(k): tuple(v) for k, v in layout["fields"].items()}
            stored_state, ragged = tuple(layout["state"]), set(layout["ragged"])
        except (KeyError, ValueError, TypeError, AttributeError):
            discard_damaged(self.path, f"{self.path} is not a resumable table (an older layout)")
            return
        if (
            stored_state != self.state_names
            or set(stored_fields) != set(self.kinds)  # the layout's JSON has its kinds sorted
            or (self.fields is not None and stored_fields != self.fields)
        ):
            raise CacheError(
                f"{self.path} does not match this run, it holds another computation (records "
                f"{stored_fields}, state {list(stored_state)}); move it away or choose another output"
            )
        for kind, names in stored_fields.items():
            columns = {name: _stored_column(ds, name, name in ragged) for name in names}
            count = ds.sizes.get(kind, 0)
            self._records[kind] = [
                {name: column[i] for name, column in columns.items()} for i in range(count)
            ]
        self._state = {name: _stored_values(ds[name]) for name in self.state_names if name in ds}
        self._history = str(ds.attrs.get("history", ""))  # the runs that wrote the records so far
        if ds.attrs.get(COMPLETE_ATTR):
            skip = {*self.identity, *_RESERVED}
            self._final = {str(k): _plain(v) for k, v in ds.attrs.items() if k not in skip}

    @property
    def records(self) -> list[dict[str, np.ndarray]]:
        """The finished records of the first kind, in order (copies)."""
        return self.records_of(self.kinds[0])

    def records_of(self, kind: str) -> list[dict[str, np.ndarray]]:
        """The finished records of ``kind``, in order (copies)."""
        return [dict(r) for r in self._records[kind]]

    @property
    def state(self) -> dict[str, np.ndarray]:
        return dict(self._state)

    @property
    def complete(self) -> bool:
        """Whether :meth:`finish` was called after the last record."""
        return self._final is not None

    @property
    def final_attrs(self) -> dict:
        """The attributes given to :meth:`finish` (empty while the table is not complete)."""
        return dict(self._final or {})

    def __len__(self) -> int:
        return sum(len(records) for records in self._records.values())

    def append(
        self, record: Mapping, *, kind: str | None = None, state: Mapping | None = None, save: bool = True
    ) -> None:
        """Add a finished record of ``kind`` (the first kind by default), replace the ``state``
        arrays given, and save (atomically) unless ``save`` is False."""
        kind = self.kinds[0] if kind is None else kind
        if kind not in self._records:
            raise ValueError(f"unknown record kind {kind!r}, expected one of {list(self.kinds)}")
        record = {str(k): np.asarray(v) for k, v in record.items()}
        names = self.fields[kind] if self.fields is not None else None
        if names is None and self._records[kind]:
            names = tuple(self._records[kind][0])
        if names is not None and set(record) != set(names):
            raise ValueError(f"record names {sorted(record)} differ from {sorted(names)}")
        if state:
            unknown = set(map(str, state)) - set(self.state_names)
            if unknown:
                raise ValueError(
                    f"unknown state {sorted(unknown)}, expected some of {list(self.state_names)}"
                )
            self._state |= {str(k): np.asarray(v) for k, v in state.items()}
        self._records[kind].append(record)
        self._final = None
        if save:
            self.save()

    def finish(self, attrs: Mapping | None = None) -> Path:
        """Mark the table complete with ``attrs`` (how the run ended, e.g. ``stop``) and save it.
        A table read back complete with the same ``attrs``, nothing appended since, is left as it
        is, its file unwritten: a rerun that had nothing to add keeps the file's bytes, so what was
        started from it (a march's ``--start``, fingerprinted by those bytes) is still found."""
        final = {str(k): _plain(v) for k, v in (attrs or {}).items()}
        clash = set(final) & {*self.identity, *_RESERVED}
        if clash:
            raise ValueError(f"final attributes {sorted(clash)} clash with the identity or the layout")
        if self._final == final and self.path.is_file():
            return self.path
        self._final = final
        return self.save()

    def dataset(self) -> xr.Dataset:
        """The table as a dataset: each kind's fields along a dimension named after the kind (complex
        values encoded by :func:`complex_variable`, attribute ``complex = 1``), the state, and the
        attributes: identity, final attributes, ``complete`` (0/1), the layout and the ``history``
        of the runs that wrote the records loaded (:func:`write_dataset` adds this run's line)."""
        variables, ragged = {}, []
        fields = {}
        for kind, records in self._records.items():
            names = self.fields[kind] if self.fields is not None else tuple(records[0]) if records else ()
            fields[kind] = list(names)
            for name in names:
                column, shapes = _padded_column([r[name] for r in records])
                variables[name] = _array_variable(
                    (kind, *(f"{name}_{i}" for i in range(column.ndim - 1))), column
                )
                if shapes is not None:
                    ragged.append(name)
                    variables[f"{name}_shape"] = xr.DataArray(shapes, dims=(kind, f"{name}_axis"))
        for name, value in self._state.items():
            variables[name] = _array_variable(tuple(f"{name}_{i}" for i in range(value.ndim)), value)
        layout = {"fields": fields, "state": list(self.state_names), "ragged": ragged}
        attrs = {
            **self.identity,
            **(self._final or {}),
            COMPLETE_ATTR: int(self._final is not None),
            TABLE_ATTR: json_attr(layout),
            **({"history": self._history} if self._history else {}),
        }
        return xr.Dataset(variables, attrs=attrs)

    def save(self) -> Path:
        return write_dataset(self.dataset(), self.path)


def _check_layout(identity: dict, fields: dict | None, state: tuple[str, ...]) -> None:
    clash = set(identity) & _RESERVED
    if clash:
        raise ValueError(f"identity attributes {sorted(clash)} are reserved by the table")
    kinds = list(fields) if fields is not None else [DEFAULT_KIND]
    names = [name for names in (fields or {}).values() for name in names] + list(state)
    taken = {*kinds, "part"}
    if len(set(names)) != len(names) or taken & set(names) or not kinds or "part" in kinds:
        raise ValueError(
            f"table fields {fields} and state {state} must be distinct from each other and the kinds"
        )


def _padded_column(values: list) -> tuple[np.ndarray, np.ndarray | None]:
    """The values stacked along a new first axis; values of different shapes (same number of
    dimensions) padded with zeros to the largest, with their shapes (else None)."""
    values = [np.asarray(v) for v in values]
    if not values:
        return np.zeros(0), None
    shapes = {v.shape for v in values}
    if len(shapes) == 1:
        return np.stack(values), None
    if len({len(s) for s in shapes}) != 1:
        raise ValueError(f"record values of shapes {sorted(shapes)} differ in their number of dimensions")
    dtype = functools.reduce(np.promote_types, {v.dtype for v in values})  # result_type takes ≤ 32
    out = np.zeros((len(values), *np.max([v.shape for v in values], axis=0)), dtype=dtype)
    for i, v in enumerate(values):
        out[(i, *(slice(0, d) for d in v.shape))] = v
    return out, np.array([v.shape for v in values], dtype=np.int64)


def _array_variable(dims: tuple[str, ...], values: np.ndarray) -> xr.DataArray:
    if np.iscomplexobj(values):
        return complex_variable(dims, values, {"complex": 1})
    return xr.DataArray(values, dims=dims)


def _stored_values(array: xr.DataArray) -> np.ndarray:
    return complex_values(array) if array.attrs.get("complex") else array.values


def _stored_column(ds: xr.Dataset, name: str, ragged: bool) -> list[np.ndarray]:
    """The values of field ``name`` per record, cut back to their own shapes when ``ragged``."""
    values = _stored_values(ds[name])
    if not ragged:
        return list(values)
    shapes = ds[f"{name}_shape"].values
    return [v[tuple(slice(0, int(d)) for d in shape)] for v, shape in zip(values, shapes, strict=True)]
