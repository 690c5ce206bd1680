"""Explicit integrator: the classic mass-spring cloth with symplectic Euler substeps.

``ExplicitClothSolver`` (``solver``) drives like the position-based ``ClothSolver``;
``stability_limit`` (``stability``) gives the largest stable substep. A baseline that shows
why the position-based and implicit integrators exist: stiff cloth needs tiny substeps.
"""

from clothtool.integrators.explicit.solver import ExplicitClothSolver
from clothtool.integrators.explicit.stability import stability_limit, stability_report

__all__ = ["ExplicitClothSolver", "stability_limit", "stability_report"]
