"""Stage: wind, drag and lift per triangle (the seed's applyWind with the physical air law).

The force on a triangle is 1/2 rho C A |u|^2 with the angle terms of
``clothtool.solver.kernels.air`` (``fluid_density`` rho in kg/m^3 and the material's
ordinary aerodynamic drag and lift coefficients), a third of it on each corner of a triangle
mesh (on a quad mesh reweighted so that each particle's share matches its lumped mass,
``clothtool.solver.air``), applied as the displacement F h^2 / (3 m) that the force gives a
particle over one iteration. In that displacement the iteration length cancels (the
kernel's docstring shows how), so the stage passes only the density in scene units,
rho s^3 / 12 for s metres per scene unit, and the drag is the same at every solver
frequency: a sheet falling face-on reaches the terminal speed sqrt(2 m g / (rho C_d A)).
(NvCloth, with user-chosen inverse masses, treats the coefficients as tuning values,
converts them in log space and moves each corner by the whole triangle's impulse; this
tool's masses are physical, so its coefficients are too.)
"""

from __future__ import annotations

import numpy as np

from clothtool.mesh.coloring import TripletScheduler
from clothtool.solver.air import corner_shares
from clothtool.solver.framefn import FusedCall, held, standing
from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.wind import apply_wind
from clothtool.solver.stage import Stage

_NO_MOTION = (np.zeros((3, 3), np.float32), np.zeros(3, np.float32))
_STILL_AIR = np.zeros(3)  # the air's displacement over an iteration without wind
_STILL_AIR.flags.writeable = False


class WindStage(Stage):
    name = "wind"

    def __init__(self, solver):
        super().__init__(solver)
        # The kernel moves each triangle's particles before later triangles read them, as the
        # seed does. In mesh order consecutive triangles share particles, so each would wait
        # for the last; scheduled into colours as the cook schedules constraints (triangles of
        # a colour share no movable particle) the kernel solves a colour's triangles in
        # vectorised blocks, ~2.6x faster than one by one in mesh order. The update is the
        # seed's, in another triangle order.
        model = solver.model
        schedule = TripletScheduler(model.triangles, model.inv_mass > 0).sets()
        self.triangles = np.ascontiguousarray(model.triangles[schedule.order], np.int32)
        self.color_offsets = schedule.offsets
        self.share = corner_shares(model)
        # the air law's constants: the cloth's material and the scene's air, fixed for a bake
        material = model.material
        self.drag = np.float32(material.drag_coefficient)
        self.lift = np.float32(material.lift_coefficient)
        self.density = np.float32(solver.environment.fluid_density * model.units_to_meters**3 / 12.0)
        # per iteration i, at row row[0] + i (begin_frame): the frame's motion and the air in
        # the cloth's frame, the same arrays from frame to frame where they can be (a moving
        # frame's FrameStacks, held zeros and air without one), so that the fused call stands
        self.matrix = self.offset = self.air = None
        self.row = np.zeros(1, np.int64)
        self._first = 0
        self._still = False  # matrix and offset hold the zeros of a cloth without a track
        self._fused: FusedCall | None = None

    def begin_frame(self, plan: FramePlan) -> None:
        solver = self.solver
        if solver.environment.wind is None:  # still air: the same (read-only) zeros every frame
            self.wind_world = _STILL_AIR
        else:
            self.wind_world = solver.environment.wind_at(plan.time) * plan.h
        # per iteration: the frame's motion and the air's displacement in the cloth's frame
        terms = solver.frame_terms
        k = plan.iterations
        if terms is None:
            if not self._still or self.matrix.shape[0] != k:
                self.matrix = np.zeros((k, 3, 3), np.float32)
                self.offset = np.zeros((k, 3), np.float32)
                self.air = None
            self._still, self._first = True, 0
            self.air = held(self.air, np.broadcast_to(self.wind_world, (k, 3)), np.float32)
        else:
            rows = terms.stacks
            self._still, self._first = False, rows.first
            self.matrix, self.offset = rows.motion_matrix, rows.motion_offset
            self.air = terms.in_frame_rows(self.wind_world, np.float32)  # contiguous rows, as stacked() gives
        self.row[0] = self._first

    def warm_up(self) -> None:
        solver = self.solver
        matrix, offset = _NO_MOTION
        one = np.float32(1.0)
        apply_wind(self.triangles[:0], self.color_offsets[:1], self.share, matrix, offset, offset, one, one, one, solver.state.cur, solver.state.prev)

    def run(self, iteration: Iteration) -> None:
        solver = self.solver
        t = self._first + iteration.index
        apply_wind(
            self.triangles, self.color_offsets, self.share, self.matrix[t], self.offset[t], self.air[t], self.drag,
            self.lift, self.density, solver.state.cur, solver.state.prev,
        )

    def fused_call(self) -> FusedCall:
        values = (self.triangles, self.color_offsets, self.share, self.matrix, self.offset, self.air, self.drag, self.lift,
                  self.density, self.row)
        self._fused = standing(self._fused, _LINES, _NAMES, values, _KERNELS)
        return self._fused


_LINES = ("{wind}({triangles}, {color_offsets}, {share}, {matrix}[{row}[0] + it], {offset}[{row}[0] + it], "
          "{air}[{row}[0] + it], {drag}, {lift}, {density}, cur, prev)",)
_NAMES = ("triangles", "color_offsets", "share", "matrix", "offset", "air", "drag", "lift", "density", "row")
_KERNELS = {"wind": apply_wind}
