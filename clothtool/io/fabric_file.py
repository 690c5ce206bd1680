"""Fabric files: HDF5, one dataset per Fabric array field, metadata as root attributes.

The layout is specified in ``formats/fabric/v2.md``. Files are byte-identical when the
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
from clothtool.errors import FormatError, UsageError
from clothtool.fabric import (
    ARRAY_FIELDS,
    ATTR_FIELDS,
    FORMAT_NAME,
    FORMAT_VERSION,
    OPTIONAL_ARRAY_FIELDS,
    READABLE_VERSIONS,
    Fabric,
)
from clothtool.inputs import note_input
from clothtool.io.atomic import atomic_output, write_error
from clothtool.io.h5safe import check_hdf5_file, read_dataset
from clothtool.io.hdf5_files import create_hdf5

# Arrays at least this many bytes are chunked and compressed (shuffle + gzip).
_COMPRESS_ABOVE_BYTES = 1 << 16
# A fabric is an HDF5 file; ".fabric.h5" is the documented name.
SUFFIXES = (".h5", ".hdf5")


def check_fabric_output_name(path: str | os.PathLike) -> None:
    """Refuse (as a usage error) an output name whose suffix promises another format."""
    if Path(path).suffix.lower() not in SUFFIXES:
        raise UsageError(
            f"{path}: a fabric is an HDF5 file and cannot be written as '{Path(path).suffix or '(no suffix)'}'; "
            "name the output NAME.fabric.h5"
        )


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
    # A fabric in vertex order has nothing version 1 lacks: it is written as version 1.
    f.attrs["format_version"] = FORMAT_VERSION if fabric.reordered else 1
    f.attrs["generator"] = f"clothtool {__version__}"
    f.attrs["particle_count"] = fabric.particle_count
    f.attrs["meters_per_unit"] = float(fabric.meters_per_unit)
    f.attrs["up_axis"] = fabric.up_axis
    f.attrs["hang_direction"] = np.asarray(fabric.hang_direction, np.float32)
    f.attrs["source_sha256"] = fabric.source_sha256
    f.attrs["cook_options"] = fabric.cook_options
    for name, _, _ in ARRAY_FIELDS:
        data = getattr(fabric, name)
        if name in OPTIONAL_ARRAY_FIELDS and data.shape[0] == 0:
            continue
        options = {}
        if data.nbytes >= _COMPRESS_ABOVE_BYTES:
            options = dict(compression="gzip", compression_opts=4, shuffle=True)
        f.create_dataset(name, data=data, **options)


def _fail(path, message: str):
    raise FormatError(f"{path}: {message}")


def read_fabric(path: str | os.PathLike, validate: bool = True) -> Fabric:
    """Read a fabric file; raise FormatError if it is not one, is truncated, is invalid or
    reaches outside itself (external storage or links, virtual datasets, soft-link cycles)."""
    import h5py

    path = Path(path)
    note_input(path)
    if not path.is_file():
        _fail(path, "fabric file not found; check the path or cook it with 'clothtool cook'")
    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("format") != FORMAT_NAME:
                _fail(path, f"not a clothtool fabric (format attribute is {_shown(f.attrs.get('format'))}); cook the mesh with 'clothtool cook'")
            version = int(f.attrs.get("format_version", -1))
            if version not in READABLE_VERSIONS:
                readable = " and ".join(str(v) for v in READABLE_VERSIONS)
                _fail(path, f"fabric format version {version} is not supported (this clothtool reads {readable}); re-cook it")
            # Before any data is read: nothing may point outside the file or claim more
            # bytes than the file holds.
            check_hdf5_file(f, path, _FIX)
            arrays = {}
            for name, dtype, shape in ARRAY_FIELDS:
                if name in OPTIONAL_ARRAY_FIELDS and version < 2:  # version 1 has none
                    arrays[name] = np.zeros(0, dtype)
                    continue
                if name not in f or not isinstance(f.get(name), h5py.Dataset):
                    _fail(path, f"dataset '{name}' is missing; the file is truncated or damaged, re-cook it")
                width = shape[-1] if isinstance(shape[-1], int) else None
                arrays[name] = read_dataset(f[name], path, name, dtype, len(shape), _FIX, width)
            fabric = Fabric(**arrays, **_read_attrs(f, path))
    except FormatError:
        raise
    except (OSError, KeyError, ValueError, TypeError, RuntimeError) as exc:
        first_line = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        _fail(path, f"cannot be read as a fabric ({first_line}); the file is truncated or damaged, re-cook it")
    if validate:
        try:
            fabric.validate()
        except Exception as exc:  # FabricError: report it against the file
            _fail(path, f"invalid fabric: {exc}; re-cook it")
    return fabric


_FIX = "re-cook it with 'clothtool cook'"


def _shown(value) -> str:
    """A foreign attribute value for a message: short, one line."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _read_attrs(f, path) -> dict:
    """The root attributes as Fabric keyword arguments, type-checked (validate() checks values)."""
    values = {}
    for key in ATTR_FIELDS:
        if key not in f.attrs:
            _fail(path, f"root attribute '{key}' is missing; the file is truncated or damaged, re-cook it")
        values[key] = f.attrs[key]
    mpu = np.asarray(values["meters_per_unit"])
    if mpu.shape != () or mpu.dtype.kind not in "iuf":
        _fail(path, f"root attribute 'meters_per_unit' must be one number, got {_shown(values['meters_per_unit'])}; re-cook it")
    hang = np.asarray(values["hang_direction"])
    if hang.dtype.kind not in "iuf":
        _fail(path, f"root attribute 'hang_direction' must be 3 numbers, got dtype {hang.dtype}; re-cook it")
    for key in ("up_axis", "source_sha256", "cook_options"):
        if not isinstance(values[key], str):
            _fail(path, f"root attribute '{key}' must be a string, got {_shown(values[key])}; re-cook it")
    values["meters_per_unit"] = float(mpu)
    values["hang_direction"] = hang.astype(np.float32).reshape(-1)
    return values


def cook_options_of(fabric: Fabric) -> dict:
    return json.loads(fabric.cook_options)
