"""Reading garment meshes and writing bake results: one module per kind of file."""
