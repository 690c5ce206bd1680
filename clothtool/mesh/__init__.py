"""Garment meshes as read from disk, before cooking."""

from clothtool.mesh.clothmesh import ClothMesh

__all__ = ["ClothMesh"]
