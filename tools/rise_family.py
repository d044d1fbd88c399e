"""The one-swing gaits of the 2009 robot and motor at each rise per step, searched and screened.

The family is robust_design.yaml's gait with its catch on a staircase (torques in the motor
frame, the physical motor torque, ``|tau| <= 0.6354`` N m, the 2009 motor's limit):

  - from the vertical crossing (the section; the clock restarts) torque ``T1`` from 7.5e-8 s;
  - the catch: B's magnet switches on when B rises through the route's planned height
    (``until: free_end_y, value: r, direction: rising``, the gait's ``rise: r``: step k from 0
    catches at ``r (k + 1)`` m in the world); the clock restarts at the catch;
  - ``T2`` for ``D`` s after the catch (the magnets swap at the catch), then the motor is off
    to the next vertical.

For each rise ``r`` [m per step] of ``--rises`` the script solves the family's fixed points
(Newton on the section, :func:`~monkeystudy.analysis.design.evaluate_design`) over a grid of
``(T1, T2, D)`` (``T1, T2`` in [-0.6354, 0.6354] N m, ``D`` in [0.1, 0.7] s). Every start is
reached by continuation: at rise 0 from robust_design's gait (its section theta2 0.43 rad,
refined from [4.8, -1.6] rad s-1), carried in parameter steps to the grid and across it from
cell to neighbouring cell; then in rise steps of at most ``--rise-step`` m up and down, each
gait of each cell from itself at the neighbouring rise (an unsolved cell from a neighbouring
cell's gaits at this rise). A cell may have several gaits (branches): it keeps up to 4, and
at each listed rise every cell is also solved from its neighbours' gaits unlike its own, for
the branches the continuation has not brought it. A gait is stable
when its full map's spectral radius (the height included, finite differences) is below 1,
its step swaps the magnets once and passes the vertical once, and ``|theta2| < pi``. The
``--candidates`` least-rho stable gaits of a rise (no two neighbours on the grid) are
screened by ``--runs`` survival runs of ``--steps`` steps each under robust_design's noise
(the 1 ms tick, timing 1e-3 s, latency 1e-3 s, mass, CG and inertia 1 %, seed 30): a run
lasts when it completes every step within ``--height-tolerance`` of the staircase; the
gait kept is the one with the most runs lasting, then the most steps on average, then the
least rho.

Besides the table of rises it reports two climbs: the steepest rise at which the grid has
any stable gait (bisection on the rise to ``--bisect-to`` m above the steepest listed rise
that has one, by continuation from it), and the steepest listed rise whose chosen gait
lasts in at least ``--keep`` of the runs.

Usage (from the project's folder; about 20 minutes on two cores shared with other work, most
of it the listed rises' branch solves, 1 to 2 minutes each, and the screens)::

    NUMBA_NUM_THREADS=1 python3 tools/rise_family.py -o /tmp/risefam/gaits.yaml

Prints one line per rise: the rise [m], ``T1``, ``T2`` [N m], ``D`` [s], the fixed point's
theta2 [rad], its section state (the start of a study's gait), rho, the runs that lasted of
the screen's runs and their mean steps; then the two steepest climbs. ``-o`` writes the
chosen gaits as YAML gait blocks of an atlas step (``name``, ``start``, ``gait``).
"""
from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from monkeystudy.analysis.design import (
    CycleShape, DesignResult, SegmentDesignSpace, cycle_shape, design_survival,
    evaluate_design, step_problems,
)
from monkeystudy.analysis.survival import Noise
from monkeystudy.controllers import Integrator
from monkeystudy.robot import Robot
from monkeystudy.simulation import Status
from monkeystudy.study.models import SequenceGaitSpec

