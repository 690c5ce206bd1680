"""The stage interface: each solver stage is a small class over one cloth's arrays."""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING

from clothtool.solver.framefn import FusedCall
from clothtool.solver.iteration import FramePlan, Iteration

if TYPE_CHECKING:  # pragma: no cover
    from clothtool.solver.cloth import ClothSolver


class Stage(abc.ABC):
    """A solver stage. ``name`` is what the profiler and the report call it."""

    name = "stage"

    @property
    def fused(self) -> bool:
        """True: runs inside the compiled frame function (clothtool.solver.framefn)."""
        return True

    def __init__(self, solver: "ClothSolver"):
        self.solver = solver

    def begin_frame(self, plan: FramePlan) -> None:  # noqa: B027 - optional hook
        """Precompute what stays constant over the frame's iterations."""

    @abc.abstractmethod
    def warm_up(self) -> None:
        """Compile this stage's kernels for its arrays' types, by calling them on zero-length
        views (no particle changes); the bake times this as "jit warm-up"."""

    @abc.abstractmethod
    def run(self, iteration: Iteration) -> None:
        """Advance this stage's part of one iteration, updating the cloth's state in place."""

    @abc.abstractmethod
    def fused_call(self) -> FusedCall:
        """What ``run`` does, as lines of the compiled frame function: the same kernels with
        the same arguments (per-iteration values indexed by ``it``), for the current frame."""

    def end_fused_frame(self) -> None:  # noqa: B027 - optional hook
        """Take back what the compiled frame function left in the stage's arrays."""
