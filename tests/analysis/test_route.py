"""The route planner on synthetic atlases: routes go around or over holes, every catch holds
with the margin, A* finds Dijkstra's least cost with an admissible heuristic, P(arrive) is the
product of the steps' survivals, the objectives trade time against energy, switches need a
transition, and a wall without a route says how near the robot gets."""
from __future__ import annotations

import dataclasses
import math

import networkx as nx
import numpy as np
import pytest

from monkeystudy.analysis.route import (
    GOAL, AtlasGait, NoRoute, Transition, plan_route, replan, route_graph, step_failure,
)
from monkeystudy.wall import Goal, Region, Start, Wall

PLATE = [(0.0, 0.0), (6.0, 0.0), (6.0, 3.0), (0.0, 3.0)]
#: a window across the middle of the plate: 1 m wide, from y = 0.6 to 2.4
WINDOW = [(2.5, 0.6), (3.5, 0.6), (3.5, 2.4), (2.5, 2.4)]

WALK = AtlasGait("walk", 0.5, 0.0, duration=1.0, energy=1.0, p_fail=1e-3, p_fail_upper=4e-3)
CLIMB = AtlasGait("climb", 0.3, 0.4, duration=1.2, energy=2.0, p_fail=2e-3, p_fail_upper=6e-3)
DESCEND = AtlasGait("descend", 0.3, -0.4, duration=1.1, energy=0.5, p_fail=3e-3,
                    p_fail_upper=8e-3)
ATLAS = [WALK, CLIMB, DESCEND]
#: every switch allowed, each at a small price
SWITCHES = [Transition(a.name, b.name, p_fail=1e-3, extra_time=0.2, extra_energy=0.1)
            for a in ATLAS for b in ATLAS if a is not b]


def plate_wall(holes=(WINDOW,), start=(0.5, 1.5), goal=(5.5, 1.5), margin=0.05,
               radius=0.2) -> Wall:
    return Wall([Region(PLATE, holes)], Start(start, "A"), Goal(goal, radius), margin)


def in_window(points) -> np.ndarray:
    p = np.asarray(points)
    return (p[:, 0] > 2.5) & (p[:, 0] < 3.5) & (p[:, 1] > 0.6) & (p[:, 1] < 2.4)


def test_a_hole_forces_the_route_around_it():
    """Steps of at most 0.5 m cannot cross the 1 m window: the route leaves the start's
    height to pass it, and every catch holds with the margin."""
    wall = plate_wall()
    route = plan_route(wall, ATLAS, SWITCHES, resolution=0.01)
    catches = route.catches
    assert wall.can_catch(catches).all()
    assert not in_window(catches).any()
    passing = catches[(catches[:, 0] >= 2.5) & (catches[:, 0] <= 3.5)]
    assert len(passing) and np.all((passing[:, 1] <= 0.6 - 0.05) | (passing[:, 1] >= 2.4 + 0.05))
    assert wall.goal.distance(catches[-1])[0] == 0.0
    # without the window the walk goes straight, in less time
    straight = plan_route(plate_wall(holes=()), ATLAS, SWITCHES, resolution=0.01)
    assert {s.gait for s in straight.steps} == {"walk"}
    np.testing.assert_allclose(straight.catches[:, 1], 1.5)
    assert straight.expected_time < route.expected_time


def test_a_long_step_goes_over_the_hole():
    hop = AtlasGait("hop", 1.6, 0.0, duration=1.5, energy=3.0, p_fail=1e-3, p_fail_upper=5e-3)
    wall = plate_wall(goal=(5.6, 1.5))
    switches = SWITCHES + [Transition("walk", "hop", extra_time=0.2),
                           Transition("hop", "walk", extra_time=0.2)]
    route = plan_route(wall, ATLAS + [hop], switches, resolution=0.01)
    assert "hop" in [s.gait for s in route.steps]
    catches = route.catches
    assert wall.can_catch(catches).all() and not in_window(catches).any()
    np.testing.assert_allclose(catches[:, 1], 1.5)         # over it, at the start's height


def test_the_margin_keeps_catches_off_the_edges():
    """A walk along y = 0.03: on steel, but within 5 cm of the bottom edge, so the route
    must first climb away from it."""
    wall = plate_wall(holes=(), start=(0.5, 0.03), goal=(5.5, 0.03), radius=0.45)
    route = plan_route(wall, ATLAS, SWITCHES, resolution=0.01)
    assert wall.can_catch(route.catches).all()
    assert route.catches[:, 1].min() >= 0.05
    loose = plan_route(plate_wall(holes=(), start=(0.5, 0.03), goal=(5.5, 0.03), radius=0.45,
                                  margin=0.0), ATLAS, SWITCHES, resolution=0.01)
    assert {s.gait for s in loose.steps} == {"walk"}


