"""clothtool: cook garment meshes into fabrics and bake fabrics into HDF5/USD caches.

Importing this package is cheap on purpose: numba, h5py and pxr load only when a command
or function that needs them runs.
"""

__version__ = "0.1.0"
