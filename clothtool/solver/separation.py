"""Stage: separation constraints (each particle stays outside its backstop sphere)."""

from __future__ import annotations

from clothtool.solver.framefn import FusedCall
from clothtool.solver.iteration import Iteration
from clothtool.solver.kernels.constraints import constrain_separation
from clothtool.solver.stage import Stage


class SeparationStage(Stage):
    name = "separation"

    def warm_up(self) -> None:
        model = self.solver.model
        constrain_separation(model.backstop_centers[:0], model.backstop_radii[:0], self.solver.state.cur[:0])

    def run(self, iteration: Iteration) -> None:
        model = self.solver.model
        constrain_separation(model.backstop_centers, model.backstop_radii, self.solver.state.cur)

    def fused_call(self) -> FusedCall:
        model = self.solver.model
        return FusedCall(
            ("{separation}({centers}, {radii}, cur)",),
            {"centers": model.backstop_centers, "radii": model.backstop_radii},
            {"separation": constrain_separation},
        )
