"""The ``grid`` step: the gait at every point of a (dtheta1, dtheta2) grid, the study's error map.

Points run in blocks of consecutive points (C order), each saved as a shard on the pool and
resumed; the consolidated dataset is streamed block by block, so memory stays flat as the grid
grows. Points that provably cannot reach the swap are marked ``unreachable`` without
integrating them (``skip_unreachable``).
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable, Iterable, Iterator, Literal, Optional

import numpy as np
from pydantic import Field, model_validator

from ...analysis.gait_kind import gait_kind_text, vertical_passes_before_swap
from ...simulation import Status, evaluate_cycle_gaits, swap_motor_times
from .. import datasets as D
from ..blocks import Block, Task, make_blocks
from ..models import Axis, Name, Point, StrictModel
from ..spec import GaitSpec
from .base import Dependency, Figure, StepContext, StepKind
from .gait_source import grid_minima, read_start

#: dims of a grid's values over the axes (a point list: ``point``)
MAP = ("dtheta1", "dtheta2")

#: the variables of a grid dataset (docs/datasets.md); a sequence gait's per segment
VARIABLES = {
    "dtheta1": D.Variable.of(("dtheta1",), np.float64, D.DTHETA1),
    "dtheta2": D.Variable.of(("dtheta2",), np.float64, D.DTHETA2),
    "point": D.index_coordinate("point", "grid point index", optional=True),
    "segment": D.index_coordinate("segment", D.SEGMENT_NOTE, optional=True),
    "error": D.Variable(MAP, np.float64, D.ERROR_UNITS, "{gait_error}; NaN unless ok",
                        {"comment": D.ERROR_COMMENT}),
    "status": D.Variable.of(MAP, np.int8, D.STATUS_ATTRS),
    "t_switch": D.Variable.of(MAP, np.float64, D.GAIT_ATTRS["t_switch"], optional=True),
    "t_motor": D.Variable.of(MAP, np.float64, D.GAIT_ATTRS["t_motor"], optional=True),
    "t_end": D.Variable(MAP, np.float64, "s", "time of {gait_end}"),
    "t_segment": D.Variable.of(MAP + ("segment",), np.float64, D.GAIT_ATTRS["t_segment"],
                               optional=True),
    "x_advance": D.Variable.of(MAP, np.float64, D.GAIT_ATTRS["x_advance"], optional=True),
    "y_advance": D.Variable.of(MAP, np.float64, D.GAIT_ATTRS["y_advance"], optional=True),
    "steps": D.Variable.of(MAP, np.int32, D.GAIT_ATTRS["steps"]),
    "nfev": D.Variable.of(MAP, np.int32, D.GAIT_ATTRS["nfev"]),
    "rejected": D.Variable.of(MAP, np.int32, D.GAIT_ATTRS["rejected"]),
}

#: Variables of a horizontal gait's grid block, with their dtype in blocks, shards and datasets.
HORIZONTAL_VARIABLES = {name: VARIABLES[name].dtype for name in (
    "error", "status", "t_switch", "t_motor", "t_end", "steps", "nfev", "rejected")}

#: Variables of a sequence gait's grid block (``t_segment`` has a trailing dim ``segment``).
SEQUENCE_VARIABLES = {name: VARIABLES[name].dtype for name in (
    "error", "status", "t_end", "t_segment", "x_advance", "y_advance", "steps", "nfev",
    "rejected")}


class GridStep(StrictModel):
    """Evaluate the gait at every combination of the axes, or at an explicit list of points."""

    name: Name
    kind: Literal["grid"]
    dtheta1: Optional[Axis] = Field(None, description="axis of initial dtheta1 [rad s-1]")
    dtheta2: Optional[Axis] = Field(None, description="axis of initial dtheta2 [rad s-1]")
    points: Optional[list[Point]] = Field(None, min_length=1,
                                          description="explicit (dtheta1, dtheta2) points "
                                                      "[rad s-1], instead of the axes")
    block_size: Optional[int] = Field(
        None, ge=1, le=1_000_000,
        description="points per block (unit of work and of resume); default: about 64 blocks "
                    "per grid, 512 to 8192 points each (fewer, larger shards on big grids)")
    skip_unreachable: bool = Field(True, description="mark points that provably cannot reach "
                                                     "the swap without integrating them")

    @model_validator(mode="after")
    def _axes_or_points(self) -> "GridStep":
        axes = (self.dtheta1 is not None, self.dtheta2 is not None)
        if self.points is not None:
            if any(axes):
                raise ValueError("give either the axes dtheta1 and dtheta2 or points, not both")
        elif not all(axes):
            raise ValueError("give both axes dtheta1 and dtheta2 (or points)")
        return self

    @property
    def n_points(self) -> int:
        if self.points is not None:
            return len(self.points)
        return self.dtheta1.num * self.dtheta2.num

    @property
    def points_per_block(self) -> int:
        """``block_size`` if given, else ~64 blocks of 512..8192 points. Depends on the study
        alone (never on the worker count), so block ids stay deterministic."""
        if self.block_size is not None:
            return self.block_size
        return int(min(8192, max(512, -(-self.n_points // 64))))

    @property
    def n_blocks(self) -> int:
        return -(-self.n_points // self.points_per_block)


def grid_variables(spec: GaitSpec) -> dict[str, type]:
    """The variables (name -> dtype) of the spec's grid blocks: the 2009 study's names or
    per segment (:attr:`~monkeystudy.study.spec.GaitSpec.swap_motor_times`)."""
    return HORIZONTAL_VARIABLES if spec.swap_motor_times else SEQUENCE_VARIABLES


def axes_points(a1: np.ndarray, a2: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """Points ``[hi - lo, 2]`` at flat C-order indices ``lo..hi`` of the grid ``a1 x a2``."""
    idx = np.arange(lo, hi)
    i, j = np.divmod(idx, a2.size)
    return np.stack([a1[i], a2[j]], axis=1)


def grid_points(step: GridStep, lo: int = 0, hi: int | None = None) -> np.ndarray:
    """Points ``[n, 2]`` (dtheta1, dtheta2) at flat indices ``lo..hi`` of a grid step."""
    hi = step.n_points if hi is None else hi
    if step.points is not None:
        return np.array(step.points[lo:hi], dtype=np.float64).reshape(-1, 2)
    return axes_points(step.dtheta1.values(), step.dtheta2.values(), lo, hi)


# --- tasks (run on the workers) ------------------------------------------------------------------
def grid_block(spec: GaitSpec, points, skip_unreachable: bool = True
               ) -> dict[str, np.ndarray]:
    """Evaluate the gait at ``points[n, 2]`` (dtheta1, dtheta2) [rad s-1], or at flat indices
    ``lo..hi`` of the grid ``a1 x a2`` given as ``points = (a1, a2, lo, hi)`` (the points are
    then made on the worker: a task carries the two axes, not its points).

    Returns the arrays of :func:`grid_variables` (``error`` NaN unless status is ok) of one
    cycle of the spec's gait (:func:`~monkeystudy.simulation.evaluate_cycle_gaits`); starts the
    gait says cannot reach its first guard are skipped (``skip_unreachable``).
    """
    if isinstance(points, tuple):
        points = axes_points(*points)
    r = evaluate_cycle_gaits(points, spec.sequence, robot=spec.robot,
                             integrator=spec.integrator, skip_unreachable=skip_unreachable)
    if spec.swap_motor_times:
        r.update(swap_motor_times(r["t_segment"]))
    return {name: np.asarray(r[name]).astype(dt, copy=False)
            for name, dt in grid_variables(spec).items()}


# --- the dataset ---------------------------------------------------------------------------------
def write_grid(path: Path, attrs: dict, *, axes: tuple[np.ndarray, np.ndarray] | None = None,
               points: np.ndarray | None = None,
               blocks: Iterable[tuple[int, dict[str, np.ndarray]]] = (),
               variables: dict | None = None, n_segments: int = 0,
               least_error_attrs: Callable[[float, float], dict] | None = None) -> dict:
    """Write a grid dataset, streaming ``blocks`` of ``(first flat index, arrays)``.

    ``axes`` (dtheta1, dtheta2 values) give dims ``dtheta1 x dtheta2`` (flat index in C order);
    ``points[n, 2]`` give dim ``point``. ``variables`` (name -> dtype) default to the
    horizontal gait's; ``n_segments > 0`` (a sequence gait) adds dim ``segment`` for
    ``t_segment``. The grid's least error and its start become the global attributes
    ``least_error``, ``least_error_dtheta1``, ``least_error_dtheta2`` (absent when no point
    has an error value), plus what ``least_error_attrs(dtheta1, dtheta2)`` returns.
    Returns ``{"skipped_fraction", "n_points", "least_error", "least_error_at", "attrs"}``
    (``attrs``: the least error's attributes written).
    """
    variables = HORIZONTAL_VARIABLES if variables is None else variables
    sequence = n_segments > 0
    with D.atomic_netcdf(path) as nc:
        if axes is not None:
            a1, a2 = (np.asarray(a, np.float64) for a in axes)
            D.write_coordinate(nc, VARIABLES, "dtheta1", a1)
            D.write_coordinate(nc, VARIABLES, "dtheta2", a2)
            dims, shape, coords = MAP, (a1.size, a2.size), ""
        else:
            pts = np.asarray(points, np.float64).reshape(-1, 2)
            D.write_coordinate(nc, VARIABLES, "point", np.arange(pts.shape[0]))
            D.write_declared(nc, VARIABLES, "dtheta1", pts[:, 0], dims=("point",))
            D.write_declared(nc, VARIABLES, "dtheta2", pts[:, 1], dims=("point",))
            dims, shape, coords = ("point",), (pts.shape[0],), "dtheta1 dtheta2"
        n = int(np.prod(shape))
        if sequence:
            D.write_coordinate(nc, VARIABLES, "segment", np.arange(n_segments))
        fields = D.gait_fields(sequence)
        vs = {name: D.write_declared(nc, VARIABLES, name, coordinates=coords,
                                     dims=dims + (("segment",) if name == "t_segment" else ()),
                                     **fields)
              for name in variables}
        written = skipped = 0
        least, least_at = np.inf, -1          # ties: the lowest flat index, as numpy's argmin
        for lo, arrays in coalesce(blocks, variables):
            for name, v in vs.items():
                write_flat(v, shape, lo, arrays[name])
            written += len(arrays["status"])
            skipped += int(np.count_nonzero(arrays["status"] == Status.UNREACHABLE))
            err = np.asarray(arrays["error"], np.float64)
            if np.isfinite(err).any() and np.nanmin(err) < least:
                least, least_at = float(np.nanmin(err)), lo + int(np.nanargmin(err))
        if written != n:
            raise RuntimeError(f"grid {path.name}: {written} of {n} points written")
        frac = skipped / n if n else 0.0
        extra: dict = {}
        at = None
        if least_at >= 0:
            if axes is not None:
                i, j = divmod(least_at, a2.size)
                at = (float(a1[i]), float(a2[j]))
            else:
                at = (float(pts[least_at, 0]), float(pts[least_at, 1]))
            extra = {"least_error": least, "least_error_dtheta1": at[0],
                     "least_error_dtheta2": at[1]}
            if least_error_attrs is not None:
                extra.update(least_error_attrs(*at))
        D.set_global_attrs(nc, dict(attrs, skipped_fraction=frac, n_points=n, **extra))
    return {"skipped_fraction": frac, "n_points": n,
            "least_error": least if at is not None else np.nan, "least_error_at": at,
            "attrs": extra}


def coalesce(blocks: Iterable[tuple[int, dict[str, np.ndarray]]], variables: dict,
              limit: int | None = None) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
    """Merge runs of contiguous blocks ``(first flat index, arrays)`` into pieces of at most
    ``limit`` points (default :data:`~monkeystudy.study.datasets.WRITE_BUFFER_POINTS`; a larger block is passed on
    alone, never split), cast to the variables' dtypes."""
    limit = D.WRITE_BUFFER_POINTS if limit is None else limit
    pending: list[dict[str, np.ndarray]] = []
    start = nxt = 0
    count = 0

    def merged():
        return start, {name: np.concatenate([np.asarray(a[name], dt) for a in pending])
                       if len(pending) > 1 else np.asarray(pending[0][name], dt)
                       for name, dt in variables.items()}

    for lo, arrays in blocks:
        m = len(arrays["status"])
        if pending and (lo != nxt or count + m > limit):
            yield merged()
            pending, count = [], 0
        if not pending:
            start = lo
        pending.append(arrays)
        count += m
        nxt = lo + m
    if pending:
        yield merged()


def write_flat(var, shape: tuple, lo: int, data: np.ndarray) -> None:
    """Write ``data[m, ...]`` at flat (C-order) point indices ``lo..lo+m`` of a variable over
    ``shape`` (1-D or 2-D) points, with any trailing dims of ``data`` (e.g. ``segment``)."""
    count = data.shape[0]
    if len(shape) == 1:
        var[lo:lo + count] = data
        return
    n2 = shape[1]
    trail = data.shape[1:]
    pos, k = lo, 0
    while k < count:
        i, j = divmod(pos, n2)
        if j == 0 and count - k >= n2:            # whole rows at once
            rows = (count - k) // n2
            var[i:i + rows, ...] = data[k:k + rows * n2].reshape((rows, n2) + trail)
            pos += rows * n2
            k += rows * n2
        else:                                     # a partial row
            m = min(n2 - j, count - k)
            var[i, j:j + m, ...] = data[k:k + m]
            pos += m
            k += m


# --- the kind ------------------------------------------------------------------------------------
class GridKind(StepKind):
    name = "grid"
    model = GridStep
    variables = VARIABLES
    gait_kinds = ("horizontal", "sequence")
    provides = "its best minima (starts of a refinement)"
    unit = "blocks"
    figures = (
        Figure("surface"),
        Figure("map"),
        Figure("swap_time"),
    )

    def blocks(self, step: GridStep) -> list[Block]:
        return make_blocks(step.n_points, step.points_per_block)

    def block_summary(self, step: GridStep) -> str:
        return f"{step.n_points} points, {step.points_per_block} per block"

    def n_tasks(self, step: GridStep, gait) -> int:
        return step.n_blocks

    def hand_on(self, dep: Dependency, ctx: StepContext, **options):
        return read_start(grid_minima, dep, ctx, options)

    def needs_runs(self, step) -> bool:
        # the finish runs the controller once (the kind of the map's best start): load
        # that kernel at warm-up, announced, not silently after the last block
        return True

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        skip = st.skip_unreachable
        if st.points is not None:
            pts = grid_points(st)
            return [Task(b, grid_block, (ctx.spec, pts[b.lo:b.hi], skip))
                    for b in ctx.todo_blocks()]
        a1, a2 = st.dtheta1.values(), st.dtheta2.values()
        return [Task(b, grid_block, (ctx.spec, (a1, a2, b.lo, b.hi), skip))
                for b in ctx.todo_blocks()]

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        st = ctx.step
        attrs["block_size"] = st.points_per_block
        where = ({"points": grid_points(st)} if st.points is not None else
                 {"axes": (st.dtheta1.values(), st.dtheta2.values())})
        blocks = ((b.lo, ctx.block_arrays(b)) for b in ctx.blocks)
        spec = ctx.spec

        # a small error can belong to a start that swaps only after swinging back and forth:
        # another gait than the study's; say which kind the map's best start is
        def least_error_kind(d1: float, d2: float) -> dict:
            return {"least_error_vertical_passes": vertical_passes_before_swap(
                d1, d2, robot=spec.robot, gait=spec.sequence, integrator=spec.integrator)}

        kind_attrs = least_error_kind if spec.swap_motor_times else None
        info = write_grid(ctx.path, attrs, blocks=blocks, variables=grid_variables(spec),
                          n_segments=spec.n_cycle_segments, least_error_attrs=kind_attrs, **where)
        text = f"{info['n_points']} points, skipped_fraction {info['skipped_fraction']:.3f}"
        if info["least_error_at"] is not None:
            text += (f", least error {info['least_error']:.3g} at "
                     f"({info['least_error_at'][0]:.6g}, {info['least_error_at'][1]:.6g})")
            if kind_attrs is not None:
                passes = info["attrs"]["least_error_vertical_passes"]
                text += f", {gait_kind_text(int(passes))}"
        return text

    def describe(self, ds) -> list[str]:
        a = ds.attrs
        lines = [f"points: {int(ds['status'].size)}, skipped_fraction "
                 f"{float(a.get('skipped_fraction', np.nan)):.3f}",
                 f"status: {D.status_counts(ds['status'].values)}"]
        err = ds["error"].values
        if np.isfinite(err).any():
            k = int(np.nanargmin(err))
            if ds["error"].ndim == 2:
                i, j = np.unravel_index(k, err.shape)
                d1, d2 = float(ds["dtheta1"][i]), float(ds["dtheta2"][j])
            else:
                d1, d2 = float(ds["dtheta1"][k]), float(ds["dtheta2"][k])
            line = (f"least error {np.nanmin(err):.4g} at dtheta1 = {d1:.6g}, "
                    f"dtheta2 = {d2:.6g} rad s-1")
            if "t_switch" in ds:
                line += f", swap at {float(ds['t_switch'].values.flat[k]):.4g} s"
            if "least_error_vertical_passes" in a:
                line += f": {gait_kind_text(int(a['least_error_vertical_passes']))}"
            lines.append(line)
        else:
            lines.append("no point with an error value")
        return lines
