"""The collision layer's neutral part: collider values that the scene builds, the solvers
collide against and the caches store, so that ``scene``, ``solver``/``integrators`` and ``io``
share them without importing each other (DESIGN.md section 2)."""
