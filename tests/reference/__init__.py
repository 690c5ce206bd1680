"""Plain-numpy references for the numba kernels (stumpy's habit).

One module per kernel module, named after it (``clothtool/solver/kernels/wind.py`` ->
``tests/reference/wind.py``, ``clothtool/mesh/coloring.py`` -> ``tests/reference/coloring.py``),
with one function per kernel under the kernel's name. A reference is written from the seed's
pseudo-code (``/work/shared/seeds/nvcloth-solver-internals.txt``) and the kernel's docstring,
never from the kernel's source, so that ``tests/kernels`` can catch kernel bugs.

References are pure: they take the kernel's arguments, leave them untouched and return the
results (float64 where the kernel updates float32 arrays in place). They favour clarity over
speed: vectorised numpy where the algorithm is order-independent, a plain loop where it is not.
``tests/kernels/test_conventions.py`` checks that no kernel goes without a reference.
"""