@pytest.mark.parametrize("cost, risk_weight, risk_from", [
    ("time", 0.0, "estimate"), ("energy", 0.0, "estimate"), ("time", 50.0, "bound"),
    ("energy", 20.0, "estimate")])
def test_astar_finds_dijkstras_least_cost(cost, risk_weight, risk_from):
    wall = plate_wall()
    kw = dict(cost=cost, risk_weight=risk_weight, risk_from=risk_from, resolution=0.01)
    a = plan_route(wall, ATLAS, SWITCHES, algorithm="astar", **kw)
    d = plan_route(wall, ATLAS, SWITCHES, algorithm="dijkstra", **kw)
    assert a.total_cost == pytest.approx(d.total_cost, rel=1e-12)
    # the total is the sum of the steps' costs as the route reports them
    per_step = [(s.time if cost == "time" else s.energy)
                + risk_weight * -math.log(1 - (s.p_fail if risk_from == "estimate"
                                               else s.p_fail_upper)) for s in a.steps]
    assert a.total_cost == pytest.approx(sum(per_step), rel=1e-9)


def test_the_heuristic_never_exceeds_the_cost_to_the_goal():
    """Admissible and consistent over every node of the graph: checked against the exact
    cost to go (Dijkstra from the goal on the reversed graph)."""
    rg = route_graph(plate_wall(), ATLAS, SWITCHES, resolution=0.01, risk_weight=10.0)
    assert rg.per_metre > 0
    to_go = nx.single_source_dijkstra_path_length(rg.graph.reverse(copy=False), GOAL)
    assert len(to_go) > 100
    for node, c in to_go.items():
        assert rg.heuristic(node) <= c + 1e-9, node
    for u, v, w in rg.graph.edges(data="weight"):
        assert rg.heuristic(u) <= w + rg.heuristic(v) + 1e-9, (u, v)


def test_p_arrive_is_the_product_of_the_steps_survivals():
    route = plan_route(plate_wall(), ATLAS, SWITCHES, resolution=0.01)
    gaits = {g.name: g for g in ATLAS}
    want, low = 1.0, 1.0
    previous = None
    for s in route.steps:
        base = gaits[s.gait.replace(" (mirrored)", "")]
        want *= 1 - base.p_fail
        low *= 1 - base.p_fail_upper
        if previous is not None and s.gait != previous:
            want *= 1 - 1e-3                         # the switch's own failure probability
            low *= 1 - 1e-3
        previous = s.gait
    assert route.p_arrive == pytest.approx(want, rel=1e-12)
    assert route.p_arrive_low == pytest.approx(low, rel=1e-12)
    assert 0 < route.p_arrive_low < route.p_arrive < 1
    # no survival curve: each gait's runs fall back on its constant rate, the same number
    assert route.p_arrive_survival == pytest.approx(route.p_arrive, rel=1e-12)
    switches = sum(s.transition for s in route.steps)
    assert switches >= 2
    assert route.expected_time == pytest.approx(
        sum(gaits[s.gait].duration for s in route.steps) + 0.2 * switches)


def test_time_and_energy_pick_different_routes():
    """A fast stride (1 m per s at 5 J) against a thrifty one (0.5 m per s at 1 J)."""
    fast = AtlasGait("fast", 1.0, 0.0, duration=1.0, energy=5.0, p_fail=0.0, p_fail_upper=1e-3)
    thrifty = AtlasGait("thrifty", 0.5, 0.0, duration=1.0, energy=1.0, p_fail=0.0,
                        p_fail_upper=1e-3)
    wall = plate_wall(holes=(), goal=(4.5, 1.5), radius=0.05)
    quick = plan_route(wall, [fast, thrifty], cost="time", resolution=0.01)
    cheap = plan_route(wall, [fast, thrifty], cost="energy", resolution=0.01)
    assert [s.gait for s in quick.steps] == ["fast"] * 4
    assert [s.gait for s in cheap.steps] == ["thrifty"] * 8
    assert quick.expected_time == 4.0 and cheap.expected_time == 8.0
    assert quick.expected_energy == 20.0 and cheap.expected_energy == 8.0


def test_the_risk_weight_trades_time_for_survival():
    fast = AtlasGait("fast", 1.0, 0.0, duration=1.0, energy=1.0, p_fail=0.05,
                     p_fail_upper=0.1)
    safe = AtlasGait("safe", 0.5, 0.0, duration=1.0, energy=1.0, p_fail=1e-4,
                     p_fail_upper=1e-3)
    wall = plate_wall(holes=(), goal=(4.5, 1.5), radius=0.05)
    bold = plan_route(wall, [fast, safe], resolution=0.01)
    careful = plan_route(wall, [fast, safe], resolution=0.01, risk_weight=100.0)
    assert {s.gait for s in bold.steps} == {"fast"}
    assert {s.gait for s in careful.steps} == {"safe"}
    assert careful.p_arrive > bold.p_arrive


