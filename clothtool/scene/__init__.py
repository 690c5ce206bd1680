"""Scenes: TOML scene files, tracks and colliders."""
