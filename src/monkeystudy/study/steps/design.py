"""The ``design`` step: search open-loop schedules and robot designs for the most stable gait.

From a horizontal gait (a shoot, refine or floquet step: its start and schedule), the step
evaluates a grid over up to four free design parameters (:data:`monkeystudy.analysis.design.
PARAMETERS`, with the bounds of what can be built). At each design the gait is re-solved as
a fixed point of the open-loop return map (clock restarted at each vertical crossing), with
one schedule value (``balance``) solved so that the gait stays horizontal, and its spectral
radius is measured by finite differences and by variational equations. The grid runs in
blocks on the pool, saved as shards (resumable); along the last axis each design starts its
Newton solve from its converged neighbour, so blocks hold whole lines of that axis and the
numbers do not depend on the workers.

For a sequence gait the free parameters are its segments' guard values and torques
(:class:`~monkeystudy.analysis.design.SegmentDesignSpace`): each design's gait is the fixed
point of the gait's own return map (no balance: it holds its height by a guard, or not), and
its stability that of the full map, the height included (``height_in_map``).

Then, in the main process: Nelder-Mead from the best grid designs (in coordinates scaled to
the axes' ranges, kept inside them), and for the best design found, the verification: the
spectral radius both ways, open-loop replays with exact timing and on the ``tick`` grid for
``cycles`` cycles or until it falls, the decay of a perturbation per cycle against the
multipliers, and a basin map.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Callable, ClassVar, Literal, Optional

import numpy as np
from pydantic import Field, field_validator, model_validator

from ...analysis.design import (
    BALANCES, CLOCKS, DESIGN_OK, OBJECTIVES, PARAMETERS, SEGMENT_PARAMETER, STATUS_NAMES,
    CycleShape, DesignResult, DesignSpace, SegmentDesignSpace, cycle_shape, design_basin,
    design_cycle_run, design_step_problem, design_survival, evaluate_design,
    motor_frame_pulses, objective_value, perturbation_decay, replay_design, with_variational,
)
from ...simulation import Status
from .. import datasets as D
from ..blocks import Block, Task
from ..errors import RunFailed
from ..models import Name, StrictModel
from ..noise import NoiseSpec
from ..counts import StepProgress, task_units
from .base import Dependency, Figure, StepContext, StepKind
from .gait_source import (
    MAX_MAP_DEFECT, GaitStart, design_start, option_problems, read_start,
)

#: designs per block at most (whole lines of the last axis; a design costs ~10 ms)
BLOCK_DESIGNS = 400


class DesignAxis(StrictModel):
    """``num`` evenly spaced values of a design parameter from ``start`` to ``stop``
    inclusive, in the parameter's units."""

    start: float
    stop: float
    num: int = Field(ge=1, le=10_000)

    @model_validator(mode="after")
    def _order(self) -> "DesignAxis":
        if self.start > self.stop or (self.num == 1 and self.start != self.stop):
            raise ValueError("an axis runs from start up to stop (num: 1 needs start == stop)")
        return self

    def values(self) -> np.ndarray:
        return np.linspace(self.start, self.stop, self.num)


class DesignRefine(StrictModel):
    """Nelder-Mead from the best grid designs."""

    starts: int = Field(3, ge=0, le=50, description="grid designs to refine from (the best, "
                        "no two neighbours on the grid); 0: none")
    max_evaluations: int = Field(300, ge=1, le=100_000, description="designs per start")
    xatol: float = Field(1e-4, gt=0, description="simplex size at convergence, as a "
                         "fraction of each axis's range")
    fatol: float = Field(1e-6, gt=0, description="objective spread at convergence")


class DesignScreen(StrictModel):
    """Survival runs of the most stable candidates (by the objective): the design checked and
    handed on is the one that lasts, not the one with the least spectral radius."""

    candidates: int = Field(6, ge=1, le=100, description="candidates screened: the refined "
                            "designs and the best grid designs (no two neighbours), the "
                            "lowest objective first")
    runs: int = Field(100, ge=1, le=100_000, description="runs per candidate")
    max_cycles: int = Field(300, ge=1, le=1_000_000, description="cycles after which a run "
                            "counts as survived")
    tick: float = Field(0.001, ge=0, le=0.1, description="controller tick of the runs [s]")
    seed: int = Field(0, ge=0, le=2**63 - 1, description="the noise's seed (the same draws "
                      "for every candidate)")
    min_advance_fraction: float = Field(0.5, gt=0, le=1, description="a cycle advancing less "
                                        "than this fraction of the design's step stalls the "
                                        "run")
    noise: NoiseSpec = Field(default_factory=NoiseSpec, description="the noise of every run "
                             "(one level)")

    @model_validator(mode="after")
    def _one_level(self) -> "DesignScreen":
        if self.noise.n_levels != 1:
            raise ValueError("a screen runs every candidate under one noise level (no lists)")
        return self


class DesignVerify(StrictModel):
    """The checks run on the best design."""

    cycles: int = Field(1000, ge=1, le=1_000_000, description="open-loop replay length")
    tick: float = Field(0.001, gt=0, le=0.1, description="controller tick of the second "
                        "replay [s] (the first has exact timing)")
    error_bound: float = Field(1e-2, gt=0, description="a replay's cycles_completed counts "
                               "the cycles before its section error against the fixed point "
                               "first exceeds this [rad2 + rad2 s-2]; the replay itself runs "
                               "on to its length or a fall")
    perturbation: float = Field(1e-3, gt=0, le=0.1, description="size of the start offset "
                                "whose decay is measured [rad, rad s-1]")
    decay_cycles: int = Field(60, ge=3, le=10_000, description="cycles of the decay run")
    basin_offset: float = Field(1e-2, gt=0, description="half-width of the basin map in "
                                "dtheta1 and dtheta2 [rad s-1]")
    basin_num: int = Field(11, ge=1, le=201, description="basin points per axis")
    basin_cycles: int = Field(60, ge=1, le=100_000, description="cycles per basin start")