def test_a_switch_without_a_transition_is_not_allowed():
    """With no transitions, a route keeps the gait it starts with: climbing reaches the goal
    up and to the right, walking alone cannot."""
    wall = plate_wall(start=(0.5, 0.3), goal=(2.3, 2.7), radius=0.1)
    route = plan_route(wall, ATLAS, [], resolution=0.01)
    assert [s.gait for s in route.steps] == ["climb"] * 6
    assert not any(s.transition for s in route.steps)
    with pytest.raises(NoRoute):
        plan_route(wall, ATLAS, [], resolution=0.01, start_gait="walk")


def test_a_wall_without_a_route_names_the_nearest_reachable_catch():
    """The goal is on a second plate 1 m away: the 0.5 m walk gets no nearer than the last
    lattice point of the first plate that it reaches."""
    near = Region([(0, 0), (3, 0), (3, 3), (0, 3)])
    far = Region([(4, 0), (7, 0), (7, 3), (4, 3)])
    wall = Wall([near, far], Start((0.5, 1.5), "A"), Goal((6.0, 1.5), 0.2), 0.05)
    with pytest.raises(NoRoute) as info:
        plan_route(wall, [WALK], resolution=0.01)
    err = info.value
    assert err.nearest == pytest.approx((2.5, 1.5))
    assert err.distance == pytest.approx(3.5)
    assert err.reachable == 5         # 0.5 .. 2.5 m (0 m is within the margin of the edge)
    assert "nearest reachable catch is (2.5, 1.5) m, 3.5 m from the goal's centre" in str(err)


def test_replan_starts_from_any_sensed_point():
    """A position off the first route's lattice: the new route's first catch is that point
    plus the gait's step, rounded to the new lattice."""
    wall = plate_wall(holes=())
    sensed = (1.2345, 1.4871)
    route = replan(wall, ATLAS, SWITCHES, position=sensed, attached="B", gait="walk",
                   resolution=0.001)
    first = route.steps[0]
    assert first.gait == "walk" and first.attached == "B" and first.attached_after == "A"
    np.testing.assert_allclose(first.catch, (sensed[0] + 0.5, sensed[1]), atol=5e-4)
    assert route.start.position == sensed
    assert wall.goal.distance(route.catches[-1])[0] == 0.0


def test_the_goal_behind_the_robot_is_reached_by_the_mirrored_gait():
    wall = plate_wall(holes=(), start=(5.5, 1.5), goal=(0.5, 1.5))
    route = plan_route(wall, [WALK], resolution=0.01)
    assert {s.gait for s in route.steps} == {"walk (mirrored)"}
    with pytest.raises(NoRoute):
        plan_route(wall, [WALK], resolution=0.01, mirror=False)


def test_the_magnets_swap_each_step_and_an_end_specific_gait_waits_for_its_end():
    """An asymmetric robot's two-step cycle: ``a`` only from A, ``b`` only from B."""
    a = AtlasGait("a", 0.6, 0.0, 1.0, 1.0, 0.0, 1e-3, attached="A")
    b = AtlasGait("b", 0.4, 0.0, 1.0, 1.0, 0.0, 1e-3, attached="B")
    wall = plate_wall(holes=(), goal=(4.5, 1.5), radius=0.05)
    route = plan_route(wall, [a, b], [Transition("a", "b"), Transition("b", "a")],
                       resolution=0.01, mirror=False)
    assert [s.gait for s in route.steps] == ["a", "b"] * 4
    assert [s.attached for s in route.steps] == ["A", "B"] * 4
    assert route.steps[-1].attached_after == "A"


def test_step_failure_counts_failures_per_step_attempted():
    """Runs of up to 100 steps: one failed in its 11th step, one in its 41st, eight were
    censored: 2 failures in 10 + 1 + 40 + 1 + 800 = 852 steps attempted."""
    cycles = [10, 40] + [100] * 8
    failed = [True, True] + [False] * 8
    p, up = step_failure(cycles, failed, 100)
    assert p == pytest.approx(2 / 852)
    # Clopper-Pearson: P(at most 2 failures | p = up) = 2.5 %
    n = 852
    tail = sum(math.comb(n, k) * up ** k * (1 - up) ** (n - k) for k in range(3))
    assert tail == pytest.approx(0.025, rel=1e-6)
    p0, up0 = step_failure([100] * 10, [False] * 10, 100)
    assert p0 == 0.0 and up0 == pytest.approx(1 - 0.025 ** (1 / 1000))


