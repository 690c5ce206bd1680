"""clothtool: cook garment meshes into fabrics and bake fabrics into HDF5/USD caches.

Importing this package is cheap on purpose: numba, h5py and pxr load only when a command
or function that needs them runs.
"""

__version__ = "0.1.0"

import os

# numba raises and catches its own exceptions while it compiles (a global that is a module,
# a constant that cannot be a literal, an overload that does not match: thousands per
# kernel) and by default formats every message through colorama, which wraps and unwraps
# sys.stdout and sys.stderr each time: ~33 us an exception, about 0.5 s of CPU of the walk
# bake's cold start. Plain messages instead. Read when numba.core.errors is imported, so it
# is set here, before any clothtool module can import numba; a user's own setting wins.
os.environ.setdefault("NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING", "1")
