"""Stage: tether constraints (long-range max-distance constraints to pinned anchors)."""

from __future__ import annotations

import numpy as np

from clothtool.solver.framefn import FusedCall
from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.constraints import constrain_tethers
from clothtool.solver.logstiffness import iteration_stiffness
from clothtool.solver.stage import Stage


class TetherStage(Stage):
    name = "tethers"

    _h: float | None = None  # the iteration length the stiffness is for
    _fused: FusedCall | None = None  # the last fused_call, kept while its values stand

    def begin_frame(self, plan: FramePlan) -> None:
        if plan.h == self._h:  # frames of one bake usually share their iteration length
            return
        self._h = plan.h
        model = self.solver.model
        material = model.material
        k = iteration_stiffness(material.tether_stiffness, self.solver.config.stiffness_frequency, plan.h)
        # NvCloth: stiffness * numParticles / numTethers, so k slots average rather than add
        self.stiffness = np.float32(k * model.particle_count / model.tether_anchor.shape[0])
        self.scale = np.float32(material.tether_scale)

    def warm_up(self) -> None:
        model = self.solver.model
        one = np.float32(1.0)
        constrain_tethers(model.tether_anchor[:0], model.tether_rest_length[:0], one, one, self.solver.state.cur[:0])

    def run(self, iteration: Iteration) -> None:
        model = self.solver.model
        constrain_tethers(model.tether_anchor, model.tether_rest_length, self.scale, self.stiffness, self.solver.state.cur)

    def fused_call(self) -> FusedCall:
        fused = self._fused
        if fused is not None and fused.args["stiffness"] is self.stiffness:  # begin_frame kept the values
            return fused
        model = self.solver.model
        fused = self._fused = FusedCall(
            ("{tethers}({anchor}, {rest_length}, {scale}, {stiffness}, cur)",),
            {"anchor": model.tether_anchor, "rest_length": model.tether_rest_length, "scale": self.scale,
             "stiffness": self.stiffness},
            {"tethers": constrain_tethers},
        )
        return fused
