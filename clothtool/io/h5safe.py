"""Refuse HDF5 files that would make a reader touch anything beyond the file's own bytes.

A fabric or cache comes from elsewhere (a render farm, a colleague, a download), so before
any data is read its link tree is walked *without following links* and every dataset's
creation properties are checked. HDF5 otherwise happily:

* reads a dataset's bytes from another file (external storage: ``/etc/passwd`` as rest
  positions) or from other datasets in other files (virtual datasets);
* opens another file through an external link;
* loops through soft links until it gives up with "too many links";
* hands a reader a dataset whose header claims terabytes that the file cannot hold
  (unwritten chunks read as the fill value), which numpy then tries to allocate.

``check_hdf5_file(f, path, fix)`` raises FormatError naming the file, the dataset or link
and ``fix`` (what the user should do, e.g. "re-cook it") on the first of these it meets.
``read_dataset`` reads a checked dataset after ``check_layout`` has checked its dtype and shape.
"""

from __future__ import annotations

import numpy as np

from clothtool.errors import FormatError

# gzip compresses at most ~1032:1, so data that decompresses to more than this many times
# the bytes the file stores for it was never written (it is fill value or a forged header).
MAX_EXPANSION = 1100
# Small datasets (attributes-sized) are never refused for their ratio.
_SLACK_BYTES = 1 << 16
# Soft links that need more hops than this to reach an object are refused (HDF5 gives up at 16).
_MAX_SOFT_HOPS = 16
_NUMERIC_KINDS = "biuf"


def _refuse(path, where: str, problem: str, fix: str):
    raise FormatError(f"{path}: {where} {problem}; clothtool reads only data stored inside the file, {fix}")


def check_hdf5_file(f, path, fix: str) -> None:
    """Walk every link of open file ``f`` (without following soft or external links) and
    refuse external links, soft links that loop or lead outside, datasets stored outside
    the file (external storage, virtual datasets), non-numeric datasets and datasets whose
    declared size the file cannot hold. Reads no dataset's data."""
    import h5py

    seen: set = set()
    stack = [("", f)]  # (path inside the file without the leading '/', group)
    while stack:
        group_name, group = stack.pop()
        if group.id in seen:  # a hard link back up the tree: already walked
            continue
        seen.add(group.id)
        for name in sorted(group):
            full = f"{group_name}/{name}" if group_name else name
            link = group.get(name, getlink=True)
            if isinstance(link, h5py.ExternalLink):
                _refuse(path, f"link '{full}'", f"is an external link to {link.filename!r}", fix)
            if isinstance(link, h5py.SoftLink):
                _resolve_soft(f, path, full, link.path, fix)
                continue  # its target is reached through hard links (or refused there)
            if not isinstance(link, h5py.HardLink):
                _refuse(path, f"link '{full}'", f"is a {type(link).__name__} (user-defined link)", fix)
            obj = group[name]
            if isinstance(obj, h5py.Group):
                stack.append((full, obj))
            elif isinstance(obj, h5py.Dataset):
                check_dataset(obj, path, full, fix)
            # named datatypes hold no data: nothing to check


def _resolve_soft(f, path, where: str, target: str, fix: str) -> None:
    """Follow soft link ``where`` -> ``target`` component by component without letting HDF5
    follow anything, refusing loops, external links and targets that do not exist."""
    import h5py

    hops = 0
    pending = [target]  # paths still to resolve; a soft link met on the way pushes its target
    base = "/" + where.rsplit("/", 1)[0] if "/" in where else "/"
    while pending:
        target = pending.pop()
        parts = [p for p in (target if target.startswith("/") else base + "/" + target).split("/") if p]
        node, current = f, ""
        for i, part in enumerate(parts):
            if part == ".":
                continue
            if not isinstance(node, h5py.Group) or part not in node:
                _refuse(path, f"soft link '{where}'", f"points at '{target}', which does not exist", fix)
            link = node.get(part, getlink=True)
            if isinstance(link, h5py.ExternalLink):
                _refuse(path, f"soft link '{where}'", f"leads through an external link to {link.filename!r}", fix)
            if isinstance(link, h5py.SoftLink):
                hops += 1
                if hops > _MAX_SOFT_HOPS:
                    _refuse(path, f"soft link '{where}'", "is part of a soft-link cycle (or a chain too long to follow)", fix)
                rest = "/".join(parts[i + 1 :])
                base = current or "/"
                target = link.path if not rest else link.path.rstrip("/") + "/" + rest
                pending.append(target)
                break
            if not isinstance(link, h5py.HardLink):
                _refuse(path, f"soft link '{where}'", f"leads through a {type(link).__name__}", fix)
            node = node[part]
            current = current + "/" + part


def check_dataset(dataset, path, name: str, fix: str) -> None:
    """Refuse external storage, virtual layouts, non-numeric dtypes and impossible sizes."""
    import h5py

    plist = dataset.id.get_create_plist()
    if plist.get_layout() == h5py.h5d.VIRTUAL:
        _refuse(path, f"dataset '{name}'", "is a virtual dataset (its data lives in other files)", fix)
    if plist.get_external_count() > 0:
        external = plist.get_external(0)[0]
        _refuse(path, f"dataset '{name}'", f"uses external storage (its bytes live in {external!r})", fix)
    dtype = dataset.dtype
    if dtype.kind not in _NUMERIC_KINDS or dtype.fields is not None or dtype.subdtype is not None:
        raise FormatError(f"{path}: dataset '{name}' has dtype {dtype}, not a number type; the file is damaged, {fix}")
    declared = int(np.prod(dataset.shape, dtype=object)) * dtype.itemsize if dataset.shape is not None else 0
    stored = int(dataset.id.get_storage_size())
    if declared > stored * MAX_EXPANSION + _SLACK_BYTES:
        raise FormatError(
            f"{path}: dataset '{name}' declares shape {dataset.shape} ({declared:,} bytes) but the file holds "
            f"{stored:,} bytes of it; the header is damaged or forged, {fix}"
        )


def read_dataset(dataset, path, name: str, dtype, ndim: int, fix: str, width: int | None = None) -> np.ndarray:
    """The whole of a checked dataset, refusing another dtype (no silent casts: float indices
    would be truncated) or another number of dimensions / last-axis width before any data
    is read."""
    import h5py

    if not isinstance(dataset, h5py.Dataset):
        raise FormatError(f"{path}: '{name}' is a {type(dataset).__name__}, expected a dataset; {fix}")
    check_layout(dataset, path, name, dtype, ndim, fix, width)
    return np.asarray(dataset[()], dtype)


def check_layout(dataset, path, name: str, dtype, ndim: int, fix: str, width: int | None = None) -> None:
    """Refuse a dataset of another dtype, number of dimensions or last-axis width."""
    dtype = np.dtype(dtype)
    if dataset.dtype != dtype:
        raise FormatError(f"{path}: dataset '{name}' has dtype {dataset.dtype}, expected {dtype}; {fix}")
    shape = dataset.shape or ()
    if len(shape) != ndim or (width is not None and shape[-1] != width):
        want = f"{ndim} dimensions" + (f" with last axis {width}" if width is not None else "")
        raise FormatError(f"{path}: dataset '{name}' has shape {shape}, expected {want}; {fix}")