#: the 2009 motor's torque limit [N m]
TORQUE_LIMIT = 0.6354
#: the motor's start after the vertical crossing [s] (robust_design's)
T1_START = 7.519090701371105e-08
#: robust_design's gait (T1, T2 [N m], D [s]) and the section state its refine starts from
#: (theta2 [rad], dtheta1, dtheta2 [rad s-1])
LEVEL_GAIT = (0.3213454663367762, -0.40251722486466324, 0.28929574705023964)
LEVEL_START = (0.43, 4.8, -1.6)
#: the integrator of the return map and the runs (gait_atlas.yaml's)
INTEGRATOR = Integrator(method="dop853", rtol=1e-12, atol=1e-13, max_time=4.0)
#: robust_design's noise
NOISE = Noise(timing=1e-3, latency=1e-3, mass=0.01, com=0.01, inertia=0.01)
DEFAULT_RISES = (-0.30, -0.25, -0.20, -0.15, -0.10, -0.05, 0.00, 0.01, 0.02, 0.03, 0.04, 0.05)


def gait_block(rise: float, t1: float, t2: float, d: float, theta2: float) -> dict:
    """The family's gait at ``rise`` [m per step] as a study's ``gait`` block (plain data):
    ``t1`` from the vertical, ``t2`` [N m] for ``d`` [s] after the catch, the section's
    theta2 ``theta2`` [rad] (the start of a search on the section)."""
    block = {"kind": "sequence", "torque_frame": "motor"}
    if rise != 0.0:
        block["rise"] = float(rise)
    block["section"] = {"theta1": 0.0, "direction": "either", "theta2": float(theta2)}
    block["segments"] = [
        {"until": "time", "value": T1_START},
        {"until": "free_end_y", "value": float(rise), "direction": "rising",
         "torque": float(t1), "clock": "reset"},
        {"until": "time", "value": float(d), "magnets": "swap", "torque": float(t2)},
    ]
    return block


def family_space(rise: float, *, full_map: bool = True,
                 integrator: Integrator = INTEGRATOR) -> SegmentDesignSpace:
    """The family at ``rise`` [m] as a design space over ``segment2_torque`` (T1),
    ``segment3_torque`` (T2) and ``segment3_value`` (D), torques in the motor frame within
    :data:`TORQUE_LIMIT`; stability of the full map (``full_map``) or of the section map
    (cheaper: enough to carry a gait on to the next rise)."""
    gait = SequenceGaitSpec(**gait_block(rise, *LEVEL_GAIT, LEVEL_START[0])).gait()
    return SegmentDesignSpace(gait, Robot.preset("seed2009"), motor_frame=True,
                              height_in_map=full_map, integrator=integrator,
                              torque_limit=TORQUE_LIMIT)


def design_values(cell) -> dict[str, float]:
    """A family member ``(T1, T2, D)`` as design values."""
    t1, t2, d = cell
    return {"segment2_torque": float(t1), "segment3_torque": float(t2),
            "segment3_value": float(d)}


@dataclass
class Gait:
    """A solved family member: its parameters ``(T1, T2, D)``, its design result and what its
    step does (``problems``: why it is not a one-swing step; empty if it is one)."""

    cell: tuple[float, float, float]
    result: DesignResult
    problems: str = ""

    @property
    def z(self) -> np.ndarray:
        return self.result.z

    @property
    def rho(self) -> float:
        return float(self.result.spectral_radius_fd)

    @property
    def stable(self) -> bool:
        return not self.problems and math.isfinite(self.rho) and self.rho < 1.0


#: two fixed points of one cell closer than this (largest component) are one gait
SAME_GAIT = 1e-6
#: gaits (branches) kept per grid cell
BRANCHES = 4
#: a neighbouring cell's gait is tried as a start for another branch when its fixed point is
#: farther than this from each of the cell's (largest component; rad, rad s-1)
NEW_BRANCH = 0.1
#: starts tried per cell for another branch
BRANCH_STARTS = 4

#: one step of robust_design's kind: one swap, one pass of the vertical
ONE_SWING = CycleShape(status=0, swaps=1, crossings=1, max_abs_theta2=0.0,
                       max_kinetic_energy=0.0)


def order_key(g: "Gait") -> tuple[bool, float]:
    """One-swing steps first, then the least spectral radius."""
    return bool(g.problems), g.rho if math.isfinite(g.rho) else math.inf


