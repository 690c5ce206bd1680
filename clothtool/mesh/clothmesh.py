"""ClothMesh: a polygon mesh with per-vertex paint attributes, as read from a file."""

from __future__ import annotations

import dataclasses

import numpy as np

from clothtool.errors import MeshError


@dataclasses.dataclass(frozen=True, eq=False)
class ClothMesh:
    """A polygon mesh (quads kept) in the file's own units and axes.

    Attributes:
        vertex_pos: f32 (n,3) vertex positions in file units.
        face_vertex_counts: i32 (f,) number of vertices of each face (>= 3).
        face_vertex_indices: i64 (fv,) vertex indices of all faces, concatenated.
        face_vertex_uv: f32 (fv,2) UV of every face vertex, or None. UVs live on face
            corners so that a UV seam does not split a particle.
        vertex_attrs: name -> f32 (n,) painted per-vertex values (pin weights, max distance,
            stiffness, vertex colour channels ``color_r``/``color_g``/``color_b``).
        source: the file name used in error messages.
        meters_per_unit: the file's unit in metres when the file says so (USD, glTF), else None.
        up_axis: "Y" or "Z" when the file says so (USD, glTF), else None.
    """

    vertex_pos: np.ndarray
    face_vertex_counts: np.ndarray
    face_vertex_indices: np.ndarray
    face_vertex_uv: np.ndarray | None = None
    vertex_attrs: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    source: str = "<memory>"
    meters_per_unit: float | None = None
    up_axis: str | None = None
    warnings: tuple[str, ...] = ()  # problems the reader noticed but could read past

    def __post_init__(self) -> None:
        object.__setattr__(self, "vertex_pos", np.ascontiguousarray(self.vertex_pos, np.float32))
        object.__setattr__(
            self, "face_vertex_counts", np.ascontiguousarray(self.face_vertex_counts, np.int32)
        )
        # int64 so that garbage indices in a file survive until the range check reports them.
        object.__setattr__(
            self, "face_vertex_indices", np.ascontiguousarray(self.face_vertex_indices, np.int64)
        )
        if self.face_vertex_uv is not None:
            object.__setattr__(
                self, "face_vertex_uv", np.ascontiguousarray(self.face_vertex_uv, np.float32)
            )
        attrs = {k: np.ascontiguousarray(v, np.float32) for k, v in self.vertex_attrs.items()}
        object.__setattr__(self, "vertex_attrs", attrs)
        n = self.vertex_pos.shape[0]
        if self.vertex_pos.ndim != 2 or self.vertex_pos.shape[1] != 3:
            raise MeshError(f"{self.source}: vertex positions must be (n,3), got {self.vertex_pos.shape}")
        for name, values in attrs.items():
            if values.shape != (n,):
                raise MeshError(
                    f"{self.source}: vertex attribute '{name}' has shape {values.shape}, expected ({n},)"
                )

    @property
    def vertex_count(self) -> int:
        return int(self.vertex_pos.shape[0])

    @property
    def face_count(self) -> int:
        return int(self.face_vertex_counts.shape[0])

    @property
    def face_offsets(self) -> np.ndarray:
        """i64 (f+1,) CSR offsets of each face into ``face_vertex_indices``."""
        offsets = np.zeros(self.face_count + 1, np.int64)
        np.cumsum(self.face_vertex_counts, out=offsets[1:])
        return offsets

    def replace(self, **changes) -> "ClothMesh":
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_triangles(cls, pos, triangles, **kwargs) -> "ClothMesh":
        triangles = np.asarray(triangles)
        return cls(
            vertex_pos=pos,
            face_vertex_counts=np.full(triangles.shape[0], 3, np.int32),
            face_vertex_indices=triangles.reshape(-1),
            **kwargs,
        )

    @classmethod
    def from_faces(cls, pos, faces, **kwargs) -> "ClothMesh":
        """Build from a list of faces (each a sequence of vertex indices)."""
        counts = np.array([len(f) for f in faces], np.int32)
        indices = np.array([i for f in faces for i in f], np.int64)
        return cls(vertex_pos=pos, face_vertex_counts=counts, face_vertex_indices=indices, **kwargs)

