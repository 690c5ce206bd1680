"""Baraff & Witkin's implicit cloth integrator (DESIGN.md section 4, the slides' seed).

Modules, in the order a step uses them:

* ``rest``: the rest state, computed once per cloth: material-space (u,v) frames per
  triangle, bending hinges and their rest angles and weights.
* ``pattern``: the fixed 3x3-block sparsity pattern of the system matrix, the colouring of
  elements into particle-disjoint groups (parallel assembly without conflicts), the edges.
* ``kernels.implicit_energies``: the stretch, shear and bend conditions (forces, df/dx,
  df/dv) accumulated straight into the system matrix, and air drag and lift.
* ``kernels.implicit_cg``: the block-sparse matrix-vector product and the filtered,
  block-Jacobi preconditioned conjugate gradient.
* ``kernels.implicit_collision``: Bridson's repulsion, friction, inelastic impulses and
  final robust pass on the shared collision geometry (``clothtool.solver.collide`` poses
  the colliders, ``clothtool.solver.kernels.collide`` measures the contacts).
* ``kernels.implicit_strain``: strain limiting, the safety net of large steps.
* ``solver``: ``ImplicitClothSolver``, which the bake drives like ``ClothSolver``.
"""
