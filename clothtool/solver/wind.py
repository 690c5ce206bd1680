"""Stage: wind, drag and lift per triangle (the seed's applyWind).

The kernel keeps the seed's formula; this stage chooses its parameters so that the result is
physical with the solver's real particle masses (1/kg). The seed's impulse moves a particle
by 2 c |cos| |d|^2 A rho_n w / h, and the physical displacement F h^2 / m of the drag force
F = 1/2 rho c A v^2 |cos| (v = |d| / h, lengths s metres per scene unit) is equal to it when
rho_n = rho s^3 h / 4. So ``fluid_density`` is the air's density in kg/m^3 and the material's
drag and lift coefficients are ordinary aerodynamic coefficients. (NvCloth, with user-chosen
inverse masses, instead treats them as tuning values and converts the coefficients in log
space; with physical masses that made drag about a hundred times too strong.)
"""

from __future__ import annotations

import numpy as np

from clothtool.cook.triplets import TripletScheduler
from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.wind import apply_wind
from clothtool.solver.stage import Stage

_NO_MOTION = (np.zeros((3, 3), np.float32), np.zeros(3, np.float32))


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

    def begin_frame(self, plan: FramePlan) -> None:
        solver = self.solver
        material = solver.model.material
        self.drag = np.float32(material.drag_coefficient)
        self.lift = np.float32(material.lift_coefficient)
        self.inv_dt = np.float32(1.0 / plan.h)
        s = solver.model.units_to_meters
        self.density = np.float32(solver.environment.fluid_density * s**3 * plan.h / 4.0)
        self.wind_world = solver.environment.wind_at(plan.time) * plan.h

    def warm_up(self) -> None:
        solver = self.solver
        matrix, offset = _NO_MOTION
        one = np.float32(1.0)
        apply_wind(self.triangles[:0], self.color_offsets[:1], matrix, offset, offset, one, one, one, one, solver.state.cur, solver.state.prev)

    def run(self, iteration: Iteration) -> None:
        solver = self.solver
        if iteration.terms is None:
            matrix, offset = _NO_MOTION
            air = self.wind_world.astype(np.float32)
        else:
            matrix, offset = iteration.terms.motion_matrix, iteration.terms.motion_offset
            air = (iteration.terms.to_local @ self.wind_world).astype(np.float32)
        apply_wind(
            self.triangles, self.color_offsets, matrix, offset, air, self.inv_dt, self.drag, self.lift, self.density,
            solver.state.cur, solver.state.prev,
        )