class DesignStep(StrictModel):
    """Search schedules, robots or a sequence gait's segments for the gait with the smallest
    spectral radius.

    A grid over the free parameters, Nelder-Mead from its best designs, and checks of the best
    (docs/model.md section 9). For a sequence gait the free parameters are its segments'
    guard values and torques (``segment<k>_value``, ``segment<k>_torque``, k from 1), and the
    stability is that of the full map, the height included."""

    name: Name
    kind: Literal["design"]
    from_: Name = Field(alias="from")  # described by the kind (accepts)
    parameters: dict[str, DesignAxis] = Field(description="free design parameters, 1 to 4, "
                                              "each a grid axis (see docs/model.md for "
                                              "names, units and bounds; a sequence gait's: "
                                              "segment<k>_value, segment<k>_torque)")
    fixed: dict[str, float] = Field(default_factory=dict, description="values of other "
                                    "design parameters (default: the starting gait's "
                                    "schedule and the study's robot)")
    balance: Literal[BALANCES] = Field("t_switch", description="schedule value solved so the "
                                       "gait returns to its height each step (its grid or "
                                       "fixed value is Newton's start); none: free. The "
                                       "horizontal gait's only: a sequence gait holds its "
                                       "height by a guard, or not at all")
    objective: Literal[OBJECTIVES] = Field("spectral_radius", description="what Nelder-Mead "
                                           "minimises: the spectral radius per step, or plus "
                                           "energy_weight times the energy per metre")
    energy_weight: float = Field(0.0, ge=0, description="weight of the energy per metre "
                                 "[m J-1] in spectral_radius_energy")
    catch_speed_weight: float = Field(0.0, ge=0, description="a gait that catches bars: "
                                      "weight [s m-1] of the largest catch speed (the hook's "
                                      "speed just before a catch) added to the objective")
    min_offset_margin: float = Field(0.0, ge=0, description="a gait that catches bars: the "
                                     "least offset margin of a catch [m] (the bar's window "
                                     "less the hook's horizontal distance from the bar); a "
                                     "design below it is rejected (status out_of_bounds)")
    clock: Literal[CLOCKS] = Field("reset_at_vertical", description="the schedule's clock: "
                                   "restarted when link 1 passes the vertical (one sensed "
                                   "event per step), or run_on: running on with the gait's "
                                   "period, nothing sensed (the same gaits; their stability "
                                   "is the stroboscopic map's; mirror-image links only)")
    starts: list[list[float]] = Field(default_factory=list, description="more Newton starts "
                                      "for every design, each [theta2 (rad), dtheta1, "
                                      "dtheta2 (rad s-1)] with an optional 4th entry, the "
                                      "balance value; a design keeps its most stable gait")
    refine: DesignRefine = Field(default_factory=DesignRefine)
    verify: DesignVerify = Field(default_factory=DesignVerify)
    screen: Optional[DesignScreen] = Field(None, description="rank the best candidates by "
                                           "survival runs under noise and check the one that "
                                           "lasts (default: the least objective)")
    height_in_map: Optional[bool] = Field(None, description="a sequence gait's designs: the "
                                          "stability of the full map, the attached end's "
                                          "height included (four multipliers; default), or "
                                          "false: of the section map. The horizontal "
                                          "gait's schedules sense no height: not for them")
    solution: Optional[int] = Field(None, ge=0, description="which solution of a shoot step "
                                    "(default: the lowest error)")
    start_index: Optional[int] = Field(None, ge=0, description="which start of a refine step "
                                       "(default: the lowest error)")

    recorded_when_set: ClassVar[frozenset[str]] = frozenset(
        {"height_in_map", "screen", "catch_speed_weight", "min_offset_margin"})

    @field_validator("parameters")
    @classmethod
    def _parameters(cls, v):
        if not 1 <= len(v) <= 4:
            raise ValueError(f"give 1 to 4 free parameters, got {len(v)}")
        for name, axis in v.items():
            _check_parameter(name, (axis.start, axis.stop))
        return v

    @field_validator("starts")
    @classmethod
    def _starts(cls, v):
        for i, x in enumerate(v):
            if len(x) not in (3, 4) or not all(math.isfinite(y) for y in x):
                raise ValueError(f"start {i}: give 3 or 4 finite numbers, got {x!r}")
        return v

    @field_validator("fixed")
    @classmethod
    def _fixed(cls, v):
        for name, value in v.items():
            _check_parameter(name, (value,))
        return v

    @model_validator(mode="after")
    def _consistent(self) -> "DesignStep":
        both = set(self.parameters) & set(self.fixed)
        if both:
            raise ValueError(f"{sorted(both)} both free and fixed")
        if self.balance != "none" and self.balance in self.parameters:
            raise ValueError(f"balance {self.balance!r} is solved, not a free parameter")
        if self.clock == "run_on" and self.screen is not None:
            raise ValueError("screen runs designs whose clock restarts at each step (clock "
                             "reset_at_vertical)")
        if self.clock == "run_on" and self.two_step:
            raise ValueError("clock run_on needs mirror-image links (a one-step cycle): "
                             "mass_ratio and length_ratio can be neither free nor other "
                             "than 1")
        return self

    @property
    def replay(self) -> str:
        """How the starting gait is read: its open-loop replay (schedule and fixed point)."""
        return "open_loop"

    @property
    def names(self) -> list[str]:
        return list(self.parameters)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(a.num for a in self.parameters.values())

    @property
    def two_step(self) -> bool:
        return any(k in self.parameters or self.fixed.get(k, 1.0) != 1.0
                   for k in ("mass_ratio", "length_ratio"))

    @property
    def designs_per_block(self) -> int:
        line = self.shape[-1]
        return line * max(1, BLOCK_DESIGNS // line)


def _check_parameter(name: str, values) -> None:
    if SEGMENT_PARAMETER.fullmatch(name):
        return       # a sequence gait's segment: checked against the study's gait (check_step)
    if name not in PARAMETERS:
        raise ValueError(f"unknown design parameter {name!r}; known: {sorted(PARAMETERS)}")
    p = PARAMETERS[name]
    for v in values:
        if not (p.lower <= v <= p.upper):
            raise ValueError(f"{name}: {v!r} {p.unit} is outside what can be built "
                             f"[{p.lower}, {p.upper}]")


# --- the starting gait and the design space ------------------------------------------------------
def design_space(ctx: StepContext, gait: GaitStart) -> DesignSpace:
    """The step's :class:`~monkeystudy.analysis.design.DesignSpace`: the study's robot, the
    starting gait's schedule (swap at ``t_switch``, motor ``torque`` from the swap for
    ``t_motor``) under the step's ``fixed`` values."""
    st = ctx.step
    src = gait.source
    base = {"t_switch": src["t_switch"], "t_motor": src["t_motor"], "torque": src["torque"]}
    base.update(st.fixed)
    for name in st.parameters:
        base.pop(name, None)
    return DesignSpace(ctx.spec.robot, base=base, balance=st.balance, two_step=st.two_step,
                       integrator=ctx.spec.integrator, clock=st.clock)


def segment_space(gait, robot, step: DesignStep, torque_frame: str, integrator=None):
    """The :class:`~monkeystudy.analysis.design.SegmentDesignSpace` of a design step on a
    sequence gait (``gait``, torques in the kernel's frame; parameters' torques in the
    study's ``torque_frame``), the step's ``fixed`` values as its base."""
    kw = {} if integrator is None else {"integrator": integrator}
    return SegmentDesignSpace(gait, robot, base=dict(step.fixed),
                              motor_frame=torque_frame == "motor",
                              height_in_map=step.height_in_map is not False,
                              min_offset_margin=step.min_offset_margin, **kw)


def schedule_design(spec) -> bool:
    """Whether a study's designs are schedules of the horizontal gait (swap and motor times,
    :class:`~monkeystudy.analysis.design.DesignSpace`) or segment values of its sequence
    gait."""
    return bool(spec.swap_motor_times)


# --- tasks (run on the workers) ------------------------------------------------------------------
#: what a block returns per design (besides the multipliers)
FIELDS = ("status", "spectral_radius", "spectral_radius_fd", "theta2", "dtheta1", "dtheta2",
          "balance_value", "error", "rise", "advance", "energy_lost", "period", "iterations",
          "nfev", "catch_offset_margin", "catch_speed")


def record(res: DesignResult, space: DesignSpace) -> dict:
    """One design's numbers as the block arrays hold them."""
    return {"status": res.status, "spectral_radius": res.spectral_radius,
            "spectral_radius_fd": res.spectral_radius_fd, "theta2": res.z[0],
            "dtheta1": res.z[1], "dtheta2": res.z[2],
            "balance_value": (res.values[space.balance] if space.balance != "none"
                              else math.nan),
            "error": res.error, "rise": res.rise, "advance": res.advance,
            "energy_lost": res.energy_lost, "period": res.period,
            "iterations": res.iterations, "nfev": res.nfev,
            "catch_offset_margin": res.min_offset_margin, "catch_speed": res.max_catch_speed}


def design_block(space: DesignSpace, names: list[str], axes: list[np.ndarray], starts,
                 lo: int, hi: int) -> dict[str, np.ndarray]:
    """Designs ``lo..hi`` (flat C-order indices of the grid over ``axes``) with their gait,
    spectral radius both ways and multipliers.

    Each design's gait is solved by Newton from every start, and the converged gait with
    the smallest spectral radius is kept (one design may have several gaits): the previous
    converged design along the last axis (a continuation; none at a line's start), then each
    of ``starts``, pairs ``(z, balance value or None)`` (the step's gait first). Each design
    counts as it is done (:func:`~monkeystudy.study.counts.task_units`).
    """
    shape = tuple(len(a) for a in axes)
    n = hi - lo
    out = {k: np.full(n, np.nan) for k in FIELDS}
    out["status"] = np.zeros(n, np.int8)
    out["multiplier_modulus"] = np.full((n, space.n_multipliers), np.nan)
    prev = None
    for i, flat in enumerate(range(lo, hi)):
        idx = np.unravel_index(flat, shape)
        free = {name: float(axes[k][idx[k]]) for k, name in enumerate(names)}
        if idx[-1] == 0:
            prev = None
        res = solve_design(space, free, ([(prev.z, prev.values[space.balance] if
                                           space.balance != "none" else None)]
                                         if prev is not None else []) + list(starts))
        prev = res if res.ok else prev
        for k, v in record(res, space).items():
            out[k][i] = v
        out["multiplier_modulus"][i] = np.abs(res.multipliers_fd)
        task_units(1)
    return out


def solve_design(space: DesignSpace, free: dict, starts) -> DesignResult:
    """The design's gait with the smallest spectral radius from Newton at each start
    ``(z, balance value or None)``, with its variational multipliers; the last failure when
    none converges."""
    best, last = None, None
    for z, q in starts:
        values = free if q is None or space.balance == "none" else dict(
            free, **{space.balance: float(q)})
        res = evaluate_design(space, values, z)
        last = res
        if res.ok and (best is None or res.spectral_radius_fd < best.spectral_radius_fd):
            best = res
    return last if best is None else with_variational(space, best)


def step_objective(res: DesignResult, st: DesignStep) -> float:
    """The step's objective of a design (:meth:`~monkeystudy.analysis.design.DesignResult.
    objective` with the step's kind and weights)."""
    return res.objective(st.objective, st.energy_weight, st.catch_speed_weight)


def _with_balance(free: dict, values: dict, space: DesignSpace) -> dict:
    """``free`` with the balance's Newton start taken from a neighbour's solved ``values``."""
    if space.balance == "none":
        return free
    return dict(free, **{space.balance: values[space.balance]})


# --- refinement and verification (main process) --------------------------------------------------
def nelder_mead(space: DesignSpace, st: DesignStep, axes, start: dict,
                evaluated: Callable[[int], None] = lambda n: None) -> tuple:
    """Nelder-Mead on the objective from the design ``start`` (a grid design's values and
    gait), in coordinates scaled to the axes' ranges and clipped to them; returns ``(best
    DesignResult or None, evaluations)``. ``evaluated(1)`` after each evaluation."""
    from scipy.optimize import minimize   # scipy loads in ~0.2 s: only this step needs it

    names = st.names
    lo = np.array([a[0] for a in axes])
    span = np.array([max(a[-1] - a[0], 1e-12) for a in axes])
    x0 = (np.array([start["values"][n] for n in names]) - lo) / span
    state = {"z": np.asarray(start["z"], float), "balance": start["values"], "best": None,
             "n": 0}

    def f(x):
        state["n"] += 1
        evaluated(1)
        xc = np.clip(x, 0.0, 1.0)
        free = {n: float(lo[k] + span[k] * xc[k]) for k, n in enumerate(names)}
        res = evaluate_design(space, _with_balance(free, state["balance"], space), state["z"])
        value = step_objective(res, st)
        # leaving the box costs the distance outside: the simplex comes back in
        value += 10.0 * float(np.sum(np.abs(x - xc)))
        if res.ok:
            state["z"], state["balance"] = res.z, res.values
            if state["best"] is None or value < state["best"][0]:
                state["best"] = (value, res)
        return value if math.isfinite(value) else 1e3

    steps = np.array([1.0 / max(a.size - 1, 4) for a in axes])
    simplex = np.vstack([x0] + [x0 + np.eye(len(x0))[k] * steps[k] *
                                (1 if x0[k] + steps[k] <= 1 else -1) for k in range(len(x0))])
    minimize(f, x0, method="Nelder-Mead",
             options={"maxfev": st.refine.max_evaluations, "xatol": st.refine.xatol,
                      "fatol": st.refine.fatol, "initial_simplex": simplex})
    best = state["best"][1] if state["best"] else None
    return best, state["n"]


#: the checks :func:`verify` counts: two replays, the decay run, the basin
VERIFY_CHECKS = 4


def checks_seconds(v: DesignVerify, per_cycle: dict[float, float]) -> float:
    """How long the checks of the best design are expected to take [s]: the cycles they run
    at most (the two replays' ``cycles``, the decay run's, every basin start's, the film's
    one) at ``per_cycle``, the seconds a cycle of a refined design's replay took on the
    same tick (0: exact timing; {0: s, v.tick: s}): the checks replay such a design the same
    way, and a basin start that falls early only makes them shorter."""
    exact = per_cycle[0.0]
    ticked = per_cycle.get(v.tick, exact)
    return (v.cycles * (exact + ticked)
            + (v.decay_cycles + v.basin_num ** 2 * v.basin_cycles + 1) * exact)


def verify(space: DesignSpace, res: DesignResult, v: DesignVerify,
           checked: Callable[[int], None] = lambda n: None) -> dict:
    """The checks of one design: replays (exact and ticked), the decay of a perturbation, the
    basin; ``checked(1)`` after each of the :data:`VERIFY_CHECKS`."""
    exact = replay_design(space, res, cycles=v.cycles, tick=0.0, error_bound=v.error_bound)
    checked(1)
    ticked = replay_design(space, res, cycles=v.cycles, tick=v.tick,
                           error_bound=v.error_bound)
    checked(1)
    dist, growth = perturbation_decay(space, res, size=v.perturbation, cycles=v.decay_cycles)
    checked(1)
    offsets = np.linspace(-v.basin_offset, v.basin_offset, v.basin_num)
    basin = design_basin(space, res, offsets, offsets, max_cycles=v.basin_cycles,
                         error_bound=v.error_bound)
    checked(1)
    return {"replays": [exact, ticked], "decay": dist, "growth": growth, "offsets": offsets,
            "basin": basin}


def grid_design(space, st: DesignStep, axes, grid: dict, flat: int) -> DesignResult:
    """Grid design ``flat`` (C-order index) solved again from its stored gait and balance."""
    idx = np.unravel_index(flat, st.shape)
    free = {n: float(axes[k][idx[k]]) for k, n in enumerate(st.names)}
    return evaluate_design(space, _with_balance(
        free, {space.balance: grid["balance_value"][flat]}, space),
        [grid[c][flat] for c in ("theta2", "dtheta1", "dtheta2")])


def start_shape(gait: GaitStart, integrator) -> CycleShape:
    """What one cycle of the starting gait does (:func:`~monkeystudy.analysis.design.
    cycle_shape`), as it is run: the kind of gait every candidate must be."""
    program = gait.program(0.0, integrator)
    return cycle_shape(program, gait.z[-3:], robot=gait.robot, integrator=integrator)


def refusal(st: DesignStep, res: DesignResult, source: str, why: str) -> dict:
    """A candidate refused as no gait of the starting gait's kind: its free parameters,
    objective, where it came from (``grid`` or ``refined``) and why."""
    return {"source": source, "design": {n: float(res.values[n]) for n in st.names},
            "objective": float(step_objective(res, st)), "why": why}


def grid_picks(space, st: DesignStep, axes, grid: dict, k: int, reference: CycleShape,
               refused: list) -> list[tuple[int, DesignResult]]:
    """The ``k`` best grid designs (lowest objective first), each solved again from its
    stored gait, no two neighbours on the grid (Chebyshev distance 1), among the designs
    that are gaits of the starting gait's kind (``reference``). A design that is not is
    passed over (it takes no place and keeps no neighbour out) and added to ``refused``; one
    whose solve fails takes its place and yields no candidate."""
    objective = grid["objective"].reshape(st.shape)
    flat = objective.ravel()
    order = [i for i in np.argsort(flat, kind="stable") if np.isfinite(flat[i])]
    chosen: list[tuple[int, DesignResult]] = []
    for i in order:
        if len(chosen) == k:
            break
        ii = np.array(np.unravel_index(i, objective.shape))
        if any(np.max(np.abs(ii - np.array(np.unravel_index(j, objective.shape)))) <= 1
               for j, _ in chosen):
            continue
        res = grid_design(space, st, axes, grid, int(i))
        why = design_step_problem(space, res, reference) if res.ok else ""
        if why:
            refused.append(refusal(st, res, "grid", why))
            continue
        chosen.append((int(i), res))
    return chosen


def refine_and_verify(space: DesignSpace, st: DesignStep, axes, grid: dict, starts,
                      reference: CycleShape, progress: StepProgress | None = None) -> dict:
    """Nelder-Mead from the best grid designs, then the checks of the best design found
    (the best grid design when no refinement improves on it). Every candidate (a refined
    design, a grid design) must be a gait of the starting gait's kind (``reference``,
    :func:`~monkeystudy.analysis.design.step_problems`); the others are refused, listed in
    ``refused`` with the reason, and the best valid one is checked (``RunFailed`` when none
    is). ``progress`` shows each phase (refine, screen, checks) with its count."""
    progress = progress or StepProgress()
    shape = st.shape
    objective = grid["objective"].reshape(shape)
    n_grid = st.screen.candidates if st.screen else 1
    refused: list[dict] = []
    later = (["screen"] if st.screen else []) + ["checks"]
    picks = grid_picks(space, st, axes, grid, max(st.refine.starts, n_grid), reference,
                       refused)
    refined = []
    starting = [(flat, start) for flat, start in picks[:st.refine.starts] if start.ok]
    # each start: up to max_evaluations designs, then its two replays (one unit each)
    per_start = st.refine.max_evaluations + 2
    # the replays' time [s] and cycles by tick: the checks' estimate (checks_seconds)
    cycle_cost: dict[float, list] = {}
    advance = progress.phase("refine", per_start * len(starting), "designs",
                             then=", ".join(later))
    for flat, start in starting:
        idx = np.unravel_index(flat, shape)
        counted = [0]

        def evaluated(n: int) -> None:
            if counted[0] < st.refine.max_evaluations:
                counted[0] += n
                advance(n)
        best, n_eval = nelder_mead(space, st, axes, {"values": start.values, "z": start.z},
                                   evaluated)
        advance(st.refine.max_evaluations - counted[0])    # converged before its budget
        found = best or start
        why = design_step_problem(space, found, reference) if best is not None else ""
        if why:
            refused.append(refusal(st, found, "refined", why))
        # every refined design's replays too: the smallest rho is not always the one that
        # survives the controller tick
        reps = []
        for t in (0.0, st.verify.tick):
            began = progress.clock()
            reps.append(replay_design(space, found, cycles=st.verify.cycles, tick=t,
                                      error_bound=st.verify.error_bound))
            spent = cycle_cost.setdefault(t, [0.0, 0])
            spent[0] += progress.clock() - began
            spent[1] += max(reps[-1].error.size, 1)
            advance(1)
        progress.estimate("checks", checks_seconds(
            st.verify, {t: sec / n for t, (sec, n) in cycle_cost.items()}))
        refined.append({"start": flat, "start_objective": float(objective[idx]),
                        "result": found, "evaluations": n_eval,
                        "cycles_completed": [r.cycles_completed for r in reps],
                        "cycles_walked": [r.cycles_walked for r in reps], "refused": why})
    candidates = [r["result"] for r in refined if not r["refused"]]
    # the best grid designs (one without a screen: the grid's best)
    candidates += [g for _, g in picks[:n_grid] if g.ok]
    if not candidates:
        if refused:
            raise RunFailed(f"{st.name}: no candidate design is a gait of the starting "
                            f"gait's kind, nothing to hand on: " + "; ".join(
                                f"{refusal_text(r)}" for r in refused[:3]))
        raise RunFailed(f"{st.name}: no design of the grid has a gait (statuses: "
                        f"{_status_text(grid['status'])})")
    ranked = sorted(candidates, key=lambda r: step_objective(r, st))
    screened = []
    if st.screen:
        n = min(st.screen.candidates, len(ranked))
        screened = screen(space, st.screen, ranked,
                          progress.phase("screen", n * st.screen.runs, "runs", then="checks"))
    # the checks, then the variational multipliers and the film (one unit each)
    done = progress.phase("checks", VERIFY_CHECKS + 2, "checks")
    best = with_variational(space, screened[0]["result"] if screened else ranked[0])
    done(1)
    checks = verify(space, best, st.verify, done)
    film = design_cycle_run(space, best, sample_dt=0.005)
    done(1)
    return {"refined": refined, "best": best, "checks": checks, "film": film,
            "screened": screened, "refused": refused}


def refusal_text(r: dict) -> str:
    """A refused candidate in words: its parameters, objective and why."""
    design = ", ".join(f"{n} {v:.6g}" for n, v in r["design"].items())
    return f"{r['source']} design ({design}), objective {r['objective']:.4g}: {r['why']}"


def screen(space, sc: DesignScreen, ranked: list[DesignResult],
           ran: Callable[[int], None] | None = None) -> list[dict]:
    """Survival runs of the first ``sc.candidates`` of ``ranked`` (the lowest objective
    first), each under the screen's noise with the same draws; returned the most robust
    first: the most runs that completed ``max_cycles``, then the most cycles on average, then
    the lowest objective (the ranked order). ``ran(1)`` as each run ends."""
    noise = sc.noise.level(0)
    out = []
    for rank, res in enumerate(ranked[:sc.candidates]):
        runs = design_survival(space, res, runs=sc.runs, max_cycles=sc.max_cycles,
                               noise=noise, seed=sc.seed, tick=sc.tick,
                               min_advance_fraction=sc.min_advance_fraction, progress=ran)
        out.append({"result": res, "rank": rank,
                    "survived": float(np.mean(runs.failure == Status.OK)),
                    "mean_cycles": float(np.mean(runs.cycles))})
    return sorted(out, key=lambda c: (-c["survived"], -c["mean_cycles"], c["rank"]))


def _status_text(status: np.ndarray) -> str:
    vals, counts = np.unique(np.asarray(status, int), return_counts=True)
    return ", ".join(f"{STATUS_NAMES[v]} {c}" for v, c in zip(vals, counts))


# --- the dataset ---------------------------------------------------------------------------------
#: the declared dims of the variables named per free parameter (written as each parameter's
#: name: its coordinate, ``refined_<parameter>``) and of the grid variables (written over
#: every free parameter, in the step's order)
PARAMETER = "<parameter>"
PARAMETERS_DIMS = ("<parameters>",)

#: the grid variables, in the order the dataset holds them; ``{map}``: the return map or the
#: full map (the height included), ``{balance}``: the balance parameter
GRID_VARIABLES = {
    "status": D.Variable(PARAMETERS_DIMS, np.int8, "1", "how the design's gait solve ended",
                         {"flag_values": np.arange(len(STATUS_NAMES), dtype=np.int8),
                          "flag_meanings": " ".join(STATUS_NAMES)}),
    "spectral_radius": D.Variable(PARAMETERS_DIMS, np.float64, "1",
                                  "spectral radius of {map} per step, by variational "
                                  "equations with saltation matrices"),
    "spectral_radius_fd": D.Variable(PARAMETERS_DIMS, np.float64, "1",
                                     "spectral radius of {map} per step, by finite "
                                     "differences"),
    "theta2": D.Variable(PARAMETERS_DIMS, np.float64, "rad",
                         "fixed point: theta2 on the section"),
    "dtheta1": D.Variable(PARAMETERS_DIMS, np.float64, D.RATE,
                          "fixed point: dtheta1 on the section"),
    "dtheta2": D.Variable(PARAMETERS_DIMS, np.float64, D.RATE,
                          "fixed point: dtheta2 on the section"),
    "balance_value": D.Variable(PARAMETERS_DIMS, np.float64, "{balance_units}",
                                "solved value of the balance parameter ({balance})"),
    "error": D.Variable(PARAMETERS_DIMS, np.float64, D.ERROR_UNITS,
                        "squared section error |P(z) - z|^2 at the solution"),
    "rise": D.Variable(PARAMETERS_DIMS, np.float64, "m",
                       "height gained by the attached end per cycle"),
    "advance": D.Variable(PARAMETERS_DIMS, np.float64, "m",
                          "horizontal advance of the attached end per cycle"),
    "energy_lost": D.Variable(PARAMETERS_DIMS, np.float64, "J",
                              "energy lost at the cycle's impacts (restored by the motor)"),
    "period": D.Variable(PARAMETERS_DIMS, np.float64, "s", "duration of a cycle"),
    "iterations": D.Variable(PARAMETERS_DIMS, np.float64, "1", "Newton iterations"),
    "nfev": D.Variable(PARAMETERS_DIMS, np.float64, "1",
                       "right-hand-side evaluations of the solve"),
    "objective": D.Variable(PARAMETERS_DIMS, np.float64, "1", "the search's objective"),
    "energy_per_metre": D.Variable(PARAMETERS_DIMS, np.float64, "J m-1",
                                   "energy restored per metre travelled"),
}

#: what a design dataset holds (docs/datasets.md), in the order it holds it; the words that
#: depend on the run are format fields: ``{meaning}``, ``{units}``, ``{parameter}`` (a
#: free parameter's), ``{replay}`` (the open-loop replay, or the replay by the gait's own
#: controller), ``{basin_cycles}``, ``{torque}`` (the motor torque, or in the motor frame)
VARIABLES: dict[str, D.Variable] = {
    PARAMETER: D.Variable((PARAMETER,), np.float64, "{units}", "{meaning}"),
    "k": D.index_coordinate("k", "multiplier, by decreasing modulus"),
    **GRID_VARIABLES,
    "multiplier_modulus": D.Variable((*PARAMETERS_DIMS, "k"), np.float64, "1",
                                     "|multiplier| of the cycle's return map (finite "
                                     "differences)"),
    "start": D.index_coordinate("start", "Nelder-Mead start (a grid design)"),
    f"refined_{PARAMETER}": D.Variable(("start",), np.float64, "{units}",
                                       "refined design: {parameter}"),
    "refined_objective": D.Variable(("start",), np.float64, "1",
                                    "objective of the refined design"),
    "start_objective": D.Variable(("start",), np.float64, "1",
                                  "objective of the grid design it started from"),
    "refine_evaluations": D.Variable(("start",), np.int32, "1",
                                     "designs evaluated by Nelder-Mead"),
    "refined_spectral_radius_fd": D.Variable(("start",), np.float64, "1",
                                             "spectral radius per step of the refined design "
                                             "(finite differences)"),
    "replay_tick": D.Variable(("replay",), np.float64, "s",
                              "controller tick of the replay (0: exact timing)"),
    "refined_cycles_completed": D.Variable(("start", "replay"), np.int64, "1",
                                           "cycles the refined design's {replay} completed "
                                           "before it fell, stopped or left the error bound"),
    "refined_cycles_walked": D.Variable(("start", "replay"), np.int64, "1",
                                        "cycles the refined design's {replay} ran before it "
                                        "fell, stopped or advanced less than half a gait "
                                        "cycle (whatever its error)"),
    "row": D.index_coordinate("row", "row of dP/dz"),
    "col": D.index_coordinate("col", "column of dP/dz"),
    "best_jacobian": D.Variable(("row", "col"), np.float64, "1",
                                "best design: dP/dz by variational equations"),
    "best_jacobian_fd": D.Variable(("row", "col"), np.float64, "1",
                                   "best design: dP/dz by finite differences"),
    **D.complex_variables("best_multipliers", ("k",),
                          "best design: multipliers of the cycle (variational equations)"),
    **D.complex_variables("best_multipliers_fd", ("k",),
                          "best design: multipliers of the cycle (finite differences)"),
    "cycle": D.index_coordinate("cycle", "replay cycle"),
    "replay_error": D.Variable(("replay", "cycle"), np.float64, D.ERROR_UNITS,
                               "{replay}: section error against the fixed point"),
    "replay_kinetic_energy": D.Variable(("replay", "cycle"), np.float64, "J",
                                        "{replay}: kinetic energy at the section"),
    "replay_pivot_height": D.Variable(("replay", "cycle"), np.float64, "m",
                                      "{replay}: height of the attached end at the section"),
    "cycles_completed": D.Variable(("replay",), np.int64, "1",
                                   "cycles the replay completed before it fell, stopped or "
                                   "left the error bound"),
    "cycles_walked": D.Variable(("replay",), np.int64, "1",
                                "cycles the replay ran before it fell, stopped or advanced "
                                "less than half a gait cycle (whatever its error)"),
    "replay_status": D.Variable.of(("replay",), np.int8, D.STATUS_ATTRS,
                                   long_name="how the replay's run ended"),
    "decay_cycle": D.index_coordinate("decay_cycle", "cycle of the perturbed run"),
    "perturbation_distance": D.Variable(("decay_cycle",), np.float64, "1",
                                        "distance |z_k - z*| of the perturbed run from the "
                                        "fixed point (exact timing)"),
    "basin_d_dtheta1": D.Variable(("basin_d_dtheta1",), np.float64, D.RATE,
                                  "start offset in dtheta1"),
    "basin_d_dtheta2": D.Variable(("basin_d_dtheta2",), np.float64, D.RATE,
                                  "start offset in dtheta2"),
    "basin_cycles": D.Variable(("basin_d_dtheta1", "basin_d_dtheta2"), np.int32, "1",
                               "cycles survived from the offset start (exact timing; "
                               "{basin_cycles}: never failed)"),
    "time": D.Variable(("sample",), np.float64, "s", "time of the best design's cycle"),
    **{key: D.Variable(("sample", "xy"), np.float64, "m", f"world position of {key}")
       for key in ("A", "joint", "B")},
    "attached_end": D.Variable(("sample",), np.int8, "1",
                               "end the frame hangs from (0: A, 1: B)"),
    "phase": D.Variable(("sample",), np.int8, "1", "phase (0 swing, 1 flight, 2 fixed)"),
    "motor_torque": D.Variable(("sample",), np.float64, "N m", "{torque}"),
    # a screen's candidates, the most robust first (the design checked above is the first)
    "candidate": D.index_coordinate("candidate", "screened candidate, the most robust first",
                                    optional=True),
    f"screen_{PARAMETER}": D.Variable(("candidate",), np.float64, "{units}",
                                      "screened candidate: {parameter}", optional=True),
    "screen_objective": D.Variable(("candidate",), np.float64, "1",
                                   "objective of the candidate", optional=True),
    "screen_spectral_radius_fd": D.Variable(("candidate",), np.float64, "1",
                                            "spectral radius per step of the candidate "
                                            "(finite differences)", optional=True),
    "screen_rank": D.Variable(("candidate",), np.int32, "1",
                              "the candidate's place by the objective (0: the least)",
                              optional=True),
    "screen_survived": D.Variable(("candidate",), np.float64, "1",
                                  "fraction of the screen's runs that completed max_cycles",
                                  optional=True),
    "screen_mean_cycles": D.Variable(("candidate",), np.float64, "1",
                                     "cycles a screen run completed, on average",
                                     optional=True),
    # a gait that catches bars (until: bar)
    "catch_offset_margin": D.Variable(PARAMETERS_DIMS, np.float64, "m",
                                      "least offset margin of the design's catches (a bar's "
                                      "window less the hook's horizontal distance from it)",
                                      optional=True),
    "catch_speed": D.Variable(PARAMETERS_DIMS, np.float64, "m s-1",
                              "largest speed of the hook just before a catch", optional=True),
    "catch": D.index_coordinate("catch", "bar catch of the cycle, in the order of its "
                                "segments", optional=True),
    "catch_segment": D.Variable(("catch",), np.int32, "1", "segment (from 0) whose until: "
                                "bar guard makes the catch", optional=True),
    "best_catch_offset_margin": D.Variable(("catch",), np.float64, "m",
                                           "best design: the catch's offset margin",
                                           optional=True),
    "best_catch_speed": D.Variable(("catch",), np.float64, "m s-1",
                                   "best design: the hook's speed just before the catch",
                                   optional=True),
}


def write_design(path: Path, attrs: dict, st: DesignStep, space: DesignSpace, axes,
                 grid: dict, found: dict) -> None:
    """Write a design dataset (:data:`VARIABLES`; dims: one per free parameter, ``k``,
    ``start``, ``replay``, ``cycle``, ``decay_cycle``, ``basin_d_dtheta1``,
    ``basin_d_dtheta2``, ``sample``)."""
    names, shape = st.names, st.shape
    best, checks = found["best"], found["checks"]
    units = {n: space.parameter(n).unit for n in names}
    words = {"map": "the full map (the attached end's height included)"
             if space.height_in_map else "the return map",
             "balance": space.balance,
             "balance_units": space.parameter(space.balance).unit
             if space.balance != "none" else "1",
             "replay": space.replay_name, "basin_cycles": st.verify.basin_cycles}

    def put(name, data, **kw):
        D.write_declared(nc, VARIABLES, name, data, **words, **kw)

    def put_designs(prefix, dim, rows):
        """Design results along ``dim``: the coordinate, each parameter's value
        (``<prefix>_<parameter>``), the objective and the finite-difference spectral
        radius."""
        D.write_coordinate(nc, VARIABLES, dim, np.arange(len(rows)))
        for n in names:
            D.write_declared(nc, VARIABLES, f"{prefix}_{PARAMETER}",
                             [r["result"].values[n] for r in rows],
                             written_as=f"{prefix}_{n}", units=units[n], parameter=n)
        put(f"{prefix}_objective", [step_objective(r["result"], st)
                                    for r in rows])
        put(f"{prefix}_spectral_radius_fd", [r["result"].spectral_radius_fd for r in rows])

    with D.atomic_netcdf(path) as nc:
        for n, a in zip(names, axes):
            nc.createDimension(n, len(a))
            D.write_declared(nc, VARIABLES, PARAMETER, a, written_as=n, dims=(n,),
                             units=units[n], meaning=space.parameter(n).meaning)
        k = space.n_multipliers
        D.write_coordinate(nc, VARIABLES, "k", np.arange(k))
        for key in GRID_VARIABLES:
            put(key, grid[key].reshape(shape), dims=tuple(names))
        put("multiplier_modulus", grid["multiplier_modulus"].reshape(*shape, k),
            dims=(*names, "k"))
        rows = catch_rows(space)
        if rows:
            for key in ("catch_offset_margin", "catch_speed"):
                put(key, grid[key].reshape(shape), dims=tuple(names))
        refined = found["refined"]
        put_designs("refined", "start", refined)
        put("start_objective", [r["start_objective"] for r in refined])
        put("refine_evaluations", [r["evaluations"] for r in refined])
        nc.createDimension("replay", 2)
        put("replay_tick", [0.0, st.verify.tick])
        for key in ("cycles_completed", "cycles_walked"):
            put(f"refined_{key}", np.array([r[key] for r in refined],
                                           np.int64).reshape(len(refined), 2))
        D.write_coordinate(nc, VARIABLES, "row", np.arange(k))
        D.write_coordinate(nc, VARIABLES, "col", np.arange(k))
        put("best_jacobian", best.jacobian)
        put("best_jacobian_fd", best.jacobian_fd)
        D.write_complex(nc, VARIABLES, "best_multipliers", best.multipliers)
        D.write_complex(nc, VARIABLES, "best_multipliers_fd", best.multipliers_fd)
        if rows:
            D.write_coordinate(nc, VARIABLES, "catch", np.arange(len(rows)))
            put("catch_segment", rows)
            put("best_catch_offset_margin", best.catch_offset_margin)
            put("best_catch_speed", best.catch_speed)
        replays = checks["replays"]
        n_cyc = st.verify.cycles
        D.write_coordinate(nc, VARIABLES, "cycle", np.arange(1, n_cyc + 1))
        for key in ("error", "kinetic_energy", "pivot_height"):
            data = np.full((len(replays), n_cyc), np.nan)
            for i, r in enumerate(replays):
                v = getattr(r, key)[:n_cyc]
                data[i, :v.size] = v
            put(f"replay_{key}", data)
        put("cycles_completed", [r.cycles_completed for r in replays])
        put("cycles_walked", [r.cycles_walked for r in replays])
        put("replay_status", [r.status for r in replays])
        decay = checks["decay"]
        D.write_coordinate(nc, VARIABLES, "decay_cycle", np.arange(1, decay.size + 1))
        put("perturbation_distance", decay)
        offsets = checks["offsets"]
        for dim in ("basin_d_dtheta1", "basin_d_dtheta2"):
            D.write_coordinate(nc, VARIABLES, dim, offsets)
        put("basin_cycles", checks["basin"])
        rec = D.run_record(found["film"])
        nc.createDimension("sample", rec["time"].size)
        nc.createDimension("xy", 2)
        put("time", rec["time"])
        for key in ("A", "joint", "B"):
            put(key, rec[key])
        put("attached_end", rec["attached_end"])
        put("phase", rec["phase"])
        torque, what = rec["motor_torque"], "motor torque"
        if attrs.get("torque_frame") == "motor":
            # the cycle starts hanging from A: after its swap the kernel's torque acts on
            # theta2 of B's frame, the opposite physical torque
            torque = np.where((rec["attached_end"] == 0) | (torque == 0.0), torque, -torque)
            what = "motor torque in the motor frame (the sign fixed to the links)"
        put("motor_torque", torque, torque=what)
        screened = found.get("screened") or []
        if screened:
            put_designs("screen", "candidate", screened)
            put("screen_rank", [c["rank"] for c in screened])
            put("screen_survived", [c["survived"] for c in screened])
            put("screen_mean_cycles", [c["mean_cycles"] for c in screened])
        D.set_global_attrs(nc, attrs)


def catch_rows(space) -> list[int]:
    """The design space's catching segments (from 0; none for a horizontal gait's)."""
    return list(getattr(space, "catch_rows", []))


def walks_on(replay, cycles: int) -> bool:
    """Whether a replay ran all ``cycles`` without falling, stopping or stalling
    (``cycles_walked``), whether or not it stayed within the error bound around the
    exact-timing fixed point: on the tick each action waits for the next tick, a delay of up
    to a tick that differs from cycle to cycle, and a stable gait keeps walking near its
    orbit with an error that this delay keeps up (its height drifting)."""
    return replay.status == Status.OK and replay.cycles_walked >= cycles


def walked_on(replay, cycles: int) -> str:
    """The verdict's words for a replay that left the error bound and walked on ("" if it
    fell or stopped): its largest error and its mean over the last ten cycles."""
    if not walks_on(replay, cycles):
        return ""
    tail = replay.error[-min(10, cycles):]
    return (f" within the error bound, then walks on to {cycles} cycles without falling "
            f"(error {float(np.max(replay.error)):.2g} at most, {float(np.mean(tail)):.2g} "
            f"over the last {tail.size})")


def cycles_text(n: int) -> str:
    """``1 cycle``, ``25 cycles``."""
    return f"{n} cycle{'' if n == 1 else 's'}"


def best_attrs(space: DesignSpace, st: DesignStep, found: dict) -> dict:
    """The best design's numbers and the verdict, as global attributes."""
    best, checks = found["best"], found["checks"]
    exact, ticked = checks["replays"]
    rho, rho_fd = best.spectral_radius, best.spectral_radius_fd
    stable = rho < 1.0
    n = st.verify.cycles
    tick_ms = f"{st.verify.tick * 1e3:g} ms tick"
    replay = space.replay_name
    if not stable:
        verdict = f"unstable: rho = {rho:.6g} per step (no design with rho < 1 found)"
    elif ticked.cycles_completed >= n:
        verdict = (f"stable: rho = {rho:.6g}; the {replay} completes {n} cycles "
                   f"with exact timing and on the {tick_ms}")
    elif exact.cycles_completed >= n and walks_on(ticked, n):
        verdict = (f"stable: rho = {rho:.6g}; the {replay} completes {n} cycles "
                   f"with exact timing; on the {tick_ms} it stays "
                   f"{cycles_text(ticked.cycles_completed)}{walked_on(ticked, n)}")
    elif exact.cycles_completed >= n:
        verdict = (f"stable with exact timing only: rho = {rho:.6g}; on the {tick_ms} the "
                   f"replay lasts {cycles_text(ticked.cycles_completed)}")
    else:
        verdict = (f"linearly stable (rho = {rho:.6g}) but the replay lasts "
                   f"{cycles_text(exact.cycles_completed)} with exact timing")
    out = {f"best_{n_}": float(best.values[n_]) for n_ in space.parameter_names}
    out.update(best_spectral_radius=rho, best_spectral_radius_fd=rho_fd,
               spectral_radius_agreement=abs(rho - rho_fd),
               best_theta2=float(best.z[0]), best_dtheta1=float(best.z[1]),
               best_dtheta2=float(best.z[2]), best_error=best.error, best_rise=best.rise,
               best_advance=best.advance, best_energy_per_metre=best.energy_per_metre,
               best_period=best.period, best_objective=step_objective(best, st),
               decay_growth=checks["growth"], multiplier_power=rho ** space.steps,
               steps_per_cycle=space.steps, balance=space.balance, clock=space.clock,
               objective=st.objective,
               energy_weight=st.energy_weight, parameters=list(st.names),
               stable=bool(stable), stable_exact=bool(stable and exact.cycles_completed >= n),
               stable_tick=bool(stable and ticked.cycles_completed >= n),
               tick_walks_on=bool(stable and walks_on(ticked, n)),
               verify_tick=st.verify.tick, verify_cycles=n, error_bound=st.verify.error_bound,
               verdict=verdict)
    if "t_switch" in best.values:
        out.update(t_switch=float(best.values["t_switch"]),
                   t_motor=float(best.values["t_motor"]))
    if space.height_in_map:
        out["height_in_map"] = 1
    if catch_rows(space):
        out.update(catch_speed_weight=st.catch_speed_weight,
                   min_offset_margin=st.min_offset_margin,
                   best_min_offset_margin=best.min_offset_margin,
                   best_max_catch_speed=best.max_catch_speed)
    screened = found.get("screened") or []
    if screened:
        sc = st.screen
        out.update(chosen_by="survival", screen_runs=sc.runs, screen_max_cycles=sc.max_cycles,
                   screen_tick=sc.tick, screen_seed=sc.seed,
                   screen_noise=sc.noise.level(0).to_dict(),
                   best_screen_survived=screened[0]["survived"],
                   best_screen_mean_cycles=screened[0]["mean_cycles"])
    return out


def segment_problems(study, index: int, step: DesignStep, names: list[str]) -> list:
    """Problems with a design step on a sequence gait: parameters that are not its segments'
    values and torques or outside their bounds, a balance, a running clock."""
    out = []
    where = ("steps", index, "parameters")
    try:
        space = SegmentDesignSpace(study.gait.gait(), study.to_robot(),
                                   motor_frame=study.gait.torque_frame == "motor")
    except ValueError as exc:
        return [(("steps", index), f"a design step on this gait: {exc}")]
    for name in names:
        if not SEGMENT_PARAMETER.fullmatch(name):
            out.append((where, f"{name!r} is a horizontal gait's schedule parameter; a "
                        f"sequence gait's design parameters: {', '.join(space.parameter_names)}"))
            continue
        try:
            p = space.parameter(name)
        except ValueError as exc:
            out.append((where, str(exc)))
            continue
        values = ([step.parameters[name].start, step.parameters[name].stop]
                  if name in step.parameters else [step.fixed[name]])
        for v in values:
            if not p.lower <= v <= p.upper:
                out.append((where, f"{name}: {v!r} {p.unit} outside [{p.lower}, {p.upper}]"))
    if "balance" in step.model_fields_set and step.balance != "none":
        out.append((("steps", index, "balance"), "a sequence gait's design has no balance: "
                    "it holds its height by a guard on a world height, or not at all"))
    if step.clock != "reset_at_vertical":
        out.append((("steps", index, "clock"), "a sequence gait's design runs its own "
                    "clock, restarted at its section"))
    return out + catch_option_problems(index, step, bool(space.catch_rows))


def catch_option_problems(index: int, step: DesignStep, catching: bool) -> list:
    """The catch options (``catch_speed_weight``, ``min_offset_margin``) set for a gait that
    catches no bar (``catching`` False)."""
    if catching:
        return []
    return [(("steps", index, key), f"{key} weighs a gait's bar catches, and this gait "
             "catches no bar (until: bar)") for key in ("catch_speed_weight",
                                                        "min_offset_margin")
            if getattr(step, key) > 0]


# --- the kind ------------------------------------------------------------------------------------
class DesignKind(StepKind):
    name = "design"
    model = DesignStep
    variables = VARIABLES
    gait_kinds = ("horizontal", "sequence")
    accepts = ("shoot", "refine", "floquet")
    provides = "its best design (schedule, robot and fixed point)"
    unit = "designs"
    block_units = True
    figures = (
        Figure("map"),
        Figure("multipliers"),
        Figure("replay"),
        Figure("filmstrip"),
        Figure("screen"),
    )

    def check_step(self, study, index, step: DesignStep, ref, seen) -> list:
        out = []
        if ref is not None and ref.kind == "floquet" and "open_loop" not in ref.controllers:
            out.append((("steps", index, "from"), f"floquet step {ref.name!r} has no "
                        "open_loop fixed point"))
        if study.gait.tick != 0.0:
            out.append((("gait", "tick"), "a design step solves gaits with exact timing "
                        "(gait tick 0); verify.tick sets the replay's tick"))
        names = list(step.parameters) + list(step.fixed)
        segments = [n for n in names if SEGMENT_PARAMETER.fullmatch(n)]
        if study.gait.conventions.swap_motor_times:
            if segments:
                out.append((("steps", index, "parameters"), f"{segments[0]!r} is a sequence "
                            f"gait's segment; the horizontal gait's design parameters: "
                            f"{sorted(PARAMETERS)}"))
            if step.height_in_map:
                out.append((("steps", index, "height_in_map"), "the horizontal gait's "
                            "schedules sense no height: its full map has a multiplier 1"))
            return (out + catch_option_problems(index, step, False)
                    + option_problems(step, ref, index))
        return out + option_problems(step, ref, index) + segment_problems(study, index, step,
                                                                          names)

    def blocks(self, step: DesignStep) -> list[Block]:
        n = int(np.prod(step.shape))
        size = step.designs_per_block
        return [Block(i, lo, min(lo + size, n)) for i, lo in enumerate(range(0, n, size))]

    def phases(self, step: DesignStep) -> tuple[str, ...]:
        return ("grid", "refine") + (("screen",) if step.screen else ()) + ("checks",)

    def block_summary(self, step: DesignStep) -> str:
        return " x ".join(f"{n} {a.num}" for n, a in step.parameters.items()) + " designs"

    def n_tasks(self, step: DesignStep, gait) -> int:
        return len(self.blocks(step))

    def hand_on(self, dep: Dependency, ctx: StepContext, **options):
        return read_start(design_start, dep, ctx, options)

    def needs_variational(self, step) -> bool:
        return True

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        schedule = schedule_design(ctx.spec)
        gait = ctx.handed_on(solution=st.solution, start_index=st.start_index,
                             replay="open_loop" if schedule else "gait",
                             max_map_defect=MAX_MAP_DEFECT, require="run")
        space = (design_space(ctx, gait) if schedule else
                 segment_space(gait.gait, ctx.spec.robot, st, ctx.spec.torque_frame,
                               ctx.spec.integrator))
        axes = [a.values() for a in st.parameters.values()]
        ctx.state.update(gait=gait, space=space, axes=axes)
        starts = [(list(gait.z), None)] + [
            (list(x[:3]), x[3] if len(x) == 4 else None) for x in st.starts]
        ctx.state["starts"] = starts
        return [Task(b, design_block, (space, st.names, axes, starts, b.lo, b.hi))
                for b in ctx.todo_blocks()]

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        st = ctx.step
        gait, space, axes = ctx.state["gait"], ctx.state["space"], ctx.state["axes"]
        n = int(np.prod(st.shape))
        grid = {k: np.full(n, np.nan) for k in FIELDS}
        grid["status"] = np.zeros(n, np.int8)
        grid["multiplier_modulus"] = np.full((n, space.n_multipliers), np.nan)
        for b in ctx.blocks:
            got = ctx.block_arrays(b)
            for k in grid:
                grid[k][b.lo:b.hi] = got[k]
        with np.errstate(invalid="ignore", divide="ignore"):
            grid["energy_per_metre"] = np.where(grid["advance"] > 0,
                                                grid["energy_lost"] / grid["advance"], np.nan)
        rho = grid["spectral_radius_fd"]
        grid["objective"] = objective_value(st.objective, rho, grid["energy_per_metre"],
                                            st.energy_weight, grid["catch_speed"],
                                            st.catch_speed_weight)
        found = refine_and_verify(space, st, axes, grid, ctx.state["starts"],
                                  start_shape(gait, ctx.spec.integrator), ctx.progress)
        src = gait.source
        if schedule_design(ctx.spec):
            attrs.update(start_t_switch=src["t_switch"], start_t_motor=src["t_motor"],
                         motor_torque=src["torque"])
        attrs.update(gait.attrs("source"), start_theta2=gait.z[0], start_dtheta1=gait.z[1],
                     start_dtheta2=gait.z[2],
                     n_blocks=len(ctx.blocks), designs=n,
                     designs_with_gait=int(np.sum(grid["status"] == DESIGN_OK)),
                     grid_min_spectral_radius=float(np.nanmin(rho)) if np.any(
                         np.isfinite(rho)) else math.nan,
                     total_nfev=int(np.nansum(grid["nfev"])))
        attrs.update(best_attrs(space, st, found))
        refused = found["refused"]
        if refused:
            attrs["refused_candidates"] = refused
        write_design(ctx.path, attrs, st, space, axes, grid, found)
        return (f"{n} designs ({attrs['designs_with_gait']} with a gait); best rho "
                f"{attrs['best_spectral_radius']:.6g} per step (fd "
                f"{attrs['best_spectral_radius_fd']:.6g}); {attrs['verdict']}"
                + (f"; refused {len(refused)} candidate(s) that are no gait of the starting "
                   f"gait's kind, e.g. {refusal_text(refused[0])}" if refused else ""))

    def describe(self, ds) -> list[str]:
        a = ds.attrs
        names = [str(x) for x in json_list(a.get("parameters", "[]"))]
        best = ", ".join(f"{n} {float(a['best_' + n]):.6g} {ds[n].attrs.get('units', '')}"
                         for n in names)
        lines = [f"{int(a['designs'])} designs over {', '.join(names)} "
                f"({int(a['designs_with_gait'])} with a gait); balance {a.get('balance')}; "
                f"clock {a.get('clock', 'reset_at_vertical')}; "
                f"{int(a['steps_per_cycle'])} step(s) per cycle",
                f"best: {best}; rho {float(a['best_spectral_radius']):.6g} (variational), "
                f"{float(a['best_spectral_radius_fd']):.6g} (fd)"
                + (" of the full map, the height included" if a.get("height_in_map") else "")
                + f"; grid min {float(a['grid_min_spectral_radius']):.6g}"]
        if "best_t_switch" in a:
            lines.append(
                "best in the motor frame (the sign fixed to the links; times from "
                + ("the clock's phase zero" if a.get("clock") == "run_on" else "the vertical")
                + "): "
                + "; ".join(f"{tau:+.4g} N m from {t0:.4g} s for {t1 - t0:.4g} s"
                            for t0, t1, tau in motor_frame_pulses(best_schedule(a)))
                + f"; swap at {float(a['best_t_switch']):.4g} s")
        else:
            k = 1
            parts = []
            while f"best_segment{k}_value" in a:
                parts.append(f"segment {k}: {float(a[f'best_segment{k}_value']):.6g}, torque "
                             f"{float(a[f'best_segment{k}_torque']):+.6g} N m")
                k += 1
            lines.append(f"best gait ({a.get('torque_frame', 'attached_end')} frame): "
                         + "; ".join(parts))
        if a.get("chosen_by") == "survival":
            lines.append(
                f"chosen by survival: {ds.sizes['candidate']} candidates, "
                f"{int(a['screen_runs'])} runs of up to {int(a['screen_max_cycles'])} cycles "
                f"each; the best completed {100 * float(a['best_screen_survived']):.4g} % of "
                "its runs (" + ", ".join(
                    f"rho {float(r):.4g}: {100 * float(v):.4g} %" for r, v in zip(
                        ds["screen_spectral_radius_fd"].values,
                        ds["screen_survived"].values)) + ")")
        refused = json_list(a.get("refused_candidates", "[]"))
        if refused:
            lines.append(f"refused {len(refused)} candidate(s), no gait of the starting "
                         f"gait's kind: " + "; ".join(refusal_text(r) for r in refused))
        lines.append(
                f"replays: {', '.join(str(int(c)) for c in ds['cycles_completed'].values)} "
                f"cycles within the error bound"
                + (f", {', '.join(str(int(c)) for c in ds['cycles_walked'].values)} walked"
                   if "cycles_walked" in ds else "")
                + f" (tick {', '.join(f'{float(t):g}' for t in ds['replay_tick'].values)} "
                f"s); {a.get('verdict')}")
        return lines


def best_schedule(attrs) -> dict[str, float]:
    """The best design's schedule from a design dataset's ``best_*`` attributes."""
    keys = ("t_switch", "motor_start", "t_motor", "torque", "pulse2_start", "pulse2_duration",
            "pulse2_torque")
    return {k: float(attrs["best_" + k]) for k in keys if "best_" + k in attrs}


def json_list(text) -> list:
    """A list attribute (stored as JSON text)."""
    return json.loads(text) if isinstance(text, str) and text else list(text or [])
