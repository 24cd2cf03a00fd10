"""Ways a cache file gets damaged, for the corruption tests (test_store, test_steady, test_mesh).

Each changes the file on disk the way a crash, a bad disk or a careless hand would: cut short, one
byte flipped or 4 KiB zeroed inside a variable's stored values, or one value edited in place through
HDF5 keeping every attribute (the checksum attribute included).
"""

from pathlib import Path

KINDS = ("truncated", "flipped", "zeroed", "edited")


def _data_offset(path: Path, name: str | None) -> tuple[int, int]:
    """(file offset, bytes) of the stored values of variable ``name`` (the largest if None)."""
    import h5py

    with h5py.File(path, "r") as f:
        datasets = [f[k] for k in f if isinstance(f[k], h5py.Dataset)]
        dataset = f[name] if name is not None else max(datasets, key=lambda d: d.size)
        offset = dataset.id.get_offset()
        assert offset is not None, "contiguous storage expected"
        return offset, dataset.id.get_storage_size()


def damage(path: Path, kind: str, variable: str | None = None) -> None:
    """Damage ``path`` in place: ``kind`` one of :data:`KINDS` (``variable``: which NetCDF variable
    the flipped/zeroed/edited bytes belong to, the largest by default)."""
    path = Path(path)
    data = bytearray(path.read_bytes())
    if kind == "truncated":
        path.write_bytes(bytes(data[: len(data) // 2]))
    elif kind in ("flipped", "zeroed") and not path.name.endswith(".nc"):
        start = len(data) // 2
        if kind == "flipped":
            data[start] ^= 0xFF
        else:
            data[start : start + 4096] = bytes(len(data[start : start + 4096]))
        path.write_bytes(bytes(data))
    elif kind in ("flipped", "zeroed"):
        offset, size = _data_offset(path, variable)
        if kind == "flipped":
            data[offset + size // 2] ^= 0xFF
        else:
            end = min(offset + size, offset + size // 4 + 4096)
            data[offset + size // 4 : end] = bytes(end - offset - size // 4)
        path.write_bytes(bytes(data))
    elif kind == "edited":
        import h5py

        with h5py.File(path, "r+") as f:
            name = variable or max((k for k in f if isinstance(f[k], h5py.Dataset)), key=lambda k: f[k].size)
            values = f[name][...]
            flat = values.reshape(-1)
            flat[flat.size // 2] += 1  # values of order 1: the sum differs from the value
            f[name][...] = values
    else:
        raise ValueError(kind)