@pytest.mark.parametrize("kwargs, message", [
    (dict(p_fail=1.0), "p_fail must be in"),
    (dict(p_fail=0.01, p_fail_upper=0.001), "below p_fail"),
    (dict(duration=0.0), "duration must be > 0"),
    (dict(energy=-1.0), "energy"),
    (dict(dx=0.0, dy=0.0), "must move the magnet"),
    (dict(attached="C"), "an end is A or B"),
])
def test_an_atlas_gait_refuses_bad_numbers(kwargs, message):
    fields = dict(name="g", dx=0.5, dy=0.0, duration=1.0, energy=1.0, p_fail=0.0,
                  p_fail_upper=0.01)
    with pytest.raises(ValueError, match=message):
        AtlasGait(**{**fields, **kwargs})


def test_the_planner_refuses_an_inconsistent_atlas():
    with pytest.raises(ValueError, match="two gaits of the atlas are named 'walk'"):
        plan_route(plate_wall(), [WALK, WALK])
    with pytest.raises(ValueError, match="no gait named 'run'"):
        plan_route(plate_wall(), [WALK], [Transition("walk", "run")])
    with pytest.raises(ValueError, match="start gait 'run' is not in the atlas"):
        plan_route(plate_wall(), [WALK], start_gait="run")
    with pytest.raises(ValueError, match="passed 10 nodes"):
        plan_route(plate_wall(), ATLAS, SWITCHES, max_nodes=10)


def test_a_switch_step_runs_once_between_the_gaits_its_transitions_name():
    from dataclasses import replace
    from monkeystudy.analysis.route import AtlasGait, Transition, plan_route
    from monkeystudy.wall import Goal, Region, Start, Wall
    wall = Wall((Region(((-1.0, -1.0), (10.0, -1.0), (10.0, 1.0), (-1.0, 1.0))),),
                Start((0.0, 0.0)), Goal((4.0, -0.1), 0.01))
    level = AtlasGait("level", 1.0, 0.0, 1.0, 1.0, 0.0, 0.001)
    down = AtlasGait("down", 1.0, -0.1, 1.0, 1.0, 0.0, 0.001)
    switch = AtlasGait("level to down", 1.0, -0.1, 1.0, 1.0, 0.0, 0.001, repeats=False)
    moves = [Transition("level", "level to down", 0.0, 0.001),
             Transition("level to down", "down", 0.0, 0.001)]
    route = plan_route(wall, [level, down, switch], moves, mirror=False)
    assert [s.gait for s in route.steps] == ["level"] * 3 + ["level to down"]
    # the switch step alone would get there from rest in one repeated gait: it may not
    with pytest.raises(NoRoute):
        plan_route(replace(wall, goal=Goal((4.0, -0.4), 0.01)), [switch], mirror=False)
    # and it never follows itself: down 0.2 m takes the switch and then the gait down
    route = plan_route(replace(wall, goal=Goal((4.0, -0.2), 0.01)), [level, down, switch],
                       moves, mirror=False)
    assert [s.gait for s in route.steps] == ["level"] * 2 + ["level to down", "down"]


def test_p_arrive_from_survival_curves_counts_each_run_of_a_gait_once():
    """With survival curves, each run of n consecutive steps of one gait survives with S(n)
    (the curve's last value times 1 - p_fail per step beyond it), each switch with its own
    1 - p_fail: counted here from the route's steps, independently of the planner."""
    curves = {"walk": (1.0, 0.9, 0.88, 0.87), "climb": (1.0, 0.95, 0.9, 0.89, 0.885),
              "descend": (1.0, 0.99)}
    atlas = [dataclasses.replace(g, survival=curves[g.name]) for g in ATLAS]
    route = plan_route(plate_wall(), atlas, SWITCHES, resolution=0.01)
    gaits = {g.name: g for g in atlas}
    runs = []
    for s in route.steps:
        if runs and runs[-1][0] == s.gait:
            runs[-1][1] += 1
        else:
            runs.append([s.gait, 1])
    assert len(runs) >= 3 and max(n for _, n in runs) > 4      # past a curve's end
    want = (1 - 1e-3) ** (len(runs) - 1)
    for name, n in runs:
        g = gaits[name.replace(" (mirrored)", "")]
        last = len(g.survival) - 1
        want *= g.survival[n] if n <= last else g.survival[last] * (1 - g.p_fail) ** (n - last)
    assert route.p_arrive_survival == pytest.approx(want, rel=1e-12)
    assert route.p_arrive_survival < route.p_arrive      # the early failures, counted


@pytest.mark.parametrize("curve", [(0.9, 0.8), (1.0, 0.8, 0.85), (1.0, 1.2), (1.0, -0.1)])
def test_a_survival_curve_starts_at_one_and_never_rises(curve):
    with pytest.raises(ValueError, match="survival must start at 1"):
        dataclasses.replace(WALK, survival=curve)
