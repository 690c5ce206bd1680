"""Read a garment mesh file (OBJ, PLY, OFF, STL, glTF/GLB, USD) into a raw ClothMesh.

The readers do not weld, triangulate, reorder or repair anything: polygons keep their
size and faces keep the file's order, so that the cooker's checks report problems against
the file the user knows. Index ranges and NaN are the cooker's business too.

meshio, trimesh and pxr are imported inside the reader that needs them, so importing this
package costs only numpy.

One module per format, each with a ``read(source, prim)`` and a ``READERS`` line at its
bottom (suffix -> read); ``_READERS`` below joins them into the one registry.
"""

from __future__ import annotations

import os

from clothtool.errors import ClothtoolError, FormatError, MeshError
from clothtool.inputs import note_input
from clothtool.io.meshin import gltf, obj, off, ply, stl, usd
from clothtool.io.meshin._common import _first_line, _invalid
from clothtool.mesh.clothmesh import ClothMesh

# suffix -> read(source, prim); this order is the order of SUPPORTED_SUFFIXES
_READERS = {**obj.READERS, **ply.READERS, **off.READERS, **stl.READERS, **gltf.READERS, **usd.READERS}
SUPPORTED_SUFFIXES: tuple[str, ...] = tuple(_READERS)


def read_mesh(path: str | os.PathLike, prim: str | None = None) -> ClothMesh:
    """Read the mesh in ``path``; ``prim`` picks a mesh prim in a USD file.

    Raises MeshError when the file is missing or has no faces, FormatError when its suffix
    is unknown or its content is not what the suffix says.
    """
    source = str(path)
    suffix = os.path.splitext(source)[1].lower()
    note_input(source)
    if not os.path.exists(source):
        raise MeshError(f"{source}: file not found; check the path")
    reader = _READERS.get(suffix)
    if reader is None:
        raise FormatError(
            f"{source}: unknown mesh file type '{suffix or '(no suffix)'}'; "
            f"use one of {', '.join(SUPPORTED_SUFFIXES)}"
        )
    if os.path.isdir(source):
        raise MeshError(f"{source}: is a directory; pass the mesh file inside it")
    if prim is not None and suffix not in usd.READERS:
        raise MeshError(f"{source}: only USD files have prims; drop prim '{prim}' for a {suffix} file")
    try:
        mesh = reader(source, prim)
    except (ClothtoolError, MemoryError):
        raise
    except OSError as exc:  # also a glTF's missing .bin, which trimesh reports by bare name
        missing = isinstance(exc, FileNotFoundError)
        name = exc.filename or (exc.args[0] if missing and len(exc.args) == 1 else source)
        reason = exc.strerror or ("not found" if missing else str(exc))
        raise MeshError(
            f"{source}: cannot read {name} ({reason}); check that it exists and is readable"
        ) from exc
    except Exception as exc:  # library errors: meshio ReadError, trimesh, pxr Tf.ErrorException, ...
        raise _invalid(source, _first_line(exc)) from exc
    if mesh.face_count == 0:
        raise MeshError(f"{source}: mesh has no faces; export the garment as a polygon mesh")
    return mesh
