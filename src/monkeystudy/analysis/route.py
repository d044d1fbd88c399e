"""A route over a wall from an atlas of gaits: which gait to step with, catch by catch, from the
start to the goal (docs/route.md).

* :class:`AtlasGait` - one gait as the planner sees it: per step the attached magnet's advance
  ``dx`` and rise ``dy`` [m], the step's duration [s] and energy [J], its failure probability
  with an upper confidence bound, which end it starts from and whether the magnets swap;
  :meth:`AtlasGait.mirrored` is the same gait walked the other way.
* :class:`Transition` - a switch from one gait to another between two steps, with its own
  failure probability and extra time and energy; a switch the atlas lists no transition for
  is not allowed (a gait followed by itself always is: its cycle closes on its own section;
  a switch step, ``repeats=False``, never follows itself nor starts from rest).
* :func:`plan_route` - the least-cost route (A* over a lattice graph, networkx), as a
  :class:`Route`: the steps and their catch points, the expected time and energy, the
  probability of arriving and its lower bound; :func:`replan` - the same from any sensed
  position; :func:`route_graph` - the graph itself.
* :func:`step_failure` - a gait's per-step failure probability and its bound from survival
  runs (:mod:`monkeystudy.analysis.survival`).

The graph
---------
A node is ``(i, j, gait, end)``: the attached magnet at the lattice point ``start +
resolution * (i, j)`` [m], the gait of the step that put it there (``-1``: none yet, the robot
hanging at the start) and the attached end. An edge is one step of a gait from the node's
point: the magnet lands at the point plus the gait's ``(dx, dy)`` rounded to the lattice
(within ``resolution / 2`` in x and in y), and the edge exists when that catch holds on the
wall (:meth:`monkeystudy.wall.Wall.can_catch`) and the switch from the node's gait is
allowed. The rounding adds up along a route: its ``n``-th catch is within ``n * resolution /
2`` in x and in y of the start plus the gaits' exact steps (``Route.drift_bound``); a walked
route replans from the sensed position (:func:`replan`), which starts the count again.
Every node's point is a catch on steel, so the graph lies in the wall's extent, a box of
finitely many lattice points: the search terminates.

Cost of an edge: the step's duration (``cost="time"``) or energy (``"energy"``) plus its
transition's extra, plus ``risk_weight * (-log(1 - p))`` with ``p`` the step's failure
probability, its transition's included (``-log`` of the probability of surviving the step,
which adds along the route as the survivals multiply). ``risk_from="bound"`` takes the upper
bounds instead of the estimates.

The heuristic
-------------
``h(node) = k * d``, with ``d`` the node's distance from the goal's disc [m] and ``k`` the
least cost per metre any gait's step can make: ``k = min over gaits of c_g / (|(dx, dy)_g| +
resolution / sqrt 2)``, ``c_g`` the step's cost without a transition (transitions add only
non-negative extras). A step moves the magnet by at most ``|(dx, dy)| + resolution / sqrt 2``
(the snap) and ``d`` changes by at most the distance moved, so ``h`` never exceeds the cost of
any route to the goal and never drops by more than an edge's cost: admissible and consistent,
and A* returns a least-cost route, as Dijkstra does (``algorithm="dijkstra"``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Iterable, Literal, Sequence

import networkx as nx
import numpy as np

from ..wall import END_NAMES, Goal, Start, Wall, end_name

#: how a mirrored gait's name ends (:meth:`AtlasGait.mirrored`)
MIRRORED = " (mirrored)"

#: the graph's node for "arrived": every node whose catch lies in the goal's disc leads to it
GOAL = "goal"

#: no gait yet: the robot hangs at the start
AT_REST = -1

#: confidence of :func:`step_failure`'s upper bound (one-sided)
BOUND_CONFIDENCE = 0.975


def _probability(value: float, what: str, upper: float = 1.0) -> float:
    p = float(value)
    if not (math.isfinite(p) and 0.0 <= p < upper):
        raise ValueError(f"{what} must be in [0, {upper:g}), got {value!r}")
    return p


def _nonnegative(value: float, what: str) -> float:
    v = float(value)
    if not (math.isfinite(v) and v >= 0.0):
        raise ValueError(f"{what} must be >= 0 and finite, got {value!r}")
    return v


@dataclass(frozen=True)
class AtlasGait:
    """One gait of the atlas, per step.

    Parameters
    ----------
    name : str
        Its name (unique in the atlas).
    dx, dy : float
        The attached magnet's advance along the wall (world x, signed) and rise [m] over one
        step: the new attached magnet catches there, relative to the old one.
    duration : float
        The step's duration [s] (> 0).
    energy : float
        The energy the motor spends in one step [J] (>= 0).
    p_fail : float
        Probability that a step fails, in [0, 1).
    p_fail_upper : float
        Its upper confidence bound, in [p_fail, 1) (:func:`step_failure`).
    attached : {"A", "B"} or None
        The end the step starts from; None: either (a mirror-symmetric robot's gait is the
        same gait from either magnet).
    swaps : bool
        The magnets swap: after the step the other end is attached (a brachiation step).
    repeats : bool
        The step may follow itself (a gait's cycle, from its own fixed point). False: a
        switch step, designed to take the robot from one gait to another, which runs once,
        after a gait a :class:`Transition` names and never first from rest.
    survival : sequence of float
        The gait's survival curve ``S(n)``, ``n = 0, 1, ...``: the fraction of its survival
        runs (from its fixed point) that completed at least ``n`` steps (``S(0) = 1``,
        non-increasing); empty when not measured (:meth:`run_survival`).
    """

    name: str
    dx: float
    dy: float
    duration: float
    energy: float
    p_fail: float
    p_fail_upper: float
    attached: str | None = None
    swaps: bool = True
    repeats: bool = True
    survival: tuple = ()

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"a gait's name must be non-empty text, got {self.name!r}")
        for key in ("dx", "dy"):
            v = float(getattr(self, key))
            if not math.isfinite(v):
                raise ValueError(f"gait {self.name!r}: {key} must be finite, got {v!r}")
            object.__setattr__(self, key, v)
        if self.dx == 0.0 and self.dy == 0.0:
            raise ValueError(f"gait {self.name!r}: a step must move the magnet (dx = dy = 0)")
        duration = float(self.duration)
        if not (math.isfinite(duration) and duration > 0.0):
            raise ValueError(f"gait {self.name!r}: duration must be > 0 [s], got "
                             f"{self.duration!r}")
        object.__setattr__(self, "duration", duration)
        object.__setattr__(self, "energy",
                           _nonnegative(self.energy, f"gait {self.name!r}: energy [J]"))
        p = _probability(self.p_fail, f"gait {self.name!r}: p_fail")
        object.__setattr__(self, "p_fail", p)
        up = _probability(self.p_fail_upper, f"gait {self.name!r}: p_fail_upper")
        if up < p:
            raise ValueError(f"gait {self.name!r}: p_fail_upper ({up!r}) is below p_fail "
                             f"({p!r})")
        object.__setattr__(self, "p_fail_upper", up)
        if self.attached is not None:
            end_name(self.attached)
        curve = tuple(float(v) for v in self.survival)
        if curve and not (curve[0] == 1.0 and all(0.0 <= v <= 1.0 for v in curve)
                          and all(b <= a for a, b in zip(curve, curve[1:]))):
            raise ValueError(f"gait {self.name!r}: survival must start at 1 and never rise, "
                             f"each in [0, 1]")
        object.__setattr__(self, "survival", curve)

    def run_survival(self, steps: int) -> float:
        """Probability that ``steps`` consecutive steps of the gait all succeed: ``S(steps)``
        of its survival curve, beyond the curve its last value times ``1 - p_fail`` per
        further step; without a curve ``(1 - p_fail) ** steps`` (a constant hazard)."""
        if steps < 0:
            raise ValueError(f"steps must be >= 0, got {steps!r}")
        if not self.survival:
            return (1.0 - self.p_fail) ** steps
        last = len(self.survival) - 1
        if steps <= last:
            return self.survival[steps]
        return self.survival[last] * (1.0 - self.p_fail) ** (steps - last)

    def starts_from(self, end: str) -> bool:
        """Whether a step may start with ``end`` attached."""
        return self.attached is None or self.attached == end

    def end_after(self, end: str) -> str:
        """The end attached after a step that started with ``end`` attached."""
        return END_NAMES[1 - END_NAMES.index(end)] if self.swaps else end

    def mirrored(self) -> "AtlasGait":
        """The same gait walked the other way: the robot's motion mirrored in a vertical
        line (``dx`` negated; the same end attached, the same duration, energy and failure
        probabilities)."""
        return replace(self, name=mirrored_name(self.name), dx=-self.dx)


def mirrored_name(name: str) -> str:
    """The name of the mirrored gait of ``name`` (a mirrored name back to the original)."""
    return name[:-len(MIRRORED)] if name.endswith(MIRRORED) else name + MIRRORED


@dataclass(frozen=True)
class Transition:
    """A switch from ``from_gait`` to ``to_gait`` between two steps (by name).

    Parameters
    ----------
    p_fail, p_fail_upper : float
        Probability that the switch fails and its upper bound (default: ``p_fail``), on top
        of the next step's own.
    extra_time : float
        Time the switch adds to the next step [s] (>= 0).
    extra_energy : float
        Energy it adds [J] (>= 0).
    """

    from_gait: str
    to_gait: str
    p_fail: float = 0.0
    p_fail_upper: float | None = None
    extra_time: float = 0.0
    extra_energy: float = 0.0

    def __post_init__(self) -> None:
        what = f"transition {self.from_gait!r} -> {self.to_gait!r}"
        if self.from_gait == self.to_gait:
            raise ValueError(f"{what}: a gait followed by itself needs no transition")
        p = _probability(self.p_fail, f"{what}: p_fail")
        up = p if self.p_fail_upper is None else \
            _probability(self.p_fail_upper, f"{what}: p_fail_upper")
        if up < p:
            raise ValueError(f"{what}: p_fail_upper ({up!r}) is below p_fail ({p!r})")
        object.__setattr__(self, "p_fail", p)
        object.__setattr__(self, "p_fail_upper", up)
        object.__setattr__(self, "extra_time", _nonnegative(self.extra_time,
                                                            f"{what}: extra_time [s]"))
        object.__setattr__(self, "extra_energy", _nonnegative(self.extra_energy,
                                                              f"{what}: extra_energy [J]"))

    def mirrored(self) -> "Transition":
        """The same switch between the mirrored gaits."""
        return replace(self, from_gait=mirrored_name(self.from_gait),
                       to_gait=mirrored_name(self.to_gait))


def step_failure(cycles, failed, max_cycles: int) -> tuple[float, float]:
    """A gait's per-step failure probability and its one-sided 97.5 % upper bound
    (:data:`BOUND_CONFIDENCE`) from survival runs: run ``k`` completed ``cycles[k]`` steps and
    then failed (``failed[k]``) or was stopped at ``max_cycles`` (censored).

    The steps are taken to fail independently with one probability ``p`` (a constant hazard,
    the tail model of :func:`~monkeystudy.analysis.survival.mfpt`): the estimate is failures
    per step attempted (:func:`~monkeystudy.analysis.survival.hazard` over the whole window)
    and the bound the Clopper-Pearson bound of that binomial count; with no failure in ``n``
    steps it is ``1 - 0.025^(1/n)``, about ``3.7 / n``. Runs of different builds that fail at
    different rates make the bound optimistic for the worst build.
    """
    # scipy's beta and the survival module (which loads the kernels) only when converting
    from scipy.stats import beta
    from .survival import hazard

    failures, attempted = hazard(cycles, failed, 0, int(max_cycles))
    if attempted == 0:
        raise ValueError("no step was attempted: the runs give no failure probability")
    upper = float(beta.ppf(BOUND_CONFIDENCE, failures + 1, attempted - failures)) \
        if failures < attempted else 1.0
    return failures / attempted, upper


@dataclass(frozen=True)
class RouteStep:
    """One step of a route.

    ``gait`` stepped with ``attached`` holding; the free magnet catches at ``catch`` [m] (a
    lattice point), after which ``attached_after`` holds. ``time`` [s], ``energy`` [J],
    ``p_fail`` and ``p_fail_upper`` are the step's with the transition before it
    (``transition``: the gait differs from the previous step's) included.
    """

    gait: str
    attached: str
    catch: tuple[float, float]
    attached_after: str
    time: float
    energy: float
    p_fail: float
    p_fail_upper: float
    transition: bool


@dataclass(frozen=True)
class Route:
    """A planned route: its steps from ``start`` to a catch in ``goal``'s disc.

    ``cost`` names the objective (``time`` or ``energy``) and ``total_cost`` its least value
    with the risk term (module docstring); ``resolution`` [m] is the lattice's spacing.

    ``p_arrive_survival`` is the probability of arriving from the gaits' survival curves
    (:meth:`AtlasGait.run_survival`, set by :func:`route_of`): each run of consecutive steps
    of one gait survives as that many steps of the gait's survival runs did, each switch
    with its transition's ``1 - p_fail``. A build that cannot walk a gait fails early in
    it, and the curve counts that failure where it happens; the constant hazard of
    :attr:`p_arrive` spreads it over every step and overrates a short route. Runs of
    different gaits are taken as independent (builds that fail one gait may fail another).
    """

    start: Start
    goal: Goal
    steps: tuple[RouteStep, ...]
    cost: str
    risk_weight: float
    total_cost: float
    resolution: float
    p_arrive_survival: float = math.nan

    @property
    def catches(self) -> np.ndarray:
        """The catch points (steps, 2) [m]."""
        return np.array([s.catch for s in self.steps], dtype=float).reshape(-1, 2)

    @property
    def drift_bound(self) -> float:
        """How far the last catch may lie from the start plus the gaits' exact steps [m],
        in x and in y: ``steps * resolution / 2`` (the lattice's rounding)."""
        return 0.5 * self.resolution * len(self.steps)

    @property
    def expected_time(self) -> float:
        """The route's time if it arrives [s]: the steps' mean durations and the
        transitions' extras."""
        return float(sum(s.time for s in self.steps))

    @property
    def expected_energy(self) -> float:
        """The route's energy if it arrives [J]."""
        return float(sum(s.energy for s in self.steps))

    @property
    def p_arrive(self) -> float:
        """Probability of arriving: the product of the steps' survivals ``1 - p_fail``."""
        return float(np.prod([1.0 - s.p_fail for s in self.steps]))

    @property
    def p_arrive_low(self) -> float:
        """Its lower bound: the product of ``1 - p_fail_upper``. Each gait's bound holds at
        its own confidence; the product holds at ``1 - sum of (1 - confidence)`` over the
        distinct gaits and transitions of the route at least."""
        return float(np.prod([1.0 - s.p_fail_upper for s in self.steps]))


class NoRoute(ValueError):
    """No route reaches the goal; ``nearest`` [m] is the reachable catch nearest the goal's
    centre, ``distance`` [m] its distance from there, ``reachable`` the number of catch points
    reachable."""

    def __init__(self, goal: Goal, nearest: tuple[float, float], reachable: int):
        self.nearest = nearest
        self.distance = float(math.hypot(nearest[0] - goal.position[0],
                                         nearest[1] - goal.position[1]))
        self.reachable = reachable
        gx, gy = goal.position
        super().__init__(
            f"no route reaches the goal ({gx:g}, {gy:g}) m (radius {goal.radius:g} m): the "
            f"nearest reachable catch is ({nearest[0]:.4g}, {nearest[1]:.4g}) m, "
            f"{self.distance:.4g} m from the goal's centre (of {reachable} catch point"
            f"{'' if reachable == 1 else 's'} reachable on steel with the margin)")


@dataclass
class RouteGraph:
    """The search graph of a wall and an atlas (:func:`route_graph`).

    ``graph``: a networkx ``DiGraph`` whose nodes are ``(i, j, gait, end)`` and :data:`GOAL`,
    each edge with its ``weight`` (the cost); ``start``: the start node; ``gaits``: the gaits by
    index (the mirrored ones after the atlas's); ``transitions`` by ``(from, to)`` index;
    ``origin`` [m] and ``resolution`` [m]: node ``(i, j, ...)`` is at ``origin + resolution *
    (i, j)``; ``per_metre``: the heuristic's least cost per metre, ``k``.
    """

    graph: nx.DiGraph
    start: tuple
    goal: Goal
    gaits: tuple[AtlasGait, ...]
    transitions: dict[tuple[int, int], Transition]
    origin: np.ndarray
    resolution: float
    per_metre: float
    cost: str
    risk_weight: float
    _goal_distance: dict = field(default_factory=dict, repr=False)

    def position(self, node) -> tuple[float, float]:
        """The catch point of ``node`` [m]."""
        return (float(self.origin[0] + self.resolution * node[0]),
                float(self.origin[1] + self.resolution * node[1]))

    def heuristic(self, node, target=GOAL) -> float:
        """A lower bound of the cost from ``node`` to the goal (module docstring)."""
        if node == GOAL:
            return 0.0
        return self.per_metre * self._goal_distance[node[:2]]


def _atlas(atlas: Iterable[AtlasGait], transitions: Iterable[Transition], mirror: bool):
    gaits = list(atlas)
    if not gaits:
        raise ValueError("the atlas has no gait")
    moves = list(transitions)
    if mirror:
        gaits += [g.mirrored() for g in gaits if g.dx != 0.0]
        mirror_of = {g.name for g in gaits}
        moves += [t.mirrored() for t in moves
                  if mirrored_name(t.from_gait) in mirror_of and
                  mirrored_name(t.to_gait) in mirror_of]
    index: dict[str, int] = {}
    for k, g in enumerate(gaits):
        if g.name in index:
            raise ValueError(f"two gaits of the atlas are named {g.name!r}")
        index[g.name] = k
    by_pair: dict[tuple[int, int], Transition] = {}
    for t in moves:
        for name in (t.from_gait, t.to_gait):
            if name not in index:
                raise ValueError(f"transition {t.from_gait!r} -> {t.to_gait!r}: no gait "
                                 f"named {name!r} in the atlas")
        by_pair.setdefault((index[t.from_gait], index[t.to_gait]), t)
    return tuple(gaits), index, by_pair


def route_graph(wall: Wall, atlas: Sequence[AtlasGait], transitions: Sequence[Transition] = (),
                *, cost: Literal["time", "energy"] = "time", risk_weight: float = 0.0,
                risk_from: Literal["estimate", "bound"] = "estimate",
                resolution: float = 0.001, mirror: bool = True, start_gait: str | None = None,
                max_nodes: int = 2_000_000) -> RouteGraph:
    """Every node reachable from the wall's start, and the edges between them (module
    docstring; the parameters are :func:`plan_route`'s)."""
    if cost not in ("time", "energy"):
        raise ValueError(f"cost must be 'time' or 'energy', got {cost!r}")
    if risk_from not in ("estimate", "bound"):
        raise ValueError(f"risk_from must be 'estimate' or 'bound', got {risk_from!r}")
    risk_weight = _nonnegative(risk_weight, "risk_weight")
    res = float(resolution)
    if not (math.isfinite(res) and res > 0.0):
        raise ValueError(f"resolution must be > 0 [m], got {resolution!r}")
    gaits, index, moves = _atlas(atlas, transitions, mirror)
    if start_gait is not None and start_gait not in index:
        raise ValueError(f"start gait {start_gait!r} is not in the atlas (gaits: "
                         f"{', '.join(index)})")

    def risk(p: float) -> float:
        return risk_weight * -math.log1p(-p) if risk_weight else 0.0

    def p_of(item) -> float:
        return item.p_fail if risk_from == "estimate" else item.p_fail_upper

    base = [(g.duration if cost == "time" else g.energy) + risk(p_of(g)) for g in gaits]
    extra = {pair: (t.extra_time if cost == "time" else t.extra_energy) for pair, t in
             moves.items()}
    step = np.array([[g.dx, g.dy] for g in gaits])
    # each gait's step on the lattice: within res / 2 of (dx, dy) in x and in y
    step_cells = np.rint(step / res).astype(np.int64)
    reach = np.hypot(step[:, 0], step[:, 1]) + res / math.sqrt(2.0)
    per_metre = float(min(c / r for c, r in zip(base, reach)))

    origin = np.array(wall.start.position, dtype=float)
    x0, y0, x1, y1 = wall.extent
    # the lattice's box: every catch lies in the wall's extent
    lo = np.floor((np.array([x0, y0]) - origin) / res).astype(np.int64)
    hi = np.ceil((np.array([x1, y1]) - origin) / res).astype(np.int64)
    holds: dict[tuple[int, int], bool] = {}
    rg = RouteGraph(nx.DiGraph(), (0, 0, AT_REST if start_gait is None else index[start_gait],
                                   wall.start.attached),
                    wall.goal, gaits, moves, origin, res, per_metre, cost, risk_weight)
    graph, goal_distance = rg.graph, rg._goal_distance

    def visit(cells: list[tuple[int, int]]) -> None:
        """Record the goal distance of the cells first seen."""
        new = [c for c in cells if c not in goal_distance]
        if new:
            pts = origin + res * np.array(new, dtype=float)
            for c, d in zip(new, wall.goal.distance(pts)):
                goal_distance[c] = float(d)

    graph.add_node(rg.start)
    visit([rg.start[:2]])
    frontier = [rg.start]
    while frontier:
        cells = sorted({n[:2] for n in frontier})
        land = np.array(cells, dtype=np.int64)[:, None, :] + step_cells[None, :, :]
        inside = np.all((land >= lo) & (land <= hi), axis=2)
        todo = sorted({tuple(c) for c in land[inside].tolist()} - holds.keys())
        if todo:
            ok = wall.can_catch(origin + res * np.array(todo, dtype=float))
            holds.update(zip(todo, ok.tolist()))
        landing = {cell: land[k] for k, cell in enumerate(cells)}
        nxt = []
        for node in frontier:
            i, j, g, end = node
            targets = landing[(i, j)]
            for h, gait in enumerate(gaits):
                if not gait.starts_from(end):
                    continue
                if not gait.repeats and (g == AT_REST or g == h):
                    continue     # a switch step runs once, from the gait it leaves
                switch = g != AT_REST and g != h
                if switch and (g, h) not in moves:
                    continue
                cell = (int(targets[h, 0]), int(targets[h, 1]))
                if not holds.get(cell, False):
                    continue
                weight = base[h]
                if switch:
                    weight += extra[(g, h)] + risk(p_of(moves[(g, h)]))
                target = (cell[0], cell[1], h, gait.end_after(end))
                if target not in graph:
                    nxt.append(target)
                graph.add_edge(node, target, weight=weight)
        if graph.number_of_nodes() > max_nodes:
            raise ValueError(f"the route graph passed {max_nodes} nodes: plan on a coarser "
                             f"resolution than {res:g} m or a smaller wall")
        visit([n[:2] for n in nxt])
        frontier = nxt
    graph.add_node(GOAL)
    for node in list(graph.nodes):
        if node != GOAL and goal_distance[node[:2]] == 0.0:
            graph.add_edge(node, GOAL, weight=0.0)
    return rg


def plan_route(wall: Wall, atlas: Sequence[AtlasGait], transitions: Sequence[Transition] = (),
               *, cost: Literal["time", "energy"] = "time", risk_weight: float = 0.0,
               risk_from: Literal["estimate", "bound"] = "estimate", resolution: float = 0.001,
               mirror: bool = True, start_gait: str | None = None,
               algorithm: Literal["astar", "dijkstra"] = "astar",
               max_nodes: int = 2_000_000) -> Route:
    """The least-cost route over ``wall`` from its start to its goal with the gaits of
    ``atlas``.

    Parameters
    ----------
    wall : Wall
        The steel, the start (the attached magnet and its end) and the goal.
    atlas : sequence of AtlasGait
        The gaits (each walked either way when ``mirror``).
    transitions : sequence of Transition
        The allowed switches between different gaits (mirrored too when ``mirror``).
    cost : {"time", "energy"}
        What a step costs: its duration [s] or its energy [J] (plus its transition's extra).
    risk_weight : float
        Cost per unit of ``-log(1 - p_fail)`` [s or J]: 0 ignores the risk; larger values
        trade time or energy for the probability of arriving.
    risk_from : {"estimate", "bound"}
        Which failure probability the risk term reads.
    resolution : float
        Spacing of the catch lattice [m], anchored at the start.
    mirror : bool
        Add each gait's mirror image (the robot walking the other way).
    start_gait : str, optional
        The gait the robot is walking (its first step is that gait or an allowed switch from
        it); None: it hangs at rest and may start with any gait.
    algorithm : {"astar", "dijkstra"}
        networkx's A* with the heuristic of the module docstring, or Dijkstra.
    max_nodes : int
        Refuse a graph larger than this (a resolution too fine for the wall).

    Raises
    ------
    NoRoute
        No route reaches the goal: the message names the nearest reachable catch.
    """
    rg = route_graph(wall, atlas, transitions, cost=cost, risk_weight=risk_weight,
                     risk_from=risk_from, resolution=resolution, mirror=mirror,
                     start_gait=start_gait, max_nodes=max_nodes)
    return route_of(rg, wall.start, algorithm)


def route_of(rg: RouteGraph, start: Start, algorithm: str = "astar") -> Route:
    """The least-cost route of a :func:`route_graph` (``start``: the wall's start)."""
    if algorithm not in ("astar", "dijkstra"):
        raise ValueError(f"algorithm must be 'astar' or 'dijkstra', got {algorithm!r}")
    try:
        if algorithm == "astar":
            path = nx.astar_path(rg.graph, rg.start, GOAL, heuristic=rg.heuristic)
        else:
            path = nx.dijkstra_path(rg.graph, rg.start, GOAL)
    except nx.NetworkXNoPath:
        nodes = [n for n in rg.graph.nodes if n != GOAL]
        cells = sorted({n[:2] for n in nodes})
        pts = np.array([rg.position(c) for c in cells])
        gx, gy = rg.goal.position
        k = int(np.argmin(np.hypot(pts[:, 0] - gx, pts[:, 1] - gy)))
        raise NoRoute(rg.goal, (float(pts[k, 0]), float(pts[k, 1])), len(cells)) from None
    steps = []
    total = 0.0
    p_survival, run = 1.0, 0
    for k, (u, v) in enumerate(zip(path[:-2], path[1:-1])):
        gait = rg.gaits[v[2]]
        switch = u[2] != AT_REST and u[2] != v[2]
        t = rg.transitions[(u[2], v[2])] if switch else None
        run += 1
        if k + 2 == len(path) - 1 or path[k + 2][2] != v[2]:
            p_survival *= gait.run_survival(run)      # the end of a run of this gait
            run = 0
        if t is not None:
            p_survival *= 1.0 - t.p_fail
        p = 1.0 - (1.0 - gait.p_fail) * (1.0 - (t.p_fail if t else 0.0))
        p_up = 1.0 - (1.0 - gait.p_fail_upper) * (1.0 - (t.p_fail_upper if t else 0.0))
        steps.append(RouteStep(gait.name, u[3], rg.position(v), v[3],
                               gait.duration + (t.extra_time if t else 0.0),
                               gait.energy + (t.extra_energy if t else 0.0), p, p_up, switch))
        total += rg.graph.edges[u, v]["weight"]
    return Route(start, rg.goal, tuple(steps), rg.cost, rg.risk_weight, total, rg.resolution,
                 p_survival)


def replan(wall: Wall, atlas: Sequence[AtlasGait], transitions: Sequence[Transition] = (), *,
           position: Sequence[float], attached: str, gait: str | None = None,
           **options) -> Route:
    """:func:`plan_route` from a sensed position: the attached magnet at ``position`` [m]
    (any point on steel, not necessarily a catch of an earlier route's lattice; the new
    lattice is anchored there), ``attached`` holding, walking ``gait`` (None: at rest).
    ``options`` are :func:`plan_route`'s."""
    return plan_route(wall.with_start(position, attached), atlas, transitions,
                      start_gait=gait, **options)


__all__ = ["AT_REST", "AtlasGait", "BOUND_CONFIDENCE", "GOAL", "MIRRORED", "NoRoute", "Route",
           "RouteGraph", "RouteStep", "Transition", "mirrored_name", "plan_route", "replan",
           "route_graph", "route_of", "step_failure"]
