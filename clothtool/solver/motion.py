"""Stage: motion constraints (max distance from the rest pose in the cloth's frame, or from
the attached position on the body: ``solver.motion_centers``)."""

from __future__ import annotations

import numpy as np

from clothtool.solver.framefn import FusedCall, standing
from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.constraints import constrain_motion
from clothtool.solver.logstiffness import iteration_stiffness
from clothtool.solver.stage import Stage


class MotionStage(Stage):
    name = "motion"

    _h: float | None = None  # the iteration length the values are for
    _fused: FusedCall | None = None  # the last fused_call, kept while its values stand

    def begin_frame(self, plan: FramePlan) -> None:
        if plan.h == self._h:  # frames of one bake usually share their iteration length
            return
        self._h = plan.h
        motion = self.solver.model.motion
        self.scale = np.float32(motion.scale)
        self.bias = np.float32(motion.bias)
        self.stiffness = iteration_stiffness(motion.stiffness, self.solver.config.stiffness_frequency, plan.h)

    def warm_up(self) -> None:
        model = self.solver.model
        one = np.float32(1.0)
        constrain_motion(self.solver.motion_centers[:0], model.max_distance[:0], one, one, one, self.solver.state.cur[:0])

    def run(self, iteration: Iteration) -> None:
        model = self.solver.model
        constrain_motion(self.solver.motion_centers, model.max_distance, self.scale, self.bias, self.stiffness, self.solver.state.cur)

    def fused_call(self) -> FusedCall:
        values = (self.solver.motion_centers, self.solver.model.max_distance, self.scale, self.bias, self.stiffness)
        self._fused = standing(self._fused, _LINES, _NAMES, values, _KERNELS)
        return self._fused


_LINES = ("{motion}({centers}, {max_distance}, {scale}, {bias}, {stiffness}, cur)",)
_NAMES = ("centers", "max_distance", "scale", "bias", "stiffness")
_KERNELS = {"motion": constrain_motion}