def distinct(z, gaits, tol: float) -> bool:
    """``z`` is farther than ``tol`` (largest component) from every gait's fixed point."""
    return all(np.max(np.abs(np.asarray(z) - g.z)) > tol for g in gaits)


def wrapped(z) -> np.ndarray:
    """A section state with theta2 in [-pi, pi) [rad]."""
    z = np.array(z, float)
    z[0] = (z[0] + math.pi) % (2 * math.pi) - math.pi
    return z


def solve_all(space: SegmentDesignSpace, cell, starts, *, check: bool = True) -> list[Gait]:
    """The family member ``cell`` at the space's rise from each distinct start ``z`` in
    ``starts``: every distinct fixed point found (one-swing steps first, then by spectral
    radius); the step of each is checked (``problems``) when ``check``."""
    found: list[Gait] = []
    seen: list[np.ndarray] = []
    for z0 in starts:
        z0 = np.asarray(z0, float)
        if any(np.allclose(z0, s, atol=1e-9, rtol=0) for s in seen):
            continue
        seen.append(z0)
        res = evaluate_design(space, design_values(cell), z0)
        if res.ok and abs(res.z[0]) > math.pi:    # the same gait, theta2 a turn away
            res = evaluate_design(space, design_values(cell), wrapped(res.z))
        if not res.ok or not distinct(res.z, found, SAME_GAIT):
            continue
        g = Gait(tuple(cell), res)
        if check:
            shape = cycle_shape(space.gait_for(res.values), res.z, robot=space.robot,
                                integrator=space.integrator)
            g.problems = "; ".join(step_problems(shape, ONE_SWING, space.robot))
        found.append(g)
    return sorted(found, key=order_key)


def solve(space: SegmentDesignSpace, cell, starts, *, check: bool = True) -> Gait | None:
    """The first of :func:`solve_all` (a one-swing step of least spectral radius), or None
    when no start converges."""
    found = solve_all(space, cell, starts, check=check)
    return found[0] if found else None


def merge(kept: list[Gait], new: list[Gait], most: int) -> list[Gait]:
    """``kept`` and the gaits of ``new`` distinct from them, the ``most`` first
    (:func:`order_key`)."""
    out = list(kept)
    for g in new:
        if distinct(g.z, out, SAME_GAIT):
            out.append(g)
    return sorted(out, key=order_key)[:most]


@dataclass(frozen=True)
class Grid:
    """The grid of ``(T1, T2, D)``: the values of each axis (torques [N m], D [s])."""

    t1: tuple[float, ...]
    t2: tuple[float, ...]
    d: tuple[float, ...]

    @classmethod
    def uniform(cls, n: int = 7, limit: float = TORQUE_LIMIT, d_low: float = 0.1,
                d_high: float = 0.7) -> "Grid":
        """``n`` values of each torque in [-limit, limit] N m, ``n`` of D in
        [d_low, d_high] s."""
        t = tuple(float(v) for v in np.linspace(-limit, limit, n))
        return cls(t, t, tuple(float(v) for v in np.linspace(d_low, d_high, n)))

    @property
    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return np.array(self.t1), np.array(self.t2), np.array(self.d)

    @property
    def shape(self) -> tuple[int, int, int]:
        return len(self.t1), len(self.t2), len(self.d)

    def cell(self, idx) -> tuple[float, float, float]:
        return self.t1[idx[0]], self.t2[idx[1]], self.d[idx[2]]

    @property
    def indices(self) -> list[tuple[int, int, int]]:
        return list(itertools.product(*(range(n) for n in self.shape)))

    def index(self, cell) -> tuple[int, int, int]:
        """The index of the grid cell nearest ``cell``."""
        return tuple(int(np.argmin(np.abs(a - v))) for a, v in zip(self.axes, cell))


