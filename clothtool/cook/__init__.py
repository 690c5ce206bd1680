"""Cooking: garment meshes into fabrics (adjacency, phases, scheduling, tethers, paint maps)."""
