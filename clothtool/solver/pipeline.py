"""Build a cloth's stage list from what its scene uses, in NvCloth's order.

A stage a cloth does not need is not created, so it costs nothing and does not appear in
the profile: no wind stage without drag or lift coefficients (air resistance acts in still
air too), no motion stage without a
painted max distance, no tethers without pinned particles, and so on.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from clothtool.solver.attach import AttachStage
from clothtool.solver.collide import CollideStage
from clothtool.solver.fabric import FabricStage
from clothtool.solver.integrate import IntegrateStage
from clothtool.solver.motion import MotionStage
from clothtool.solver.selfcollide import SelfCollideStage, needs_self_collide
from clothtool.solver.separation import SeparationStage
from clothtool.solver.sleep import SleepStage
from clothtool.solver.stage import Stage
from clothtool.solver.tethers import TetherStage
from clothtool.solver.wind import WindStage

if TYPE_CHECKING:  # pragma: no cover
    from clothtool.solver.cloth import ClothSolver

# The seed's order: integrate, wind, motion, tethers, fabric, separation, collide,
# self-collide, sleep; attachments move the body-bound particles right after integration.
STAGE_ORDER = ("integrate", "attach", "wind", "motion", "tethers", "fabric", "separation", "collide", "self-collide", "sleep")


def build_stages(solver: "ClothSolver") -> list[Stage]:
    model = solver.model
    material = model.material
    stages: list[Stage] = [IntegrateStage(solver)]
    if getattr(solver, "attachment", None) is not None:
        stages.append(AttachStage(solver))
    if material.drag_coefficient > 0 or material.lift_coefficient > 0:
        stages.append(WindStage(solver))
    if model.has_motion_constraints:
        stages.append(MotionStage(solver))
    if model.has_tethers and material.tether_stiffness > 0:
        stages.append(TetherStage(solver))
    if model.constraint_indices.shape[0]:
        stages.append(FabricStage(solver))
    if model.backstop_centers is not None:
        stages.append(SeparationStage(solver))
    if solver.environment.colliders is not None:
        stages.append(CollideStage(solver))
    if needs_self_collide(solver):  # self-collision, or cloth-cloth collision with neighbours
        stages.append(SelfCollideStage(solver))
    if solver.config.sleep_threshold > 0:
        stages.append(SleepStage(solver))
    return stages