def neighbours(idx, shape) -> list[tuple[int, ...]]:
    """Grid indices (of a grid of ``shape``) at Chebyshev distance 1 from ``idx``, the
    nearest (fewest axes moved) first."""
    out = []
    for step in itertools.product((-1, 0, 1), repeat=len(idx)):
        if any(step):
            j = tuple(i + s for i, s in zip(idx, step))
            if all(0 <= k < n for k, n in zip(j, shape)):
                out.append((sum(map(abs, step)), j))
    return [j for _, j in sorted(out)]


def level_gait(space: SegmentDesignSpace) -> Gait:
    """robust_design's gait on the level (``space`` at rise 0), from its refine's start."""
    g = solve(space, LEVEL_GAIT, [LEVEL_START], check=False)
    if g is None:
        raise RuntimeError("robust_design's gait has no fixed point from its start")
    return g


def seed_grid(space: SegmentDesignSpace, grid: Grid, level: Gait, *,
              branches: bool = True) -> dict:
    """The grid at rise 0, reached from the level gait: carried in 8 parameter steps to the
    nearest grid cell, then across the grid (:func:`spread`)."""
    near = grid.index(level.cell)
    z = level.z
    target = np.array(grid.cell(near))
    for s in np.linspace(0.0, 1.0, 9)[1:]:
        cell = (1 - s) * np.array(level.cell) + s * target
        g = solve(space, cell, [z], check=False)
        if g is None:
            raise RuntimeError(f"the level gait is lost on the way to grid cell {near}")
        z = g.z
    return spread(space, grid, {}, seeds={near: [z]}, branches=branches)


def spread(space: SegmentDesignSpace, grid: Grid, solved: dict, seeds: dict, *,
           branches: bool = True) -> dict:
    """Solve the grid's cells from ``seeds`` (index -> starts) and from the gaits of
    ``solved`` (index -> list of Gait, kept): breadth first, each unsolved cell next to a
    solved one from its solved neighbours' fixed points (the nearest cells first, at most
    :data:`BRANCH_STARTS`); then, with ``branches``, each cell once more from its
    neighbours' fixed points unlike any of its own (:data:`NEW_BRANCH`; at most
    :data:`BRANCH_STARTS`, the nearest to its best gait first), for gaits on other
    branches. A cell keeps :data:`BRANCHES` gaits. Returns every solved cell."""
    out = {idx: list(gs) for idx, gs in solved.items()}
    frontier = []
    for idx, starts in seeds.items():
        gs = solve_all(space, grid.cell(idx), starts)
        if gs:
            out[idx] = merge(out.get(idx, []), gs, BRANCHES)
            frontier.append(idx)
    frontier += [idx for idx in solved]
    tried: set = set(out)
    while frontier:
        nxt = []
        for idx in frontier:
            for j in neighbours(idx, grid.shape):
                if j in tried:
                    continue
                tried.add(j)
                starts = [g.z for k in neighbours(j, grid.shape) if k in out
                          for g in out[k]][:BRANCH_STARTS]
                gs = solve_all(space, grid.cell(j), starts)
                if gs:
                    out[j] = gs[:BRANCHES]
                    nxt.append(j)
        frontier = nxt
    if branches:
        before = {idx: list(gs) for idx, gs in out.items()}
        for idx in grid.indices:
            own = before.get(idx, [])
            others = [g.z for k in neighbours(idx, grid.shape) if k in before
                      for g in before[k] if distinct(g.z, own, NEW_BRANCH)]
            if own:
                others.sort(key=lambda z: float(np.max(np.abs(z - own[0].z))))
            gs = solve_all(space, grid.cell(idx), others[:BRANCH_STARTS])
            if gs:
                out[idx] = merge(out.get(idx, []), gs, BRANCHES)
    return out


def continue_grid(space: SegmentDesignSpace, grid: Grid, previous: dict, *,
                  branches: bool = True) -> dict:
    """The grid at the space's rise from its gaits at a neighbouring rise (``previous``):
    each gait of each cell from its fixed point there, then across the grid
    (:func:`spread`)."""
    out = {}
    for idx, gs in previous.items():
        found = solve_all(space, grid.cell(idx), [g.z for g in gs])
        if found:
            out[idx] = found[:BRANCHES]
    return spread(space, grid, out, seeds={}, branches=branches)


