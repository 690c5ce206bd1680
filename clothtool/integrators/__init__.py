"""Integrators beyond NvCloth's position-based solver (DESIGN.md section 4).

Each lives in its own package beside its kernels and offers the ``ClothSolver`` interface
(``plan_frame``, ``iteration``, ``iterate``, ``step``, ``world_points``...), so that the bake
can drive any of them:

* ``implicit``: Baraff & Witkin's stretch/shear/bend energies with linearised backward Euler
  and a filtered, preconditioned conjugate gradient; Bridson-style collisions.
* ``explicit``: the classic mass-spring model with symplectic Euler.
"""
