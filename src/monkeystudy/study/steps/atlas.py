"""The ``atlas`` step: the gaits a route may walk, each measured as the planner needs it.

Each gait of the step (a sequence gait with its catch at a planned world height, written in
the step with the section state it starts from) is measured on its own task: its fixed point
polished by Newton, its full return map's spectral radius (the height included, by finite
differences at two step sizes), one noiseless step (advance, rise, duration, the motor's
work) and survival runs under the step's noise (:mod:`monkeystudy.analysis.survival`), whose
failures per step are the gait's failure probability with its Clopper-Pearson bound
(:func:`~monkeystudy.analysis.route.step_failure`). A *switch step* (``switch: {from, to}``)
is a step designed to take the robot from one gait's cycle into another's
(:func:`~monkeystudy.analysis.walk.design_switch`): it has no fixed point of its own, and its
failure probability is measured by runs of the first gait, the switch step, then the second
gait (:func:`~monkeystudy.analysis.walk.switch_runs`). Every ordered pair of gaits is measured
the same way as a direct switch (no step between). The dataset hands the atlas on to a
``route`` step.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal, Optional

import numpy as np
from pydantic import Field, model_validator

from ...analysis.multipliers import jacobian_fd, solve_fixed_point
from ...analysis.route import AtlasGait, Transition, step_failure
from ...analysis.sections import cycle_full_map, cycle_return_map, cycle_section_state
from ...analysis.survival import Noise, mfpt, survival_curve, survival_runs
from ...analysis.walk import WalkGait, Walker, switch_runs
from .. import datasets as D
from ..blocks import Block, Task
from ..models import Name, SequenceGaitSpec, StrictModel
from ..noise import NoiseSpec
from ..spec import GaitSpec
from .base import Figure, StepContext, StepKind


class SwitchOf(StrictModel):
    """The gaits a switch step goes between."""

    from_: Name = Field(alias="from", description="the gait it leaves (a gait of the atlas)")
    to: Name = Field(description="the gait it enters (a gait of the atlas)")


class AtlasGaitSpec(StrictModel):
    """One gait of the atlas."""

    name: Name = Field(description="its name: the route's steps name it")
    gait: SequenceGaitSpec = Field(description="the gait: a sequence gait whose catch is a "
                                   "free_end_y guard (a planned world height) and whose "
                                   "step swaps the magnets")
    start: list[float] = Field(min_length=3, max_length=3, description="its section state "
                               "near its fixed point (theta2 [rad], dtheta1, dtheta2 "
                               "[rad s-1]), polished by Newton; a switch step's is ignored "
                               "(it starts from the gait it leaves)")
    switch: Optional[SwitchOf] = Field(None, description="a switch step: it runs once, "
                                       "between these two gaits")


class SwitchRunsSpec(StrictModel):
    """How switches between gaits are measured."""

    runs: int = Field(200, ge=1, le=1_000_000, description="runs per switch")
    steps_before: int = Field(2, ge=1, le=100, description="steps of the gait left before "
                              "the switch")
    steps_after: int = Field(3, ge=1, le=100, description="steps of the gait entered after "
                             "it (they count as the switch's)")


class AtlasStep(StrictModel):
    """Gaits measured for a route: each one's step (advance, rise, duration, motor work), its
    full-map spectral radius and its failure probability per step under noise, and the
    switches between them."""

    name: Name
    kind: Literal["atlas"]
    gaits: list[AtlasGaitSpec] = Field(min_length=1, max_length=64)
    tick: float = Field(0.001, ge=0, le=1.0, description="controller tick [s]")
    noise: NoiseSpec = Field(default_factory=NoiseSpec)
    runs: int = Field(200, ge=1, le=1_000_000, description="survival runs per gait")
    max_cycles: int = Field(200, ge=2, le=100_000_000, description="steps after which a "
                            "survival run stops as a survivor")
    seed: int = Field(0, ge=0, le=2**63 - 1, description="the noise's seed")
    min_advance: float = Field(0.5, ge=0, le=1.0, description="a step that advances less "
                               "than this fraction of its gait's step, the way the gait "
                               "travels, fails (stalled) [1]")
    height_tolerance: float = Field(0.05, gt=0, description="a switch run's catch this far "
                                    "from its planned height fails it [m]")
    switches: SwitchRunsSpec = Field(default_factory=SwitchRunsSpec)
    fd_step: float = Field(1e-5, gt=0, le=1e-2, description="finite-difference step of the "
                           "full map's Jacobian (also at a tenth of it, for the agreement)")

    @model_validator(mode="after")
    def _names(self) -> "AtlasStep":
        names = [g.name for g in self.gaits]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"two gaits are named {dup[0]!r}")
        for g in self.gaits:
            if g.switch is not None:
                for end in (g.switch.from_, g.switch.to):
                    if end not in names or end == g.name:
                        raise ValueError(f"gait {g.name!r}: switch names {end!r}, not "
                                         f"another gait of the atlas")
                    if next(h for h in self.gaits if h.name == end).switch is not None:
                        raise ValueError(f"gait {g.name!r}: a switch goes between gaits, "
                                         f"not to or from switch step {end!r}")
            if not any(s.until == "free_end_y" for s in g.gait.segments):
                raise ValueError(f"gait {g.name!r}: its catch must be a free_end_y guard "
                                 "(a planned world height)")
            if not any(s.magnets == "swap" for s in g.gait.segments):
                raise ValueError(f"gait {g.name!r}: its step must swap the magnets")
        if self.noise.n_levels != 1:
            raise ValueError("an atlas has one noise level (give single values)")
        return self


def integrator_words(ds) -> str:
    """A dataset's integrator (attr ``integrator``, JSON) in words: ``DOP853, rtol 1e-12,
    atol 1e-13``."""
    integ = json.loads(ds.attrs.get("integrator", "{}") or "{}")
    if not integ:
        return "as its dataset records"
    return (f"{str(integ.get('method', '')).upper()}, rtol {float(integ['rtol']):g}, "
            f"atol {float(integ['atol']):g}")


def catch_height(spec: SequenceGaitSpec) -> float:
    """The planned height of a gait's catch above its start [m]: its free_end_y guard's."""
    return float(next(s.value for s in spec.segments if s.until == "free_end_y"))


def mfpt_words(g: dict) -> str:
    """A gait's MFPT in words from its dataset row (``gait_*`` values): the estimate and its
    95 % interval [steps], or the lower bound when censored."""
    if g["gait_mfpt_censored"]:
        return f"; MFPT >= {float(g['gait_mfpt']):.4g} steps (no failure late in the runs)"
    return (f"; MFPT {float(g['gait_mfpt']):.4g} steps ({float(g['gait_mfpt_low']):.4g} to "
            f"{float(g['gait_mfpt_high']):.4g})")


# --- tasks (run on the workers) ------------------------------------------------------------------
def walk_gait(entry: dict, z) -> WalkGait:
    """The :class:`~monkeystudy.analysis.walk.WalkGait` of an atlas entry (its ``gait``
    block as plain data) from section state ``z``."""
    return WalkGait(entry["name"], SequenceGaitSpec(**entry["gait"]).gait(), tuple(z))


def measure_gait(spec: GaitSpec, entry: dict, *, tick: float, noise: dict, runs: int,
                 max_cycles: int, seed: int, min_advance: float,
                 fd_step: float) -> dict[str, np.ndarray]:
    """One repeating gait of the atlas: its fixed point (Newton), its full map's spectral
    radius (finite differences at ``fd_step`` and a tenth of it), one noiseless step from
    its fixed point (advance, rise [m], duration [s], motor work [J]) and ``runs`` survival
    runs under ``noise`` on the controller ``tick`` [s]."""
    gspec = SequenceGaitSpec(**entry["gait"])
    gait = gspec.gait()
    robot, integ = spec.robot, spec.integrator
    fixed = fixed_point(spec, entry)
    z = np.asarray(fixed.z, float)

    def full(v):
        return cycle_full_map(v, gait, robot=robot, integrator=integ)

    w = np.concatenate([[0.0], z])
    rho = [float(np.max(np.abs(np.linalg.eigvals(jacobian_fd(full, w, h)))))
           for h in (fd_step, fd_step / 10)]
    walk = WalkGait(entry["name"], gait, tuple(z))
    one = Walker(walk, (0.0, 0.0), "A", robot=robot, integrator=integ).step(
        walk, catch_height(gspec))
    dx = float(one.position[0])
    seq = replace(gait, tick=float(tick))
    r = survival_runs(seq.loop_controller(), cycle_section_state(seq, z), z,
                      runs=np.arange(runs), max_cycles=max_cycles, noise=Noise(**noise),
                      seed=seed, robot=robot, integrator=integ,
                      min_advance=min_advance * abs(dx), travel=math.copysign(1.0, dx),
                      section=seq.section_observers())
    return {"z": z, "map_defect": np.array([fixed.defect]), "rho": np.array(rho),
            "step": np.array([dx, one.position[1], one.duration, one.energy,
                              float(one.status)]),
            "cycles": r.cycles.astype(np.int64), "failure": r.failure.astype(np.int8)}


def fixed_point(spec: GaitSpec, entry: dict):
    """A repeating gait's fixed point on its section, by Newton from its ``start``
    (:func:`~monkeystudy.analysis.multipliers.solve_fixed_point`'s result)."""
    gait = SequenceGaitSpec(**entry["gait"]).gait()
    return solve_fixed_point(
        lambda z: cycle_return_map(z, gait, robot=spec.robot, integrator=spec.integrator),
        np.asarray(entry["start"], float))


def measure_switch(spec: GaitSpec, before: dict, after: dict, via: dict | None, *,
                   steps_before: int, steps_after: int, tick: float, noise: dict, runs: int,
                   seed: int, min_advance: float,
                   height_tolerance: float) -> dict[str, np.ndarray]:
    """Runs of ``steps_before`` steps of gait ``before``, the switch step ``via`` (None: a
    direct switch) and ``steps_after`` steps of ``after`` (atlas entries as plain data)
    under ``noise``: which step of each run failed (-1: none)."""
    z0 = np.asarray(fixed_point(spec, before).z, float)
    first = walk_gait(before, z0)
    last = walk_gait(after, np.asarray(fixed_point(spec, after).z, float))

    def planned(gait: WalkGait, entry: dict, start: WalkGait):
        """``(gait, rise [m], advance [m], its noiseless step)`` of one step from ``start``'s
        fixed point (the way it travels: the sign of the advance)."""
        rise = catch_height(SequenceGaitSpec(**entry["gait"]))
        one = Walker(start, (0.0, 0.0), "A", robot=spec.robot,
                     integrator=spec.integrator).step(gait, rise)
        return gait, rise, float(one.position[0]), one

    switch = planned(walk_gait(via, z0), via, first) if via is not None else None
    plan = [planned(first, before, first)] * steps_before + ([switch] if switch else []) + \
        [planned(last, after, last)] * steps_after
    r = switch_runs([p[:3] for p in plan], np.arange(runs), min_advance=min_advance,
                    height_tolerance=height_tolerance, robot=spec.robot,
                    integrator=spec.integrator, tick=tick, noise=Noise(**noise), seed=seed)
    out = {"failed_step": r.failed_step}
    if switch is not None:      # the switch step's own noiseless step from the gait it leaves
        _, rise, dx, one = switch
        out.update(z=z0, step=np.array([dx, rise, one.duration, one.energy]))
    return out


# --- the dataset ---------------------------------------------------------------------------------
GAIT_DIM, SWITCH_DIM = ("gait",), ("switch",)

#: the variables of an atlas dataset (docs/datasets.md)
VARIABLES = {
    "gait": D.label_coordinate("gait", "the gait's name"),
    "gait_dx": D.Variable(GAIT_DIM, np.float64, "m", "the attached magnet's advance along the "
                          "wall over one noiseless step (signed: world x)"),
    "gait_dy": D.Variable(GAIT_DIM, np.float64, "m", "its rise over the step: the catch's "
                          "planned height above the attached magnet's"),
    "gait_duration": D.Variable(GAIT_DIM, np.float64, "s", "the step's duration, section to "
                                "section"),
    "gait_energy": D.Variable(GAIT_DIM, np.float64, "J", "the motor's net work over the step"),
    "gait_repeats": D.Variable(GAIT_DIM, np.int8, "1", "1: a gait that repeats (from its "
                               "fixed point); 0: a switch step, run once between two gaits"),
    "gait_switch_from": D.Variable(GAIT_DIM, str, "1", "the gait a switch step leaves (empty "
                                   "for a gait)"),
    "gait_switch_to": D.Variable(GAIT_DIM, str, "1", "the gait a switch step enters (empty "
                                 "for a gait)"),
    "gait_theta2": D.Variable(GAIT_DIM, np.float64, "rad", "theta2 of the fixed point on the "
                              "section (a switch step: of the gait it leaves)"),
    "gait_dtheta1": D.Variable(GAIT_DIM, np.float64, D.RATE, "dtheta1 of that state"),
    "gait_dtheta2": D.Variable(GAIT_DIM, np.float64, D.RATE, "dtheta2 of that state"),
    "gait_map_defect": D.Variable(GAIT_DIM, np.float64, "1", "|P(z) - z| at the fixed point "
                                  "(NaN for a switch step)"),
    "gait_spectral_radius": D.Variable(GAIT_DIM, np.float64, "1", "the full return map's "
                                       "spectral radius, the height included (finite "
                                       "differences at fd_step; NaN for a switch step)"),
    "gait_spectral_radius_agreement": D.Variable(
        GAIT_DIM, np.float64, "1", "its difference from the one at a tenth of fd_step"),
    "gait_p_fail": D.Variable(GAIT_DIM, np.float64, "1", "failure probability per step: "
                              "failures per step attempted (a switch step: per switch, its "
                              "following steps of the gait it enters included)"),
    "gait_p_fail_upper": D.Variable(GAIT_DIM, np.float64, "1", "its one-sided 97.5 % "
                                    "Clopper-Pearson upper bound"),
    "gait_mfpt": D.Variable(GAIT_DIM, np.float64, "1", "mean first-passage time to failure "
                            "[steps] (a lower bound when gait_mfpt_censored; NaN for a switch "
                            "step)"),
    "gait_mfpt_low": D.Variable(GAIT_DIM, np.float64, "1", "its 95 % interval's low end "
                                "[steps]"),
    "gait_mfpt_high": D.Variable(GAIT_DIM, np.float64, "1", "its 95 % interval's high end "
                                 "[steps] (NaN when gait_mfpt_censored: unbounded)"),
    "gait_mfpt_censored": D.Variable(GAIT_DIM, np.int8, "1", "1: no failure late in the "
                                     "window, gait_mfpt is a lower bound"),
    "gait_survival_runs": D.Variable(GAIT_DIM, np.int32, "1", "runs measured (a switch "
                                     "step: runs that reached it)"),
    "gait_survival_failed": D.Variable(GAIT_DIM, np.int32, "1", "runs that failed"),
    "steps_completed": D.index_coordinate("steps_completed", "steps completed in a run, 0 to "
                                          "max_cycles"),
    "gait_survival": D.Variable(("gait", "steps_completed"), np.float64, "1",
                                "fraction of the gait's survival runs (from its fixed point) "
                                "that completed at least this many steps (NaN for a switch "
                                "step)"),
    "switch": D.index_coordinate("switch", "a direct switch between two gaits"),
    "switch_from": D.Variable(SWITCH_DIM, str, "1", "the gait left"),
    "switch_to": D.Variable(SWITCH_DIM, str, "1", "the gait entered, with no step between"),
    "switch_p_fail": D.Variable(SWITCH_DIM, np.float64, "1", "failure probability of the "
                                "switch: runs that failed in the entered gait's first steps "
                                "per run that reached it"),
    "switch_p_fail_upper": D.Variable(SWITCH_DIM, np.float64, "1", "its one-sided 97.5 % "
                                      "Clopper-Pearson upper bound"),
    "switch_runs": D.Variable(SWITCH_DIM, np.int32, "1", "runs that reached the switch"),
    "switch_failed": D.Variable(SWITCH_DIM, np.int32, "1", "of them, runs that failed after "
                                "it"),
}


def switch_failure(failed_step: np.ndarray, at: int) -> tuple[int, int, float, float]:
    """``(runs that reached step at, of them failed there or later, p, upper bound)``."""
    reached = (failed_step < 0) | (failed_step >= at)
    failed = reached & (failed_step >= at)
    n, k = int(reached.sum()), int(failed.sum())
    if n == 0:
        return 0, 0, math.nan, math.nan
    p, upper = step_failure(np.where(failed[reached], 0, 1), failed[reached], 1)
    return n, k, p, upper


@dataclass(frozen=True)
class Atlas:
    """What an atlas step hands on: the gaits as a walk runs them and as the planner sees
    them, the allowed switches, and the noise and tick they were measured under."""

    walk_gaits: tuple
    gaits: tuple
    transitions: tuple
    tick: float
    noise: Noise
    excluded: tuple


def write_atlas(path: Path, attrs: dict, rows: list[dict], switches: list[dict]) -> None:
    """Write an atlas dataset: one row per gait, one per direct switch."""
    with D.atomic_netcdf(path) as nc:
        D.write_coordinate(nc, VARIABLES, "gait", [r["gait"] for r in rows])
        D.write_coordinate(nc, VARIABLES, "steps_completed",
                           np.arange(len(rows[0]["gait_survival"])))
        for name in VARIABLES:
            if name.startswith("gait_"):
                D.write_declared(nc, VARIABLES, name, [r[name] for r in rows])
        D.write_coordinate(nc, VARIABLES, "switch", np.arange(len(switches)))
        for name in VARIABLES:
            if name.startswith("switch_"):
                D.write_declared(nc, VARIABLES, name, [r[name] for r in switches])
        D.set_global_attrs(nc, attrs)


# --- the kind ------------------------------------------------------------------------------------
class AtlasKind(StepKind):
    name = "atlas"
    model = AtlasStep
    variables = VARIABLES
    gait_kinds = ("horizontal", "sequence")
    runs_gait = False
    provides = "the atlas of gaits and switches a route plans with"
    unit = "blocks"
    # drawn when no route step plans with the atlas (a route step draws it as its own)
    figures = (Figure("gaits"),)

    def pairs(self, step: AtlasStep) -> list[tuple[int, int]]:
        """The direct switches measured: every ordered pair of repeating gaits."""
        rep = [k for k, g in enumerate(step.gaits) if g.switch is None]
        return [(a, b) for a in rep for b in rep if a != b]

    def blocks(self, step: AtlasStep) -> list[Block]:
        """One block per gait of the atlas, then one per direct switch."""
        n = len(step.gaits) + len(self.pairs(step))
        return [Block(k, k, k + 1) for k in range(n)]

    def block_summary(self, step: AtlasStep) -> str:
        return (f"{len(step.gaits)} gaits and {len(self.pairs(step))} direct switches, "
                f"{step.runs} runs of up to {step.max_cycles} steps per gait")

    def n_tasks(self, step: AtlasStep, gait) -> int:
        return len(self.blocks(step))

    def needs_runs(self, step) -> bool:
        return True

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        entries = [g.model_dump(mode="json", by_alias=True) for g in st.gaits]
        by_name = {e["name"]: e for e in entries}
        noise = st.noise.level(0).to_dict()
        common = {"tick": st.tick, "noise": noise, "seed": st.seed,
                  "min_advance": st.min_advance}
        switch_kw = dict(common, runs=st.switches.runs, steps_before=st.switches.steps_before,
                         steps_after=st.switches.steps_after,
                         height_tolerance=st.height_tolerance)
        pairs = self.pairs(st)
        tasks = []
        for b in ctx.todo_blocks():
            k = b.index
            if k < len(entries):
                e = entries[k]
                if e.get("switch") is None:
                    tasks.append(Task(b, measure_gait, (ctx.spec, e),
                                      dict(common, runs=st.runs, max_cycles=st.max_cycles,
                                           fd_step=st.fd_step)))
                else:
                    sw = e["switch"]
                    tasks.append(Task(b, measure_switch, (ctx.spec, by_name[sw["from"]],
                                                          by_name[sw["to"]], e), switch_kw))
            else:
                a, c = pairs[k - len(entries)]
                tasks.append(Task(b, measure_switch, (ctx.spec, entries[a], entries[c], None),
                                  switch_kw))
        return tasks

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        st = ctx.step
        before = st.switches.steps_before
        rows, described = [], []
        for k, g in enumerate(st.gaits):
            got = ctx.block_arrays(ctx.blocks[k])
            z = np.asarray(got["z"], float)
            row = {"gait": g.name, "gait_repeats": int(g.switch is None),
                   "gait_switch_from": "" if g.switch is None else g.switch.from_,
                   "gait_switch_to": "" if g.switch is None else g.switch.to,
                   "gait_theta2": z[0], "gait_dtheta1": z[1], "gait_dtheta2": z[2],
                   "gait_dy": catch_height(g.gait)}
            if g.switch is None:
                dx, _, duration, energy, _ = (float(v) for v in got["step"])
                failed = got["failure"] != 0
                p, upper = step_failure(got["cycles"], failed, st.max_cycles)
                m = mfpt(got["cycles"], failed, st.max_cycles)
                rho = got["rho"]
                row.update(gait_dx=dx, gait_duration=duration, gait_energy=energy,
                           gait_map_defect=float(got["map_defect"][0]),
                           gait_spectral_radius=float(rho[0]),
                           gait_spectral_radius_agreement=float(abs(rho[0] - rho[1])),
                           gait_p_fail=p, gait_p_fail_upper=upper, gait_mfpt=m.value
                           if m.method != "lower_bound" else m.low,
                           gait_mfpt_low=m.low,
                           gait_mfpt_high=m.high if m.method != "lower_bound" else math.nan,
                           gait_mfpt_censored=int(m.method == "lower_bound"),
                           gait_survival_runs=st.runs, gait_survival_failed=int(failed.sum()),
                           gait_survival=survival_curve(got["cycles"], st.max_cycles,
                                                        np.arange(st.max_cycles + 1)))
            else:
                n, kf, p, upper = switch_failure(got["failed_step"], before)
                dx, _, duration, energy = (float(v) for v in got["step"])
                row.update(gait_dx=dx, gait_duration=duration, gait_energy=energy,
                           gait_map_defect=math.nan,
                           gait_spectral_radius=math.nan,
                           gait_spectral_radius_agreement=math.nan, gait_p_fail=p,
                           gait_p_fail_upper=upper, gait_mfpt=math.nan,
                           gait_mfpt_low=math.nan, gait_mfpt_high=math.nan,
                           gait_mfpt_censored=0, gait_survival_runs=n,
                           gait_survival_failed=kf,
                           gait_survival=np.full(st.max_cycles + 1, np.nan))
            rows.append(row)
        switches = []
        for j, (a, c) in enumerate(self.pairs(st)):
            got = ctx.block_arrays(ctx.blocks[len(st.gaits) + j])
            n, kf, p, upper = switch_failure(got["failed_step"], before)
            switches.append({"switch_from": st.gaits[a].name, "switch_to": st.gaits[c].name,
                             "switch_p_fail": p, "switch_p_fail_upper": upper,
                             "switch_runs": n, "switch_failed": kf})
        entries = [dict(g.model_dump(mode="json", by_alias=True),
                        z=[rows[k]["gait_theta2"], rows[k]["gait_dtheta1"],
                           rows[k]["gait_dtheta2"]]) for k, g in enumerate(st.gaits)]
        attrs.update(atlas=entries, tick=st.tick, noise=st.noise.level(0).to_dict(),
                     seed=st.seed, runs=st.runs, max_cycles=st.max_cycles,
                     min_advance=st.min_advance, height_tolerance=st.height_tolerance,
                     switch_runs=st.switches.runs, steps_before=before,
                     steps_after=st.switches.steps_after, fd_step=st.fd_step,
                     n_blocks=len(ctx.blocks))
        write_atlas(ctx.path, attrs, rows, switches)
        held = sum(1 for s in switches if s["switch_failed"] == 0)
        return (f"{len(rows)} gaits, rho " + ", ".join(
            f"{r['gait']} {r['gait_spectral_radius']:.4g}" for r in rows
            if r["gait_repeats"]) + f"; {held} of {len(switches)} direct switches held in "
            f"every run")

    def hand_on(self, dep, ctx: StepContext, *, max_switch_p_fail: float = 0.05,
                mirror: bool = True, **_):
        """The :class:`Atlas` of the dataset: its gaits (with their mirror images), the
        direct switches whose failure probability is at most ``max_switch_p_fail`` and the
        switch steps' transitions."""
        import xarray as xr   # the driver reads datasets; the workers never load xarray
        with xr.open_dataset(dep.path) as ds:
            ds = ds.load()
        entries = json.loads(ds.attrs["atlas"])
        walk, gaits, moves, excluded = [], [], [], []
        for k, e in enumerate(entries):
            p, up = float(ds["gait_p_fail"][k]), float(ds["gait_p_fail_upper"][k])
            if not (p < 1.0 and up < 1.0):
                excluded.append(e["name"])
                continue
            walk.append(walk_gait(e, e["z"]))
            gaits.append(AtlasGait(e["name"], float(ds["gait_dx"][k]), float(ds["gait_dy"][k]),
                                   float(ds["gait_duration"][k]), max(
                                       0.0, float(ds["gait_energy"][k])), p, up,
                                   repeats=e.get("switch") is None,
                                   survival=() if e.get("switch") is not None else
                                   tuple(ds["gait_survival"].values[k])))
            if e.get("switch") is not None:
                moves += [Transition(e["switch"]["from"], e["name"], 0.0, 0.0),
                          Transition(e["name"], e["switch"]["to"], 0.0, 0.0)]
        names = {g.name for g in gaits}
        for j in range(ds.sizes["switch"]):
            a, c = str(ds["switch_from"][j].values), str(ds["switch_to"][j].values)
            p, up = float(ds["switch_p_fail"][j]), float(ds["switch_p_fail_upper"][j])
            if a in names and c in names and p <= max_switch_p_fail and up < 1.0:
                moves.append(Transition(a, c, p, up))
        moves = [t for t in moves if t.from_gait in names and t.to_gait in names]
        if mirror:
            walk += [w.mirrored() for w, g in zip(list(walk), list(gaits)) if g.dx != 0.0]
            mirrored = {g.name for g in gaits if g.dx != 0.0}
            gaits += [g.mirrored() for g in gaits if g.dx != 0.0]
            moves += [t.mirrored() for t in moves
                      if t.from_gait in mirrored and t.to_gait in mirrored]
        return Atlas(tuple(walk), tuple(gaits), tuple(moves), float(ds.attrs["tick"]),
                     Noise(**json.loads(ds.attrs["noise"])), tuple(excluded))

    def own_setup(self, ds) -> str:
        """The gaits it ran and how, from its dataset."""
        return (f"runs the gaits written in it ({', '.join(str(g) for g in ds['gait'].values)}) "
                f"on a {1e3 * float(ds.attrs['tick']):g} ms tick under its noise, with the "
                f"study's robot and integrator ({integrator_words(ds)})")

    def describe(self, ds) -> list[str]:
        lines = []
        for k, name in enumerate(ds["gait"].values):
            g = {v: ds[v].values[k] for v in ds.data_vars if v.startswith("gait_")}
            kind = "gait" if g["gait_repeats"] else (f"switch {g['gait_switch_from']} -> "
                                                    f"{g['gait_switch_to']}")
            lines.append(f"{name} ({kind}): step {float(g['gait_dx']):+.4g} m along, "
                         f"{float(g['gait_dy']):+.4g} m up, {float(g['gait_duration']):.4g} s, "
                         f"{float(g['gait_energy']):.4g} J; rho "
                         f"{float(g['gait_spectral_radius']):.6g}; p_fail "
                         f"{float(g['gait_p_fail']):.3g} (<= "
                         f"{float(g['gait_p_fail_upper']):.3g}), "
                         f"{int(g['gait_survival_failed'])} of {int(g['gait_survival_runs'])} "
                         f"runs failed" + (mfpt_words(g) if g["gait_repeats"] else ""))
        for j in range(ds.sizes["switch"]):
            lines.append(f"switch {ds['switch_from'].values[j]} -> {ds['switch_to'].values[j]}"
                         f": {int(ds['switch_failed'][j])} of {int(ds['switch_runs'][j])} "
                         f"runs failed (p {float(ds['switch_p_fail'][j]):.3g} <= "
                         f"{float(ds['switch_p_fail_upper'][j]):.3g})")
        return lines
