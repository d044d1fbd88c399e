"""The ``survival`` step: how many cycles a gait lasts under noise, and its mean first-passage
time (MFPT) to failure, for one or more noise levels.

From a gait's start (a shoot, refine or floquet step; a sequence gait's floquet or refine
step), ``runs`` independent runs of up to ``max_cycles`` cycles, each with its own noise
(:mod:`monkeystudy.analysis.survival`): actuation timing jitter, sensor noise on the guards,
torque error per pulse, robot parameters drawn per run, a perturbed start. Every noise value
may be a list: the step then runs each level (the lists' common length) with the same runs'
draws, scaled (common random numbers: the levels differ by the noise, not by luck). Runs are
blocks on the pool, saved as shards; the noise of a run depends only on ``(seed, run,
cycle)``, so the dataset is the same for any number of workers and after a resume.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import ClassVar, Literal, Optional

import numpy as np
from pydantic import Field

from ...analysis.sections import cycle_section_state
from ...analysis.survival import (
    ERROR_BOUND, MFPT, STALLED, Noise, catches_per_cycle, cycle_grid, mfpt, survival_curve,
    survival_runs, travel_direction,
)
from ...simulation import STATUS_NAMES, Status
from .. import datasets as D
from ..blocks import Block, Task
from ..models import Name, OpenLoopSettings, Replay, StrictModel
from ..noise import SOURCES, NoiseSpec
from ..counts import task_units
from ..spec import GaitSpec
from .base import Figure, StepContext, StepKind, max_drop_of
from .gait_source import MAX_MAP_DEFECT, GaitStart, robot_attr, run_problems


#: simulated cycles a block of runs may take at most (a run that never fails costs
#: max_cycles): blocks of about this much work keep the shards small and the pool busy
BLOCK_CYCLES = 200_000

#: why a run stopped: its failing cycle's status, ``ok`` when it completed max_cycles
FAILURE_CODES = tuple(int(c) for c in (
    Status.OK, Status.NO_SWITCH, Status.ENERGY_NOT_RESTORED, Status.NO_RETURN_TO_VERTICAL,
    Status.NON_FINITE, Status.STEP_FAILURE, Status.BUFFER_FULL, Status.HORIZON, Status.FELL,
    ERROR_BOUND, STALLED))
FAILURE_NAMES = tuple({Status.OK: "survived", ERROR_BOUND: "error_bound",
                       STALLED: "stalled"}.get(c) or STATUS_NAMES[c]
                      for c in FAILURE_CODES)
MFPT_METHODS = ("mean", "tail", "lower_bound", "none")


class SurvivalStep(StrictModel):
    """Runs of a gait under noise until each fails or completes ``max_cycles``: survival per
    cycle and the mean first-passage time (MFPT) to failure with a 95 % interval."""

    name: Name
    kind: Literal["survival"]
    from_: Name = Field(alias="from")  # described by the kind (accepts)
    replay: Replay = None
    controller: OpenLoopSettings = Field(default_factory=OpenLoopSettings)
    runs: int = Field(ge=1, le=1_000_000, description="independent runs per noise level")
    max_cycles: int = Field(ge=2, le=100_000_000, description="cycles after which a run "
                            "stops as a survivor (right-censored)")
    error_bound: Optional[float] = Field(None, gt=0, description="a cycle that ends with a "
                                         "larger error against the gait fails the run "
                                         "[rad2 + rad2 s-2] (default: only falls and "
                                         "missed events fail)")
    min_advance: Optional[float] = Field(None, description="a cycle whose attached end "
                                         "advances horizontally less than this, the way "
                                         "the gait travels, fails the run ('stalled': it "
                                         "stopped travelling) [m] (default: no minimum)")
    max_drop: Optional[float] = Field(None, gt=0, description="a run fails ('fell') when "
                                      "the attached end sinks this far [m] (default: link "
                                      "1's length)")
    seed: int = Field(0, ge=0, le=2**63 - 1, description="the noise's seed: with the run "
                      "and the cycle it keys every draw")
    noise: NoiseSpec = Field(default_factory=NoiseSpec)
    solution: Optional[int] = Field(None, ge=0, description="which solution of a shoot step "
                                    "(default: the lowest error)")
    start_index: Optional[int] = Field(None, ge=0, description="which start of a refine step "
                                       "(default: the lowest error)")
    height_tolerance: Optional[float] = Field(None, gt=0, description="report, per noise "
                                              "level, the fraction of the runs that completed "
                                              "max_cycles whose attached end ended within this "
                                              "of its planned height [m]: its start height, "
                                              "plus the gait's rise per cycle completed "
                                              "(default: not reported; every run's "
                                              "height_drift is written)")

    recorded_when_set: ClassVar[frozenset[str]] = frozenset({"height_tolerance"})

    @property
    def n_levels(self) -> int:
        return self.noise.n_levels

    @property
    def runs_per_block(self) -> int:
        return max(1, min(self.runs, BLOCK_CYCLES // self.max_cycles))


# --- the gait a survival step runs ---------------------------------------------------------------
def survival_controller(start: GaitStart, *, tick: float, integrator):
    """``(controller, start hybrid state, section observer)`` of a survival start: its gait
    as its own controller or replayed open-loop with the start's recorded times
    (:meth:`~monkeystudy.study.steps.gait_source.GaitStart.program`), on the controller
    ``tick`` [s], its cycles measured by exact observers of the section (a gait whose cycles
    alternate with their mirror images runs both, :meth:`~monkeystudy.controllers.
    SequenceGait.loop_segments`)."""
    seq = start.program(tick, integrator)
    return seq.loop_controller(), cycle_section_state(seq, start.z), seq.section_observers()


# --- tasks (run on the workers) ------------------------------------------------------------------
def survival_block(spec: GaitSpec, start: GaitStart, runs: np.ndarray, *, noise: dict,
                   max_cycles: int, error_bound: float, min_advance: float, max_drop: float,
                   tick: float, seed: int) -> dict[str, np.ndarray]:
    """Runs number ``runs`` of the start's gait under ``noise`` (a :class:`~monkeystudy.
    analysis.survival.Noise` as a mapping), on its robot: per run the cycles completed, why it
    stopped, the distance travelled [m], the time [s] and error at its last completed cycle,
    its RHS evaluations, the attached end's height change there [m]. Each run counts as it
    ends (:func:`~monkeystudy.study.counts.task_units`)."""
    controller, hyb, section = survival_controller(start, tick=tick,
                                                   integrator=spec.integrator)
    # a minimum advance is measured the way the gait travels (a ladder gait may go to -x)
    travel = (travel_direction(controller, hyb, robot=start.robot, integrator=spec.integrator)
              if math.isfinite(min_advance) else 1.0)
    r = survival_runs(controller, hyb, start.z[-3:], runs=runs, max_cycles=max_cycles,
                      noise=Noise(**noise), seed=seed, robot=start.robot,
                      integrator=spec.integrator, error_bound=error_bound,
                      min_advance=min_advance, travel=travel, max_drop=max_drop,
                      section=section, progress=task_units)
    return {"cycles": r.cycles.astype(np.int64), "failure": r.failure.astype(np.int8),
            "distance": r.distance, "time": r.time, "error": r.error, "nfev": r.nfev,
            "height": r.height}


# --- the dataset ---------------------------------------------------------------------------------
def level_summary(cycles: np.ndarray, failure: np.ndarray, distance: np.ndarray,
                  max_cycles: int) -> dict:
    """One noise level's estimates from its runs (:func:`~monkeystudy.analysis.survival.mfpt`)."""
    failed = failure != Status.OK
    m: MFPT = mfpt(cycles, failed, max_cycles)
    total = int(cycles.sum())
    advance = float(distance.sum() / total) if total else math.nan
    return {"mfpt": m, "advance": advance,
            "counts": np.array([int(np.sum(failure == c)) for c in FAILURE_CODES], np.int64)}


def height_within(height_drift: np.ndarray, failure: np.ndarray, tolerance: float) -> float:
    """The fraction of the runs that completed their cycles (``failure`` ok) whose attached
    end ended within ``tolerance`` [m] of its planned height (``height_drift`` [m]: from the
    start's height, plus the gait's rise per cycle); NaN when no run completed them."""
    done = failure == Status.OK
    if not done.any():
        return math.nan
    return float(np.mean(np.abs(height_drift[done]) <= tolerance))


#: what the MFPT counts
MFPT_CYCLES = "cycles (completed before failure)"

#: what the MFPT counts in a gait that catches bars
MFPT_BRACHIATIONS = ("brachiations (the bar catches of the cycles completed before failure: "
                     "cycles times catches_per_cycle)")

#: the MFPT and its interval: (variable, what it is)
MFPT_ESTIMATES = (("mfpt", "mean first-passage time to failure"),
                  ("mfpt_low", "lower end of the MFPT's 95 % interval"),
                  ("mfpt_high", "upper end of the MFPT's 95 % interval"))

#: the variables of a survival dataset (docs/datasets.md); a noise value's long_name says its
#: spread (``{spread}``: standard deviation or half-width, as the step's distribution)
VARIABLES = {
    "level": D.index_coordinate("level", "noise level (every noise value of the level below)"),
    "run": D.index_coordinate("run", "run number (keys its noise with the seed)"),
    "cycle": D.Variable(("cycle",), np.int64, "1", "cycles completed"),
    "failure_mode": D.label_coordinate("failure_mode", "why a run stopped (survived: it "
                                       "completed max_cycles)"),
    **{f"noise_{s.name}": D.Variable(("level",), np.float64, s.units,
                                     s.what + ("" if s.uniform_per_run else "{spread}"),
                                     {"key": "noise." + ".".join(s.key)}, optional=s.when_set)
       for s in SOURCES},
    "cycles_completed": D.Variable(("level", "run"), np.int64, "1",
                                   "cycles the run completed within the bounds"),
    "failure": D.Variable(("level", "run"), np.int8, "1", "why the run stopped (survived: "
                          "completed max_cycles, right-censored)",
                          {"flag_values": np.array(FAILURE_CODES, np.int8),
                           "flag_meanings": " ".join(FAILURE_NAMES)}),
    "distance": D.Variable(("level", "run"), np.float64, "m", "horizontal travel of the "
                           "attached end up to the last completed cycle"),
    "time_survived": D.Variable(("level", "run"), np.float64, "s",
                                "time of the last completed cycle's end"),
    "height_drift": D.Variable(("level", "run"), np.float64, "m",
                               "height of the attached end at the last completed cycle's end "
                               "less {planned} (after max_cycles for a run that "
                               "completed them; 0 when none completed)"),
    "height_within_tolerance": D.Variable(("level",), np.float64, "1",
                                          "fraction of the runs that completed max_cycles "
                                          "whose height_drift is within height_tolerance "
                                          "(attribute) of 0", optional=True),
    "final_error": D.Variable(("level", "run"), np.float64, D.ERROR_UNITS,
                              "section error against the gait at the last completed cycle's "
                              "end (at the start when none completed)",
                              {"comment": D.ERROR_COMMENT}),
    "survival": D.Variable(("level", "cycle"), np.float64, "1",
                           "fraction of runs that completed at least this many cycles "
                           "(Kaplan-Meier; every run censored at max_cycles)"),
    **{name: var for key, what in MFPT_ESTIMATES for name, var in (
        (key, D.Variable(("level",), np.float64, "1", f"{what} [{MFPT_CYCLES}]",
                         {"comment": "restricted mean up to max_cycles plus a constant-hazard "
                                     "tail fitted on the window's second half; 95 % percentile "
                                     "bootstrap over runs (see mfpt_method)"})),
        (key.replace("mfpt", "mfpt_distance"),
         D.Variable(("level",), np.float64, "m", f"{what} as distance travelled (MFPT times "
                    "the mean advance per completed cycle)")))},
    **{f"{key}_brachiations": D.Variable(
        ("level",), np.float64, "1", f"{what} [{MFPT_BRACHIATIONS}]",
        {"comment": "the MFPT in cycles times catches_per_cycle (attribute)"}, optional=True)
       for key, what in MFPT_ESTIMATES},
    "mfpt_method": D.Variable(("level",), np.int8, "1", "how the MFPT was estimated",
                              {"flag_values": np.arange(len(MFPT_METHODS), dtype=np.int8),
                               "flag_meanings": " ".join(MFPT_METHODS)}),
    "restricted_mean": D.Variable(("level",), np.float64, "1",
                                  f"mean of min(cycles completed, max_cycles) [{MFPT_CYCLES}]: "
                                  "a lower bound of the MFPT"),
    **{key: D.Variable(("level",), np.float64, "1", f"failures per cycle at risk in the {half} "
                       "half of the max_cycles window")
       for key, half in (("hazard_early", "first"), ("hazard_late", "second"))},
    "advance_per_cycle": D.Variable(("level",), np.float64, "m", "mean horizontal advance of "
                                    "the attached end per completed cycle"),
    "failure_count": D.Variable(("level", "failure_mode"), np.int64, "1",
                                "runs that stopped this way"),
}


#: what a run's height drift is measured from: the start's height, or with a gait's rise
#: the route's staircase
PLANNED_HEIGHT = "its height at the start"
PLANNED_STAIRCASE = ("its planned height there (its height at the start plus the gait's "
                     "rise, attribute, per completed cycle)")


def write_survival(path: Path, attrs: dict, step: SurvivalStep, arrays: dict,
                   rise: float = 0.0, catches: int = 0) -> None:
    """Write a survival dataset (dims ``level``, ``run``, ``cycle``, ``failure_mode``);
    ``rise`` [m per cycle]: the gait's (its runs' heights measured from its staircase);
    ``catches`` the gait's bar catches per cycle (brachiations: the MFPT is written in them
    too, and the attribute ``catches_per_cycle``; 0: a gait without bar catches)."""
    n_levels, runs = arrays["cycles"].shape
    grid = cycle_grid(step.max_cycles)
    summaries = [level_summary(arrays["cycles"][i], arrays["failure"][i],
                               arrays["distance"][i], step.max_cycles)
                 for i in range(n_levels)]
    # the spread a noise value states (a per-run latency is always uniform on [0, value))
    spread = (" (standard deviation)" if step.noise.distribution == "gaussian"
              else " (half-width of a uniform)")
    with D.atomic_netcdf(path) as nc:

        planned = PLANNED_STAIRCASE if rise != 0.0 else PLANNED_HEIGHT

        def write(name, data):
            D.write_declared(nc, VARIABLES, name, data, spread=spread, planned=planned)

        D.write_coordinate(nc, VARIABLES, "level", np.arange(n_levels))
        D.write_coordinate(nc, VARIABLES, "run", np.arange(runs))
        D.write_coordinate(nc, VARIABLES, "cycle", grid)
        D.write_coordinate(nc, VARIABLES, "failure_mode", list(FAILURE_NAMES))
        for s in SOURCES:
            values = [getattr(step.noise.level(k), s.name) for k in range(n_levels)]
            if not s.when_set or any(v > 0.0 for v in values):
                write(f"noise_{s.name}", values)
        write("cycles_completed", arrays["cycles"])
        write("failure", arrays["failure"])
        write("distance", arrays["distance"])
        write("time_survived", arrays["time"])
        write("height_drift", arrays["height"])
        if step.height_tolerance is not None:
            write("height_within_tolerance",
                  [height_within(arrays["height"][i], arrays["failure"][i],
                                 step.height_tolerance) for i in range(n_levels)])
        write("final_error", arrays["error"])
        write("survival", np.array([survival_curve(arrays["cycles"][i], step.max_cycles, grid)
                                    for i in range(n_levels)]))
        ms = [s["mfpt"] for s in summaries]
        for key, attr in (("mfpt", "value"), ("mfpt_low", "low"), ("mfpt_high", "high")):
            write(key, [getattr(m, attr) for m in ms])
            write(key.replace("mfpt", "mfpt_distance"),
                  [getattr(m, attr) * s["advance"] for m, s in zip(ms, summaries)])
            if catches:
                write(f"{key}_brachiations", [getattr(m, attr) * catches for m in ms])
        write("mfpt_method", [MFPT_METHODS.index(m.method) for m in ms])
        write("restricted_mean", [m.restricted_mean for m in ms])
        for key in ("hazard_early", "hazard_late"):
            write(key, [getattr(m, key) for m in ms])
        write("advance_per_cycle", [s["advance"] for s in summaries])
        write("failure_count", np.array([s["counts"] for s in summaries]))
        extra = {"catches_per_cycle": catches} if catches else {}
        D.set_global_attrs(nc, dict(attrs, total_cycles=int(arrays["cycles"].sum()),
                                    total_nfev=int(arrays["nfev"].sum()), **extra))


# --- the kind ------------------------------------------------------------------------------------
class SurvivalKind(StepKind):
    name = "survival"
    model = SurvivalStep
    variables = VARIABLES
    gait_kinds = ("horizontal", "sequence")
    accepts = ("shoot", "refine", "floquet", "design")
    unit = "runs"
    block_units = True
    figures = (
        Figure("survival"),
        Figure("mfpt"),
        Figure("failure_modes"),
        Figure("height_drift"),
        Figure("mfpt_comparison", across=True),
    )

    def check_step(self, study, index, step: SurvivalStep, ref, seen) -> list:
        out = run_problems(study, index, step, ref, replays=False)
        if ref is None:
            return out
        conv = study.gait.conventions
        if ref.kind == "design":
            if step.replay == "gait":
                out.append((("steps", index, "replay"), "a design's gait is open loop: replay "
                            "open_loop"))
            if step.controller.clock != "reset_at_vertical":
                out.append((("steps", index, "controller", "clock"), "a design's clock "
                            "restarts at each vertical crossing (reset_at_vertical)"))
            if ref.clock != "reset_at_vertical":
                out.append((("steps", index, "from"), f"design step {ref.name!r} runs its "
                            "clock on (clock: run_on): survival runs designs whose clock "
                            "restarts at the vertical only"))
            return out
        replay = step.replay or conv.replay
        if replay == "gait" and "gait" not in conv.replays and not (
                ref.kind == "floquet" and "search" in ref.controllers):
            # the gait's own controller runs from a fixed point of it
            out.append((("steps", index, "replay"), "replay: gait runs the state-based "
                        "search controller from its fixed point: from: a floquet step "
                        "with the search controller"))
        elif (replay == "open_loop" and ref.kind == "floquet"
              and "open_loop" in conv.floquet_controllers
              and "open_loop" not in ref.controllers_for(study.gait)):
            out.append((("steps", index, "from"), f"floquet step {ref.name!r} has no "
                        "open_loop fixed point to replay"))
        if replay == "gait" and step.controller.clock != "reset_at_vertical":
            out.append((("steps", index, "controller", "clock"), "the gait's own controller "
                        "has no clock to run on (replay: gait)"))
        return out

    def blocks(self, step: SurvivalStep) -> list[Block]:
        """Blocks of consecutive runs of one level (flat index ``level * runs + run``)."""
        size = step.runs_per_block
        out = []
        for level in range(step.n_levels):
            for r0 in range(0, step.runs, size):
                lo = level * step.runs + r0
                out.append(Block(len(out), lo, lo + min(size, step.runs - r0)))
        return out

    def block_summary(self, step: SurvivalStep) -> str:
        return (f"{step.n_levels} noise level(s) x {step.runs} runs of up to "
                f"{step.max_cycles} cycles")

    def n_tasks(self, step: SurvivalStep, gait) -> int:
        return len(self.blocks(step))

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        gait = ctx.handed_on(solution=st.solution, start_index=st.start_index,
                             replay=st.replay, clock=st.controller.clock,
                             max_map_defect=MAX_MAP_DEFECT, require="run")
        tick = st.controller.tick if st.controller.tick is not None else ctx.study.gait.tick
        kw = {"max_cycles": st.max_cycles,
              "error_bound": st.error_bound if st.error_bound is not None else math.inf,
              "min_advance": st.min_advance if st.min_advance is not None else -math.inf,
              "max_drop": max_drop_of(st, ctx.spec), "tick": float(tick), "seed": st.seed}
        ctx.state.update(gait=gait, options=dict(kw, clock=st.controller.clock))
        tasks = []
        for b in ctx.todo_blocks():
            level, r0 = divmod(b.lo, st.runs)
            runs = np.arange(r0, r0 + b.size, dtype=np.int64)
            tasks.append(Task(b, survival_block, (ctx.spec, gait, runs),
                              dict(kw, noise=st.noise.level(level).to_dict())))
        return tasks

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        st = ctx.step
        n = st.n_levels * st.runs
        arrays = {"cycles": np.empty(n, np.int64), "failure": np.empty(n, np.int8),
                  "distance": np.empty(n), "time": np.empty(n), "error": np.empty(n),
                  "nfev": np.empty(n, np.int64), "height": np.empty(n)}
        for b in ctx.blocks:
            got = ctx.block_arrays(b)
            for k in arrays:
                arrays[k][b.lo:b.hi] = got[k]
        arrays = {k: v.reshape(st.n_levels, st.runs) for k, v in arrays.items()}
        gait, kw = ctx.state["gait"], ctx.state["options"]
        z = gait.z
        run = ({"t_segment": gait.schedule(ctx.spec.integrator)}
               if gait.replay == "open_loop" else {})
        attrs.update(gait.attrs("survival", **run), replay=gait.replay,
                     start_theta2=z[-3], dtheta1=z[-2], dtheta2=z[-1],
                     tick=kw["tick"], clock=kw["clock"], seed=st.seed, runs=st.runs,
                     max_cycles=st.max_cycles, error_bound=kw["error_bound"],
                     min_advance=kw["min_advance"],
                     max_drop=kw["max_drop"], noise_distribution=st.noise.distribution,
                     swept=st.noise.swept(), n_blocks=len(ctx.blocks))
        if st.height_tolerance is not None:
            attrs["height_tolerance"] = st.height_tolerance
        if gait.robot is not ctx.spec.robot:
            # the runs used their source's robot (a design's): the dataset names it
            attrs["robot"] = robot_attr(ctx.spec.robot, gait.robot, st.from_)
        controller, _, _ = survival_controller(gait, tick=kw["tick"],
                                               integrator=ctx.spec.integrator)
        catches = catches_per_cycle(controller.program()[0])
        write_survival(ctx.path, attrs, st, arrays, rise=gait.gait.rise, catches=catches)
        parts = []
        for i in range(st.n_levels):
            s = level_summary(arrays["cycles"][i], arrays["failure"][i],
                              arrays["distance"][i], st.max_cycles)
            parts.append(mfpt_text(s["mfpt"], catches))
        return f"{st.runs} runs x {st.n_levels} level(s); MFPT " + "; ".join(parts)

    def describe(self, ds) -> list[str]:
        a = ds.attrs
        swept = a.get("swept", "[]")
        lines = [f"{a.get('replay')} replay from ({float(a['start_theta2']):.6g}, "
                 f"{float(a['dtheta1']):.8g}, {float(a['dtheta2']):.8g}); tick "
                 f"{a.get('tick')} s; {a.get('runs')} runs of up to {a.get('max_cycles')} "
                 f"cycles, seed {a.get('seed')}; swept: {swept}"]
        modes = [str(x) for x in ds["failure_mode"].values]
        for i in range(ds.sizes["level"]):
            noise = ", ".join(f"{v[6:]} {float(ds[v][i]):.3g}"
                              + ("" if ds[v].attrs["units"] == "1" else f" {ds[v].attrs['units']}")
                              for v in ds.data_vars if v.startswith("noise_")
                              and float(ds[v][i]) > 0) or "no noise"
            m = MFPT(float(ds["mfpt"][i]), float(ds["mfpt_low"][i]), float(ds["mfpt_high"][i]),
                     MFPT_METHODS[int(ds["mfpt_method"][i])], float(ds["restricted_mean"][i]),
                     0, 0, math.nan, math.nan)
            counts = ds["failure_count"].values[i]
            ended = ", ".join(f"{modes[k]} {int(c)}" for k, c in enumerate(counts) if c)
            distance = float(ds["mfpt_distance"][i])
            walked = (f", {distance:.4g} m walked on average before a failure"
                      if math.isfinite(distance) else "")
            catches = int(a.get("catches_per_cycle", 0))
            lines.append(f"level {i} ({noise}): MFPT {mfpt_text(m, catches)}{walked}; "
                         f"runs: {ended}")
            if "height_drift" in ds:
                lines.append("  " + height_text(ds, i))
        return lines


def height_text(ds, level: int) -> str:
    """The height change of one level's completed runs, as ``inspect`` prints it."""
    done = np.asarray(ds["failure"].values[level]) == Status.OK
    drift = np.asarray(ds["height_drift"].values[level], float)[done]
    if drift.size == 0:
        return "height: no run completed max_cycles"
    lo, med, hi = np.quantile(drift, [0.025, 0.5, 0.975])
    out = (f"height after {ds.attrs.get('max_cycles')} cycles ({drift.size} completed runs): "
           f"median {med * 1e3:+.3g} mm, 95 % of runs in [{lo * 1e3:+.3g}, {hi * 1e3:+.3g}] "
           f"mm, largest |change| {np.abs(drift).max() * 1e3:.3g} mm")
    if "height_within_tolerance" in ds:
        tol = float(ds.attrs["height_tolerance"])
        out += (f"; within +-{tol * 1e3:g} mm: "
                f"{100 * float(ds['height_within_tolerance'][level]):.4g} %")
    return out


def mfpt_text(m: MFPT, catches: int = 0) -> str:
    """An MFPT with its interval, in cycles (and in brachiations for a gait that catches
    ``catches`` bars per cycle), as logs and ``inspect`` print it."""
    if m.method == "none":
        return "none (no run)"
    if m.method == "lower_bound":
        out = f"> {m.low:.4g} cycles (no failure late in the window)"
        return out + (f", > {m.low * catches:.4g} brachiations" if catches else "")
    out = f"{m.value:.4g} cycles [{m.low:.4g}, {m.high:.4g}]"
    return out + (f", {m.value * catches:.4g} brachiations [{m.low * catches:.4g}, "
                  f"{m.high * catches:.4g}]" if catches else "")
