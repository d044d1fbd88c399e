"""The ``basin`` step: how many cycles a gait survives from perturbed starts (a basin map).

A grid of offsets of the start's (dtheta1, dtheta2) around the gait; each start runs until its
error against the unperturbed gait exceeds ``error_bound``, it falls, or ``max_cycles``. More
than :data:`BASIN_TASK_POINTS` starts run as blocks of whole rows on the pool, each saved as
a shard and resumed like grid blocks.
"""
from __future__ import annotations

from pathlib import Path
from typing import Literal, Optional

import numpy as np
from pydantic import Field

from ...analysis.replay import sequence_basin
from ...controllers import SequenceGait
from .. import datasets as D
from ..blocks import Block, Task
from ..models import Axis, Name, Replay, StrictModel
from ..spec import GaitSpec
from .base import Figure, StepContext, StepKind
from .gait_source import gait_line, run_problems


class BasinOffsets(StrictModel):
    d_dtheta1: Axis = Field(description="offsets of the start's dtheta1 [rad s-1]")
    d_dtheta2: Axis = Field(description="offsets of the start's dtheta2 [rad s-1]")


#: a basin with more points than this runs as blocks of rows on the pool (else one task)
BASIN_TASK_POINTS = 400

#: points per basin block (whole rows of d_dtheta2, at least one row)
BASIN_BLOCK_POINTS = 100


