"""Fabric files: HDF5, one dataset per Fabric array field, metadata as root attributes.

The layout is specified in ``formats/fabric/v1.md``. Files are byte-identical when the
same fabric is written twice (h5py does not record times by default; we fix the library
version bounds and write datasets in a fixed order).
"""

from __future__ import annotations

import contextlib
import json
import os
from pathlib import Path

import numpy as np

from clothtool import __version__
from clothtool.errors import FormatError
from clothtool.fabric import ARRAY_FIELDS, FORMAT_NAME, FORMAT_VERSION, Fabric
from clothtool.io.atomic import atomic_output, write_error
from clothtool.io.hdf5_files import create_hdf5

# Arrays at least this many bytes are chunked and compressed (shuffle + gzip).
_COMPRESS_ABOVE_BYTES = 1 << 16


def write_fabric(fabric: Fabric, path: str | os.PathLike) -> None:
    """Validate ``fabric`` and write it to ``path`` atomically."""
    fabric.validate()
    with atomic_output(path, "writing the fabric") as tmp:
        f = create_hdf5(tmp)
        try:
            _write_fabric_file(fabric, f)
            f.close()  # writes the metadata: a full disk can fail here too
        except BaseException as exc:
            # The first failure is the one to report: closing a file that failed to write
            # fails again (or worse), so it is closed quietly and then thrown away.
            with contextlib.suppress(Exception):
                f.close()
            if isinstance(exc, (OSError, RuntimeError)):  # h5py raises RuntimeError when a flush fails
                raise write_error(path, exc, "writing the fabric") from None
            raise


def _write_fabric_file(fabric: Fabric, f) -> None:
    f.attrs["format"] = FORMAT_NAME
    f.attrs["format_version"] = FORMAT_VERSION
    f.attrs["generator"] = f"clothtool {__version__}"
    f.attrs["particle_count"] = fabric.particle_count
    f.attrs["meters_per_unit"] = float(fabric.meters_per_unit)
    f.attrs["up_axis"] = fabric.up_axis
    f.attrs["hang_direction"] = np.asarray(fabric.hang_direction, np.float32)
    f.attrs["source_sha256"] = fabric.source_sha256
    f.attrs["cook_options"] = fabric.cook_options
    for name, _, _ in ARRAY_FIELDS:
        data = getattr(fabric, name)
        options = {}
        if data.nbytes >= _COMPRESS_ABOVE_BYTES:
            options = dict(compression="gzip", compression_opts=4, shuffle=True)
        f.create_dataset(name, data=data, **options)


def _fail(path, message: str):
    raise FormatError(f"{path}: {message}")


def read_fabric(path: str | os.PathLike, validate: bool = True) -> Fabric:
    """Read a fabric file; raise FormatError if it is not one, is truncated or is invalid."""
    import h5py

    path = Path(path)
    if not path.is_file():
        _fail(path, "fabric file not found; check the path or cook it with 'clothtool cook'")
    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("format") != FORMAT_NAME:
                _fail(path, f"not a clothtool fabric (format attribute is {f.attrs.get('format')!r}); cook the mesh with 'clothtool cook'")
            version = int(f.attrs.get("format_version", -1))
            if version != FORMAT_VERSION:
                _fail(path, f"fabric format version {version} is not supported (this clothtool reads {FORMAT_VERSION}); re-cook it")
            arrays = {}
            for name, dtype, _ in ARRAY_FIELDS:
                if name not in f:
                    _fail(path, f"dataset '{name}' is missing; the file is truncated or damaged, re-cook it")
                arrays[name] = np.asarray(f[name][()], dtype=dtype)
            fabric = Fabric(
                **arrays,
                meters_per_unit=float(f.attrs["meters_per_unit"]),
                up_axis=str(f.attrs["up_axis"]),
                hang_direction=np.asarray(f.attrs["hang_direction"], np.float32),
                source_sha256=str(f.attrs["source_sha256"]),
                cook_options=str(f.attrs["cook_options"]),
            )
    except FormatError:
        raise
    except (OSError, KeyError, ValueError, TypeError) as exc:
        first_line = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        _fail(path, f"cannot be read as a fabric ({first_line}); the file is truncated or damaged, re-cook it")
    if validate:
        try:
            fabric.validate()
        except Exception as exc:  # FabricError: report it against the file
            _fail(path, f"invalid fabric: {exc}; re-cook it")
    return fabric


def cook_options_of(fabric: Fabric) -> dict:
    return json.loads(fabric.cook_options)