def rise_path(rises, step: float) -> list[float]:
    """The rises the continuation visits, from 0 out to each end of ``rises``, in steps of at
    most ``step`` [m], every rise of ``rises`` on the path (rounded to 1e-9 m)."""
    lo, hi = min(min(rises), 0.0), max(max(rises), 0.0)

    def leg(end):
        n = max(1, math.ceil(abs(end) / step - 1e-9))
        pts = set(np.round(np.linspace(0.0, end, n + 1), 9)) | {round(r, 9) for r in rises
                                                               if r * end > 0}
        return sorted(pts, key=abs)
    return leg(hi)[1:] if hi > 0 else [], leg(lo)[1:] if lo < 0 else []


@dataclass
class Screened:
    """A screened gait: lasting runs of the screen's, their mean steps."""

    gait: Gait
    lasted: int
    runs: int
    mean_steps: float


@dataclass(frozen=True)
class Screen:
    """The survival screen: ``runs`` runs of ``steps`` steps on the ``tick`` [s], ``seed``,
    a run lasting when it completes them within ``height_tolerance`` [m] of the staircase."""

    candidates: int = 8
    runs: int = 100
    steps: int = 300
    seed: int = 30
    tick: float = 1e-3
    height_tolerance: float = 0.02
    noise: Noise = NOISE

    def run(self, space: SegmentDesignSpace, g: Gait) -> Screened:
        r = design_survival(space, g.result, runs=self.runs, max_cycles=self.steps,
                            noise=self.noise, seed=self.seed, tick=self.tick)
        lasted = (r.failure == Status.OK) & (np.abs(r.height) <= self.height_tolerance)
        return Screened(g, int(lasted.sum()), self.runs, float(np.mean(r.cycles)))


def candidates(solved: dict, k: int) -> list[Gait]:
    """The ``k`` least-rho stable gaits of a grid (each cell's best), no two neighbours on
    it."""
    order = sorted((idx for idx, gs in solved.items() if gs[0].stable),
                   key=lambda i: (solved[i][0].rho, i))
    out: list = []
    for idx in order:
        if len(out) == k:
            break
        if any(max(abs(a - b) for a, b in zip(idx, j)) <= 1 for j in out):
            continue
        out.append(idx)
    return [solved[i][0] for i in out]


def stable_cells(solved: dict) -> int:
    """The grid's cells that have a stable gait."""
    return sum(gs[0].stable for gs in solved.values())


def choose(space: SegmentDesignSpace, solved: dict, screen: Screen) -> tuple[Screened | None, int]:
    """The screened gait that lasts longest (the most runs lasting, then the most steps, then
    the least rho) of the grid's candidates, and the number of stable gaits."""
    n_stable = stable_cells(solved)
    picks = [screen.run(space, g) for g in candidates(solved, screen.candidates)]
    if not picks:
        return None, n_stable
    return min(picks, key=lambda s: (-s.lasted, -s.mean_steps, s.gait.rho)), n_stable


@dataclass
class RiseResult:
    """A rise's search: the grid's cells with a gait and with a stable one, the chosen gait."""

    rise: float
    converged: int
    stable: int
    chosen: Screened | None = None


@dataclass
class Search:
    """The whole search: each listed rise's result, the grids by rise (full map)."""

    rises: list = field(default_factory=list)
    grids: dict = field(default_factory=dict)


