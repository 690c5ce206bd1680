"""numba kernels, one module per solver stage. Each is mirrored by a numpy reference in
tests/reference/ that the kernel tests compare against on random inputs.

Conventions: particle arrays are float32 (n,4) with the inverse mass in column 3 (NvCloth's
layout); read-only arrays first, then scalars, then arrays updated in place; no allocation.
"""
