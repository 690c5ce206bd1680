"""The implicit integrator's numba kernels, one module per stage, each mirrored by a plain
numpy reference of the same name in ``tests/reference/`` (``implicit_energies``,
``implicit_cg``, ``implicit_collision``, ``implicit_strain``, ``implicit_coloring``)."""