def search(rises, grid: Grid, screen: Screen, *, rise_step: float = 0.01,
           log=lambda s: None) -> Search:
    """The family at each rise of ``rises`` [m]: the grid by continuation from the level gait
    (rise steps of at most ``rise_step`` m), the stable gaits, the screened choice."""
    listed = {round(r, 9) for r in rises}
    out = Search()

    def at(r: float, previous: dict | None) -> dict:
        full = round(r, 9) in listed
        space = family_space(r, full_map=full)
        began = time.perf_counter()
        solved = (seed_grid(space, grid, level_gait(space), branches=full) if previous is None
                  else continue_grid(space, grid, previous, branches=full))
        what = ""
        if full:
            out.grids[round(r, 9)] = solved
            chosen, n_stable = choose(space, solved, screen)
            out.rises.append(RiseResult(r, len(solved), n_stable, chosen))
            what = f", {n_stable} with a stable gait; full map, branches and screen"
        log(f"# rise {r:+.3f} m: {len(solved)} cells converged "
            f"({time.perf_counter() - began:.0f} s{what})")
        return solved

    base = at(0.0, None)
    up, down = rise_path(rises, rise_step)
    for leg in (up, down):
        prev = base
        for r in leg:
            prev = at(r, prev)
    out.rises.sort(key=lambda x: x.rise)
    return out


def steepest(holds, rise: float, state, step: float, to: float) -> tuple[float, float]:
    """The steepest rise at which ``holds(r, state)`` finds what it looks for: from ``rise``
    (where it does, ``state`` there), up in steps of ``step`` [m] to the first rise where it
    does not, then bisected to ``to`` [m]. ``holds`` returns the state at ``r`` to continue
    from (None: it does not hold there); each trial continues from the steepest rise below
    it that holds. Returns ``(steepest rise that holds, least rise above it that does not)``
    [m], rounded to 1e-9 m."""
    lo, hi = round(rise, 9), None
    while hi is None:
        r = round(lo + step, 9)
        found = holds(r, state)
        if found is None:
            hi = r
        else:
            lo, state = r, found
    while hi - lo > to + 1e-12:
        mid = round(0.5 * (lo + hi), 9)
        found = holds(mid, state)
        if found is None:
            hi = mid
        else:
            lo, state = mid, found
    return lo, hi


def steepest_stable(grid: Grid, solved: dict, rise: float, step: float, to: float,
                    *, log=lambda s: None) -> tuple[float, float]:
    """The steepest rise at which the family has a stable gait on the grid (:func:`steepest`
    from ``solved``, the grid at ``rise``, which has one; each trial's grid by continuation,
    :func:`continue_grid`)."""
    def stable_at(r: float, prev: dict) -> dict | None:
        s = continue_grid(family_space(r), grid, prev, branches=True)
        n = stable_cells(s)
        log(f"# climb {r:+.4f} m: {len(s)} converged, {n} stable")
        return s if n else None
    return steepest(stable_at, rise, solved, step, to)


def atlas_entry(r: float, g: Gait) -> dict:
    """The atlas step's entry of the gait ``g`` at rise ``r``: its name, start (the fixed
    point) and gait block (section theta2: the fixed point's, to 1e-3 rad)."""
    t1, t2, d = g.cell
    return {"name": f"rise_{r:+.2f}".replace("+", ""),
            "start": [float(v) for v in g.z],
            "gait": gait_block(r, t1, t2, d, round(float(g.z[0]), 3))}