class BasinStep(StrictModel):
    """Cycles an open-loop replay of the gait (a sequence gait: ``replay``) survives from
    perturbed starts. More than
    ``BASIN_TASK_POINTS`` points are split into blocks of whole rows (about
    ``BASIN_BLOCK_POINTS`` points each) on the pool, each saved as a shard (resumable)."""

    name: Name
    kind: Literal["basin"]
    from_: Name = Field(alias="from")  # described by the kind (accepts)
    replay: Replay = None
    offsets: BasinOffsets = Field(description="start offsets (d_dtheta1, d_dtheta2) [rad s-1]")
    max_cycles: int = Field(60, ge=1, le=100_000, description="cycles per run (a start that "
                            "never fails scores this)")
    error_bound: float = Field(1e-2, gt=0, description="failure: error against the "
                               "unperturbed gait above this [1]")
    tick: Optional[float] = Field(None, ge=0, le=1.0, description="controller tick [s] "
                                  "(default: the gait's)")
    solution: Optional[int] = Field(None, ge=0, description="which solution of the shoot "
                                    "step (default: the lowest error)")

    @property
    def n_points(self) -> int:
        return self.offsets.d_dtheta1.num * self.offsets.d_dtheta2.num

    @property
    def rows_per_block(self) -> int:
        """Rows of d_dtheta1 per task: all of them up to ``BASIN_TASK_POINTS`` points."""
        n1, n2 = self.offsets.d_dtheta1.num, self.offsets.d_dtheta2.num
        if self.n_points <= BASIN_TASK_POINTS:
            return n1
        return max(1, BASIN_BLOCK_POINTS // n2)


# --- tasks (run on the workers) ------------------------------------------------------------------
def basin_block(spec: GaitSpec, gait: SequenceGait, z_star, offsets1: np.ndarray,
                offsets2: np.ndarray, *, times, max_cycles: int, error_bound: float,
                tick: float, replay: str) -> dict[str, np.ndarray]:
    """Cycles ``gait`` survives from starts ``z_star + (0, a, b)`` for ``a`` in ``offsets1``
    (rows of the basin), ``b`` in ``offsets2`` [rad s-1], as its own controller or replayed
    open-loop with the fixed point's segment exit ``times`` [s] (None: its own cycle's;
    :func:`~monkeystudy.analysis.replay.sequence_basin`); returns ``{"cycles": int32 array
    [len(offsets1) * len(offsets2)]}`` in C order."""
    B = sequence_basin(gait, np.asarray(z_star, float), np.asarray(offsets1, float),
                       np.asarray(offsets2, float), max_cycles=int(max_cycles),
                       error_bound=float(error_bound), robot=spec.robot,
                       integrator=spec.integrator, replay=replay, times=times,
                       tick=float(tick))
    return {"cycles": np.ascontiguousarray(B, np.int32).ravel()}


# --- the dataset ---------------------------------------------------------------------------------
#: the variables of a basin dataset (docs/datasets.md)
VARIABLES = {
    **{dim: D.Variable((dim,), np.float64, D.RATE,
                       f"offset of the start's {what} from the gait")
       for dim, what in (("d_dtheta1", "dtheta1"), ("d_dtheta2", "dtheta2"))},
    "cycles": D.Variable(("d_dtheta1", "d_dtheta2"), np.int32, "1",
                         "cycles survived before the error against the gait exceeded "
                         "error_bound, the run fell or stopped (max_cycles: never)"),
}


def write_basin(path: Path, attrs: dict, offsets1: np.ndarray, offsets2: np.ndarray,
                cycles: np.ndarray) -> None:
    """Write a basin dataset: cycles survived ``[len(offsets1), len(offsets2)]``."""
    with D.atomic_netcdf(path) as nc:
        D.write_coordinate(nc, VARIABLES, "d_dtheta1", np.asarray(offsets1, float))
        D.write_coordinate(nc, VARIABLES, "d_dtheta2", np.asarray(offsets2, float))
        D.write_declared(nc, VARIABLES, "cycles", cycles)
        D.set_global_attrs(nc, attrs)


# --- the kind ------------------------------------------------------------------------------------
class BasinKind(StepKind):
    name = "basin"
    model = BasinStep
    variables = VARIABLES
    gait_kinds = ("horizontal", "sequence")
    accepts = ("shoot", "floquet")
    unit = "blocks"
    figures = (
        Figure("cycles_map"),
    )

    def check_step(self, study, index, step: BasinStep, ref, seen) -> list:
        return run_problems(study, index, step, ref)

    def blocks(self, step: BasinStep) -> list[Block]:
        """Blocks of whole rows of d_dtheta1 (flat C-order point indices ``lo..hi``)."""
        n1, n2 = step.offsets.d_dtheta1.num, step.offsets.d_dtheta2.num
        rows = step.rows_per_block
        return [Block(i, r0 * n2, min(r0 + rows, n1) * n2)
                for i, r0 in enumerate(range(0, n1, rows))]

    def block_summary(self, step: BasinStep) -> str:
        return f"{step.n_points} starts"

    def n_tasks(self, step: BasinStep, gait) -> int:
        return len(self.blocks(step))

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        g = ctx.handed_on(solution=st.solution, replay=st.replay)
        tick = st.tick if st.tick is not None else ctx.study.gait.tick
        ctx.state.update(gait=g, tick=tick)
        o1, o2 = st.offsets.d_dtheta1.values(), st.offsets.d_dtheta2.values()
        n2 = o2.size
        kw = {"max_cycles": st.max_cycles, "error_bound": st.error_bound, "tick": tick,
              "replay": g.replay, "times": g.times}
        return [Task(b, basin_block, (ctx.spec, g.gait, g.z, o1[b.lo // n2:b.hi // n2], o2),
                     kw) for b in ctx.todo_blocks()]

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        st = ctx.step
        cycles = np.empty(st.n_points, np.int32)
        for b in ctx.blocks:
            cycles[b.lo:b.hi] = ctx.block_arrays(b)["cycles"]
        cycles = cycles.reshape(st.offsets.d_dtheta1.num, st.offsets.d_dtheta2.num)
        g = ctx.state["gait"]
        attrs.update(g.attrs("run"), motor_torque=g.torque, max_cycles=st.max_cycles,
                     error_bound=st.error_bound, tick=ctx.state["tick"],
                     n_blocks=len(ctx.blocks))
        write_basin(ctx.path, attrs, st.offsets.d_dtheta1.values(),
                    st.offsets.d_dtheta2.values(), cycles)
        i0 = int(np.argmin(np.abs(st.offsets.d_dtheta1.values())))
        j0 = int(np.argmin(np.abs(st.offsets.d_dtheta2.values())))
        return (f"{cycles.size} starts: cycles at the least offset {int(cycles[i0, j0])}, "
                f"median {float(np.median(cycles)):g}, max {int(cycles.max())} of "
                f"{st.max_cycles}")

    def describe(self, ds) -> list[str]:
        a = ds.attrs
        c = ds["cycles"].values
        o1, o2 = ds["d_dtheta1"].values, ds["d_dtheta2"].values
        i0, j0 = int(np.argmin(np.abs(o1))), int(np.argmin(np.abs(o2)))
        return [gait_line(a),
                f"{c.size} starts, offsets d_dtheta1 {o1[0]:.3g}..{o1[-1]:.3g}, d_dtheta2 "
                f"{o2[0]:.3g}..{o2[-1]:.3g} rad s-1; tick {a.get('tick')} s, error bound "
                f"{a.get('error_bound')}",
                f"cycles: at the least offset ({o1[i0]:.3g}, {o2[j0]:.3g}) {int(c[i0, j0])}, "
                f"min {int(c.min())}, median {float(np.median(c)):g}, max {int(c.max())} of "
                f"{a.get('max_cycles')}"]
