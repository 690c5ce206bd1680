"""Numba kernels of the explicit (mass-spring) integrator, one module per stage.

Module names carry an ``explicit_`` prefix because each kernel module's numpy reference lives
in the flat ``tests/reference/`` folder under the module's last name part.
"""