def flow(v) -> str:
    """A value as a YAML flow node (repr floats: they read back exactly)."""
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k}: {flow(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(flow(x) for x in v) + "]"
    if isinstance(v, float):
        return repr(v)
    return str(v)


def entries_yaml(entries: list[dict]) -> str:
    """Atlas entries as the ``gaits:`` list of an atlas step (indented for it)."""
    lines = []
    for e in entries:
        g = e["gait"]
        lines += [f"      - name: {e['name']}", f"        start: {flow(e['start'])}",
                  "        gait:", f"          kind: {g['kind']}",
                  f"          torque_frame: {g['torque_frame']}"]
        if "rise" in g:
            lines.append(f"          rise: {g['rise']!r}")
        lines += [f"          section: {flow(g['section'])}", "          segments:"]
        lines += [f"            - {flow(s)}" for s in g["segments"]]
    return "\n".join(lines) + "\n"


def row_text(res: RiseResult) -> str:
    """One rise's line of the table."""
    c = res.chosen
    if c is None:
        return (f"{res.rise:+6.2f}  no stable gait ({res.converged} converged, "
                f"{res.stable} stable)")
    g = c.gait
    t1, t2, d = g.cell
    start = ", ".join(f"{v:.6f}" for v in g.z)
    return (f"{res.rise:+6.2f}  {t1:+.4f}  {t2:+.4f}  {d:.3f}  {g.z[0]:+.4f}  "
            f"[{start}]  {g.rho:.7f}  {c.lasted:3d}/{c.runs}  {c.mean_steps:6.1f}"
            f"   ({res.stable} stable)")


HEADER = ("  rise      T1       T2       D    theta2   start [theta2, dtheta1, dtheta2]"
          "          rho   lasted  mean steps")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("--rises", type=float, nargs="+", default=list(DEFAULT_RISES),
                    help="rises per step to search [m] (default: %(default)s)")
    ap.add_argument("--grid", type=int, default=7, help="values per axis of (T1, T2, D)")
    ap.add_argument("--rise-step", type=float, default=0.01,
                    help="largest rise step of the continuation [m]")
    ap.add_argument("--candidates", type=int, default=8, help="gaits screened per rise")
    ap.add_argument("--runs", type=int, default=100, help="survival runs per candidate")
    ap.add_argument("--steps", type=int, default=300, help="steps per survival run")
    ap.add_argument("--seed", type=int, default=30, help="the noise's seed")
    ap.add_argument("--height-tolerance", type=float, default=0.02,
                    help="a run lasts within this of the staircase [m]")
    ap.add_argument("--keep", type=int, default=90,
                    help="runs that must last for the steepest lasting climb")
    ap.add_argument("--bisect-to", type=float, default=0.005,
                    help="resolution of the steepest stable climb [m]")
    ap.add_argument("--no-bisect", action="store_true",
                    help="skip the search for the steepest stable climb")
    ap.add_argument("-o", "--output", type=Path, help="write the chosen gaits here (YAML)")
    ap.add_argument("--grids", type=Path, help="write every gait of each listed rise's grid "
                    "here (JSON: rise, T1, T2, D, fixed point, rho, problems)")
    a = ap.parse_args(argv)

    def log(s):
        print(s, file=sys.stderr, flush=True)

    grid = Grid.uniform(a.grid)
    screen = Screen(candidates=a.candidates, runs=a.runs, steps=a.steps, seed=a.seed,
                    height_tolerance=a.height_tolerance)
    found = search(a.rises, grid, screen, rise_step=a.rise_step, log=log)
    print(HEADER)
    for res in found.rises:
        print(row_text(res), flush=True)
    stable_rises = [res.rise for res in found.rises if res.stable]
    if stable_rises and not a.no_bisect:
        top = max(stable_rises)
        lo, hi = steepest_stable(grid, found.grids[round(top, 9)], top, a.rise_step,
                                 a.bisect_to, log=log)
        print(f"steepest climb with a stable gait on the grid: {lo:+.4f} m "
              f"(none at {hi:+.4f} m)")
    lasting = [res.rise for res in found.rises
               if res.chosen is not None and res.chosen.lasted >= a.keep]
    print(f"steepest climb whose chosen gait lasts in >= {a.keep} of {a.runs} runs: "
          + (f"{max(lasting):+.2f} m" if lasting else "none"))
    if a.grids:
        a.grids.parent.mkdir(parents=True, exist_ok=True)
        a.grids.write_text(json.dumps([
            {"rise": r, "cell": list(g.cell), "z": [float(v) for v in g.z], "rho": g.rho,
             "problems": g.problems}
            for r, solved in sorted(found.grids.items()) for gs in solved.values()
            for g in gs]))
    if a.output:
        entries = [atlas_entry(res.rise, res.chosen.gait) for res in found.rises
                   if res.chosen is not None]
        a.output.parent.mkdir(parents=True, exist_ok=True)
        a.output.write_text(entries_yaml(entries))
    return 0


if __name__ == "__main__":
    sys.exit(main())
