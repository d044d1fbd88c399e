"""Hypothesis strategies for studies with small budgets (tests/plotting/test_report_property.py).

A study is drawn as plain data (``dict``) and written as text by :func:`study_text` (JSON is
YAML 1.2, the loader's language), so that a failing example can be kept verbatim as a
regression case. Every study drawn is valid by construction, except that two of its steps may
be named so that their figures share a file name (a basin step ``b`` and a grid step
``b_cycles`` both draw ``b_cycles_map``), which the loader must refuse; the property test
asserts that the loader agrees, so a strategy that drifts from the schema fails loudly rather
than being filtered out. :func:`invalid_studies` draws studies with several known problems at
once, for the loader's one-pass report.

What is drawn:

* robots: the presets, or two links within physical bounds: mass 0.2-5 kg, length 0.2-1.5 m,
  the CG strictly inside the link (5-95 % of its length), the inertia about the CG positive
  and at most ``m c (L - c)`` (all the mass at the two ends: no rigid link has more), gravity
  2-25 m s-2; mirror-image links half the time (a return map of one cycle and a run of many
  compare like with like only when the frame's flip at the swap leaves the robot the same, so
  the loader asks for them in every multi-cycle or return-map step);
* the integrator: mostly rtol 1e-8 (fast), sometimes the defaults (no ``integrator`` key:
  rtol 1e-10) or rtol 1e-10 alone, so that floquet's Newton polish meets the map's error
  level of the default tolerances;
* the horizontal gait (a motor torque of 1-30 % of ``(m1 + m2) g L1``, either sign; exact
  timing or a 1 or 5 ms tick) or a sequence gait (two swings before the swap, no flight; or a
  release, a flight and a catch with the other magnet), each from a template with drawn
  values, or one of the templates at the values where it has a gait (the flight gait of
  studies/flight_gait.yaml, the climbing gait of studies/climbing_gait.yaml), its grid
  around that gait;
* grids of 1-8 points per axis (one point, 1 x N and N x 1 among them), or 1-4 explicit
  points, over rate ranges scaled to the robot's pendulum frequency that often reach past the
  region where a gait exists;
* every step kind, chained through ``from:`` wherever the schema allows it: refine (from the
  grid's minima or a point), stability (from a refine or a floquet step), shoot (from starts
  or a refine step), floquet (from a shoot or a refine step, or none), tick_sweep (also with
  a floquet step's multiplier), basin and continuation (from a shoot or a floquet step),
  survival (from a refine, shoot, floquet or design step), design (from a shoot or a floquet
  step), work_precision and stress; the replays on both clocks (``run_on`` and the
  restarting one, where the gait has both) with ticks of 0 and 1 ms;
* steps that fail mid-study (a refine from a grid without a gait, a work_precision over
  points without one) followed by steps that do not depend on them;
* step names: readable ones, single characters, digits and underscores, long ones up to the
  schema's 100 characters, and names that are prefixes or suffixes of others.
"""
from __future__ import annotations

import json
import math
import string

from hypothesis import strategies as st

SEED2009 = {"mass": 1.0, "length": 0.61, "com": 0.543754, "inertia": 0.01808704}

#: the longest step name the schema allows
NAME_MAX = 100


def _r(x: float, digits: int = 4) -> float:
    """``x`` to ``digits`` significant digits (readable study texts); below 1e-6, 0."""
    return float(f"{x:.{digits}g}") if abs(x) >= 1e-6 else 0.0


@st.composite
def links(draw) -> dict:
    """One link within physical bounds."""
    mass = _r(draw(st.floats(0.2, 5.0)))
    length = _r(draw(st.floats(0.2, 1.5)))
    com = _r(length * draw(st.floats(0.05, 0.95)))
    com = min(com, length)
    bound = mass * com * (length - com)          # all the mass at the two ends
    inertia = _r(bound * draw(st.floats(0.1, 1.0)))
    inertia = min(inertia, bound) if inertia > 0 else bound
    return {"mass": mass, "length": length, "com": com, "inertia": inertia}


@st.composite
def robots(draw, mirror: bool | None = None) -> dict | str:
    """A preset name or explicit parameters (``mirror``: links that are mirror images)."""
    if mirror is None and draw(st.booleans()):
        return draw(st.sampled_from(["seed2009", "uniform_rod"]))
    first = draw(links())
    mirror = draw(st.booleans()) if mirror is None else mirror
    if mirror:
        second = dict(first, com=_r(first["length"] - first["com"], 6))
        second["com"] = min(max(second["com"], 0.0), first["length"])
    else:
        second = draw(links())
    return {"name": "drawn", "gravity": _r(draw(st.floats(2.0, 25.0))),
            "links": [first, second]}


def is_mirror(robot) -> bool:
    """The robot's links are mirror images (the presets are)."""
    if isinstance(robot, str):
        return True
    a, b = robot["links"]
    return a == dict(b, com=a["com"]) and abs(a["com"] + b["com"] - a["length"]) < 1e-12


def robot_scale(robot) -> tuple[float, float, float]:
    """``(L1 [m], total mass [kg], g [m s-2])`` of a drawn robot."""
    if isinstance(robot, str):
        if robot == "seed2009":
            return SEED2009["length"], 2.0, 9.81
        return 0.61, 2.0, 9.81
    return robot["links"][0]["length"], sum(lk["mass"] for lk in robot["links"]), \
        robot["gravity"]


def rate_scale(robot) -> float:
    """Rates [rad s-1] scale with the pendulum frequency sqrt(g / L); 1 for seed2009."""
    length, _, g = robot_scale(robot)
    return math.sqrt(g / length) / math.sqrt(9.81 / 0.61)


@st.composite
def integrators(draw, max_time: float | None = None) -> dict | None:
    """The study's ``integrator``: mostly rtol 1e-8, atol 1e-10; an eighth of the time the
    defaults (None: no key, rtol 1e-10), an eighth rtol 1e-10 alone."""
    choice = draw(st.integers(0, 7))
    if choice == 0:
        return None
    if choice == 1:
        return {"rtol": 1e-10}
    out = {"rtol": 1e-8, "atol": 1e-10}
    if max_time is not None:
        out["max_time"] = max_time
    return out


@st.composite
def horizontal_gaits(draw, robot, tick: float | None = None) -> dict:
    length, mass, g = robot_scale(robot)
    if robot in ("seed2009", "uniform_rod") and draw(st.booleans()):
        torque = 0.6354
    else:
        torque = _r(draw(st.floats(0.01, 0.3)) * mass * g * length)
        torque = torque if draw(st.booleans()) else -torque
    tick = draw(st.sampled_from([0.0, 0.001, 0.005])) if tick is None else tick
    return {"kind": "horizontal", "motor_torque": torque, "tick": tick}


@st.composite
def sequence_gaits(draw, robot) -> dict:
    """Two swings before the swap (no flight) or a release, a flight and a catch."""
    length, mass, g = robot_scale(robot)
    torque = _r(draw(st.floats(0.02, 0.2)) * mass * g * length)
    tick = draw(st.sampled_from([0.0, 0.001]))
    if draw(st.booleans()):
        segments = [
            {"until": "coord", "coord": "theta1", "value": 0.0, "direction": "falling",
             "latch_energy": True},
            {"until": "coord", "coord": "theta1", "value": 0.0, "direction": "rising"},
            {"until": "free_end_height", "value": 0.0, "direction": "rising"},
            {"until": "energy_restored", "value": 0.0, "magnets": "swap", "torque": torque},
        ]
        section = {"theta1": 0.0, "direction": "either", "theta2": 0.0}
    else:
        release = _r(draw(st.floats(0.3, 0.9)))
        segments = [
            {"until": "coord", "coord": "theta1", "value": release, "direction": "rising",
             "latch_energy": True},
            {"until": "free_end_y", "value": 0.0, "direction": "rising", "magnets": "none"},
            {"until": "energy_restored", "value": 0.0, "magnets": "B", "torque": torque},
        ]
        section = {"theta1": 0.0, "direction": "either",
                   "theta2": _r(draw(st.floats(0.0, 0.5)))}
    return {"kind": "sequence", "section": section, "segments": segments, "tick": tick}


#: sequence gaits at the values where they have a gait, with a grid around it: the flight
#: gait of studies/flight_gait.yaml (its cycle ends hanging from B: the next cycle is its
#: mirror image) and the climbing gait of studies/climbing_gait.yaml
KNOWN_SEQUENCE_GAITS = {
    "flight": ({"kind": "sequence", "section": {"theta1": 0.0, "direction": "either",
                                                 "theta2": 0.3},
                "segments": [
                    {"until": "coord", "coord": "theta1", "value": 0.6, "direction": "rising",
                     "latch_energy": True},
                    {"until": "free_end_y", "value": 0.0, "direction": "rising",
                     "magnets": "none"},
                    {"until": "energy_restored", "value": 0.0, "magnets": "B",
                     "torque": 0.6354}],
                "tick": 0.0},
               (1.8, 2.0, 9.8, 10.1)),
    "climbing": ({"kind": "sequence", "section": {"theta1": 0.0, "direction": "either",
                                                   "theta2": 1.0},
                  "segments": [
                      {"until": "free_end_height", "value": 0.05, "direction": "rising",
                       "latch_energy": True},
                      {"until": "energy_restored", "value": 0.981, "magnets": "swap",
                       "torque": 0.6354}],
                  "tick": 0.0},
                 (4.3, 4.6, 0.1, 0.4)),
}


@st.composite
def axes(draw, lo: float, hi: float, span_max: float, scale: float,
         num: int | None = None) -> dict:
    """An axis of 1-8 values inside ``[lo, hi] * scale`` (``num`` values, if given)."""
    num = draw(st.integers(1, 8)) if num is None else num
    start = _r(scale * draw(st.floats(lo, hi)))
    if num == 1:
        return {"start": start, "stop": start, "num": 1}
    span = _r(scale * draw(st.floats(0.05, span_max)))
    return {"start": start, "stop": _r(start + span), "num": num}


#: where the grids look (seed2009's rates, scaled to the robot): the horizontal gait's maps
#: start near dtheta2 = 10.3, so the range reaches well below, where there is no gait; the
#: sequence templates' own maps (studies/two_swing.yaml, studies/flight_gait.yaml)
REGIONS = {"horizontal": (-1.0, 3.0, 7.0, 14.0), "two_swing": (-2.5, 0.5, 8.0, 22.0),
           "flight": (0.5, 3.0, 7.0, 13.0)}


def gait_region(gait: dict) -> str:
    if gait["kind"] == "horizontal":
        return "horizontal"
    return "flight" if any(seg["magnets"] == "none" for seg in gait["segments"]
                           if "magnets" in seg) else "two_swing"


@st.composite
def grid_steps(draw, name: str, robot, region: str | tuple) -> dict:
    """A grid: explicit points (a fifth of the time), else two axes, one of them a single
    value a quarter of the time (a 1 x N or N x 1 grid, or one point)."""
    s = rate_scale(robot)
    lo1, hi1, lo2, hi2 = REGIONS[region] if isinstance(region, str) else region
    if draw(st.integers(0, 4)) == 0:
        n = draw(st.integers(1, 4))
        pts = [[_r(s * draw(st.floats(lo1, hi1))), _r(s * draw(st.floats(lo2, hi2)))]
               for _ in range(n)]
        pts = [p for i, p in enumerate(pts) if p not in pts[:i]]
        return {"name": name, "kind": "grid", "points": pts}
    shape = draw(st.sampled_from(["any", "any", "any", "row", "column", "point"]))
    n1 = 1 if shape in ("row", "point") else None
    n2 = 1 if shape in ("column", "point") else None
    return {"name": name, "kind": "grid",
            "dtheta1": draw(axes(lo1, hi1, hi1 - lo1, s, n1)),
            "dtheta2": draw(axes(lo2, hi2, hi2 - lo2, s, n2))}


def _n_points(grid: dict) -> int:
    if "points" in grid:
        return len(grid["points"])
    return grid["dtheta1"]["num"] * grid["dtheta2"]["num"]


@st.composite
def small_offsets(draw) -> dict:
    def axis():
        n = draw(st.integers(1, 4))
        h = _r(draw(st.floats(1e-4, 2e-2)))
        return {"start": -h if n > 1 else 0.0, "stop": h if n > 1 else 0.0, "num": n}
    return {"d_dtheta1": axis(), "d_dtheta2": axis()}


@st.composite
def timing_noise(draw) -> list[float] | float:
    """Timing jitter levels [s]: nothing (no run fails) up to 20 ms (all fail at once)."""
    levels = draw(st.lists(st.sampled_from([0.0, 1e-5, 1e-3, 2e-2]), min_size=1, max_size=3,
                           unique=True))
    return levels if len(levels) > 1 else levels[0]


@st.composite
def replay_controllers(draw, horizontal: bool) -> dict | None:
    """A multi-cycle step's ``controller``: the clock (``run_on`` only for the horizontal
    gait, which has both) and the tick: the gait's, exact timing or 1 ms."""
    out = {}
    if horizontal and draw(st.booleans()):
        out["clock"] = "run_on"
    tick = draw(st.sampled_from([None, 0.0, 0.001]))
    if tick is not None:
        out["tick"] = tick
    return out or None


def _with(step: dict, **keys) -> dict:
    """``step`` with the keys whose value is not None."""
    return dict(step, **{k: v for k, v in keys.items() if v is not None})


@st.composite
def stability_steps(draw, name: str, source: str, horizontal: bool,
                    replays: tuple = ()) -> dict:
    step = {"name": name, "kind": "stability", "from": source,
            "cycles": draw(st.integers(1, 6)),
            "sample_dt": draw(st.sampled_from([0.005, 0.02, 0.05]))}
    if draw(st.booleans()):
        step["max_drop"] = _r(draw(st.floats(0.01, 0.6)))
    return _with(step, controller=draw(replay_controllers(horizontal)),
                 replay=draw(st.sampled_from([None, *replays])))


@st.composite
def survival_steps(draw, name: str, source: str, replay: str | None = None,
                   horizontal: bool = False) -> dict:
    step = {"name": name, "kind": "survival", "from": source,
            "runs": draw(st.integers(1, 5)), "max_cycles": draw(st.integers(2, 12)),
            "seed": draw(st.integers(0, 3)), "noise": {"timing": draw(timing_noise())}}
    if replay:
        step["replay"] = replay
    if draw(st.booleans()):
        step["max_drop"] = _r(draw(st.floats(0.01, 0.5)))
    if replay != "gait":
        step = _with(step, controller=draw(replay_controllers(horizontal)))
    return step


@st.composite
def tick_sweep_steps(draw, name: str, source: str, replays: tuple = ()) -> dict:
    ticks = draw(st.lists(st.sampled_from([0.0, 0.001, 0.005]), min_size=1, max_size=3,
                          unique=True))
    return _with({"name": name, "kind": "tick_sweep", "from": source, "ticks": ticks,
                  "cycles": draw(st.integers(1, 6))},
                 replay=draw(st.sampled_from([None, *replays])))


@st.composite
def basin_steps(draw, name: str, source: str, replays: tuple = ()) -> dict:
    return _with({"name": name, "kind": "basin", "from": source,
                  "offsets": draw(small_offsets()), "max_cycles": draw(st.integers(1, 6))},
                 tick=draw(st.sampled_from([None, None, 0.0, 0.001])),
                 replay=draw(st.sampled_from([None, *replays])))


@st.composite
def continuation_steps(draw, name: str, source: str, parameters: tuple) -> dict:
    parameter = draw(st.sampled_from(parameters))
    if parameter.endswith("_viscous"):      # friction starts at its least value, 0
        ds = _r(draw(st.floats(1e-4, 1e-2)))
    else:
        ds = _r(draw(st.floats(1e-3, 2e-2))) * draw(st.sampled_from([1, -1]))
    return {"name": name, "kind": "continuation", "from": source, "parameter": parameter,
            "ds": ds, "steps": draw(st.integers(1, 3))}


@st.composite
def work_precision_steps(draw, name: str, robot) -> dict:
    """Timings at a few points (near the 2009 gait, scaled to the robot: some robots have a
    well-conditioned gait there, most do not, and the step is refused), one tolerance each."""
    s = rate_scale(robot)
    pts = [[_r(s * draw(st.floats(0.5, 1.5))), _r(s * draw(st.floats(10.0, 11.5)))]
           for _ in range(draw(st.integers(1, 2)))]
    pts = [p for i, p in enumerate(pts) if p not in pts[:i]]
    return {"name": name, "kind": "work_precision", "points": pts,
            "methods": draw(st.lists(st.sampled_from(["rk45", "dop853"]), min_size=1,
                                     max_size=2, unique=True)),
            "rtols": [draw(st.sampled_from([1e-6, 1e-8]))], "repeat": 1,
            "scipy_methods": ["RK45"], "scipy_rtols": [1e-6], "scipy_points": 1,
            "first_swing_only": draw(st.booleans())}


@st.composite
def stress_steps(draw, name: str) -> dict:
    """The three stress scenarios at their smallest: ten periods of one phase, one tolerance,
    one or two long-run cycles, two extreme cases."""
    return {"name": name, "kind": "stress",
            "energy_drift": {"phases": [draw(st.sampled_from(["swing", "flight"]))],
                             "rtols": [1e-6], "periods": 10.0, "checkpoints": 4},
            "long_runs": {"cycles": draw(st.integers(1, 2))},
            "extreme": {"cases": draw(st.lists(st.sampled_from(
                ["mass_ratio_1_100", "tiny_inertia", "cg_at_the_ends", "coulomb_sticking"]),
                min_size=1, max_size=2, unique=True)),
                "points": [[0.902, 10.935]], "max_steps": 20000}}


@st.composite
def floquet_followers(draw, source: str, horizontal: bool, replays: tuple,
                      parameters: tuple) -> list[dict]:
    """One or two steps run from a floquet step's fixed point (no continuation without
    ``parameters``)."""
    kinds = draw(st.lists(st.sampled_from(["stability", "tick_sweep", "basin", "survival",
                                           "continuation"][:5 if parameters else 4]),
                          min_size=1, max_size=2, unique=True))
    out = []
    for kind in kinds:
        name = f"{kind}_f"
        if kind == "stability":
            out.append(draw(stability_steps(name, source, horizontal, replays)))
        elif kind == "tick_sweep":
            out.append(draw(tick_sweep_steps(name, source, replays)))
        elif kind == "basin":
            out.append(draw(basin_steps(name, source, replays)))
        elif kind == "survival":
            replay = draw(st.sampled_from([None, "gait"] if horizontal else [None, *replays]))
            out.append(draw(survival_steps(name, source, replay, horizontal)))
        else:
            out.append(draw(continuation_steps(name, source, parameters)))
    return out


@st.composite
def horizontal_studies(draw, design: bool | None = None) -> dict:
    """A horizontal-gait study (``design``: with a design step, or drawn)."""
    design = draw(st.integers(0, 5)) == 0 if design is None else design
    # a design needs a schedule near a stable one to find gaits at all: mostly the 2009
    # robot's (studies/open_loop_design_smoke.yaml), sometimes any robot (it finds none)
    known = design and draw(st.integers(0, 3)) > 0
    robot = "seed2009" if known else draw(robots())
    mirror = is_mirror(robot)
    gait = ({"kind": "horizontal", "motor_torque": 0.6354, "tick": 0.0} if known
            else draw(horizontal_gaits(robot, tick=0.0 if design else None)))
    s = rate_scale(robot)
    steps = [draw(grid_steps("map", robot, "horizontal"))]
    if draw(st.booleans()):
        steps.append(draw(grid_steps("map2", robot, "horizontal")))
    refine = None
    if draw(st.integers(0, 3)) > 0:
        if draw(st.booleans()):
            start = {"from": "map", "best": draw(st.integers(1, min(2, _n_points(steps[0]))))}
        else:
            start = [_r(s * draw(st.floats(-1.0, 3.0))), _r(s * draw(st.floats(7.0, 14.0)))]
        refine = {"name": "best", "kind": "refine", "start": start,
                  "maxiter": draw(st.integers(1, 12))}
        steps.append(refine)
        if mirror and draw(st.integers(0, 3)) > 0:
            steps.append(draw(stability_steps("cycles", "best", True)))
    shoot = design or draw(st.integers(0, 2)) == 0
    ticks_at = None
    if shoot:
        # the 2009 gait's grazing fixed point is found from (1.0, 12.0) (studies/
        # analysis_smoke.yaml); from (1.44, 10.31) alone a grazing solve swaps a swing late
        near = ([[_r(1.0 * s), _r(12.0 * s)], [_r(1.44 * s), _r(10.31 * s)]]
                if known or draw(st.booleans()) else [])
        starts = near + [[_r(s * draw(st.floats(0.0, 3.0))), _r(s * draw(st.floats(8.0, 13.0)))]]
        # near the 2009 gait, enough Newton iterations to converge (at rtol 1e-8: 8)
        exact = {"name": "exact", "kind": "shoot", "starts": starts,
                 "method": draw(st.sampled_from(["grazing", "gauss_newton", "both"])),
                 "max_iter": draw(st.integers(8 if near else 1, 12))}
        if refine and not known and draw(st.integers(0, 2)) == 0:   # from the refined rates
            exact = dict(exact, starts=None, **{"from": "best"})
            del exact["starts"]
        steps.append(exact)
        if mirror:
            # a continuation differentiates the exact-timing map: the gait's tick must be 0
            kinds = ["basin", "tick_sweep"] + (["continuation"] if gait["tick"] == 0 else [])
            for kind in draw(st.lists(st.sampled_from(kinds), max_size=2, unique=True)):
                if kind == "basin":
                    steps.append(draw(basin_steps("basin", "exact")))
                elif kind == "tick_sweep":
                    steps.append(draw(tick_sweep_steps("ticks", "exact")))
                    ticks_at = len(steps) - 1
                else:
                    steps.append(draw(continuation_steps("family", "exact",
                                                         ("com", "inertia", "gravity"))))
    # the search controller's fixed point is polished from the 2009 robot's gait: only there
    # does its default start lie near one (elsewhere the floquet dataset records that no
    # cycle was found, and a later step has no fixed point to run)
    floquet = mirror and draw(st.integers(0, 2)) == 0
    if floquet:
        ctrls = ["search"] + (["open_loop"] if shoot and draw(st.booleans()) else [])
        steps.append({"name": "multipliers", "kind": "floquet", "from": "exact",
                      "controllers": ctrls} if "open_loop" in ctrls else
                     {"name": "multipliers", "kind": "floquet", "controllers": ctrls})
        if "open_loop" in ctrls and ticks_at is not None and draw(st.booleans()):
            # the tick sweep takes the floquet step's leading multiplier: it comes after it
            steps.append(dict(steps.pop(ticks_at), floquet="multipliers"))
        # the open-loop replays run the open_loop map's fixed point; the search
        # controller's is run by its own controller (survival's replay: gait) only
        if "open_loop" in ctrls and draw(st.booleans()):
            steps += draw(floquet_followers("multipliers", True, (), ("com", "inertia",
                                                                       "gravity")
                                            if gait["tick"] == 0 else ()))
    sources = ([("best", None)] if refine else []) + ([("exact", None)] if shoot else []) \
        + ([("multipliers", "gait")] if floquet else [])
    if sources and mirror and draw(st.integers(0, 2)) == 0:
        source, replay = draw(st.sampled_from(sources))
        steps.append(draw(survival_steps("noise", source, replay, True)))
    if draw(st.integers(0, 7)) == 0:
        steps.append(draw(work_precision_steps("timing", robot)))
    if draw(st.integers(0, 11)) == 0:
        steps.append(draw(stress_steps("stress")))
    if design:
        params = draw(st.sampled_from([["motor_start"], ["t_motor"], ["motor_start", "t_motor"]]))
        grid = {}
        for p in params:
            # around the smoke study's schedule (motor_start -0.30..-0.20, t_motor 0.14..0.22)
            lo, hi = {"motor_start": (-0.35, -0.15), "t_motor": (0.1, 0.25)}[p]
            num = draw(st.integers(1, 3))
            a = _r(draw(st.floats(lo, hi)))
            b = _r(a + draw(st.floats(0.01, 0.1)))
            grid[p] = {"start": a, "stop": a if num == 1 else b, "num": num}
        extra = {}
        if known:
            extra = {"fixed": {"torque": -0.6354}, "balance": "t_switch",
                     "starts": [[-0.3288, 4.7564, 5.3654, 0.4711]]}
            if draw(st.integers(0, 3)) == 0:
                extra["clock"] = "run_on"
        # from the shoot step's gait, or the same gait as a floquet step analysed it
        source = ("multipliers" if floquet and "open_loop" in ctrls and draw(st.booleans())
                  else "exact")
        steps.append({"name": "design", "kind": "design", "from": source, "parameters": grid,
                      **extra,
                      "refine": {"starts": draw(st.integers(0, 1)),
                                 "max_evaluations": draw(st.integers(1, 5))},
                      "verify": {"cycles": draw(st.integers(1, 10)),
                                 "decay_cycles": draw(st.integers(3, 6)),
                                 "basin_num": draw(st.integers(1, 3)),
                                 "basin_cycles": draw(st.integers(1, 5))}})
        # survival runs a design whose clock restarts, and on its own clock only
        if mirror and "clock" not in extra and draw(st.integers(0, 2)) == 0:
            steps.append(draw(survival_steps("design_noise", "design", None, False)))
    integrator = draw(integrators(3.0 if known else draw(st.sampled_from([1.0, 3.0]))))
    return study(robot, gait, steps, integrator)


def study(robot, gait: dict, steps: list[dict], integrator: dict | None) -> dict:
    """A study of these parts (no ``integrator`` key when it is None: the defaults)."""
    out = {"schema_version": 1, "name": "drawn", "robot": robot, "gait": gait}
    if integrator is not None:
        out["integrator"] = integrator
    out["steps"] = steps
    return out


#: the parameters a sequence gait's fixed point is continued in
SEQUENCE_PARAMETERS = ("torque", "mass_ratio", "com", "pivot_viscous")


def ends_on_b(gait: dict) -> bool:
    """A sequence gait's cycle ends hanging from B: an odd number of swaps, or a catch
    with B."""
    magnets = [seg.get("magnets", "keep") for seg in gait["segments"]]
    return magnets.count("swap") % 2 == 1 or "B" in magnets


@st.composite
def sequence_studies(draw) -> dict:
    """A sequence gait drawn from a template on any mirror-image robot, or a template at its
    gait (:data:`KNOWN_SEQUENCE_GAITS`) with the steps that run its floquet step's fixed
    point."""
    known = draw(st.sampled_from([None, "flight", "flight", "climbing"]))
    if known:
        robot = "seed2009"
        gait, region = KNOWN_SEQUENCE_GAITS[known]
        gait = dict(gait, tick=draw(st.sampled_from([0.0, 0.0, 0.001])))
    else:
        robot = draw(st.one_of(st.just("seed2009"), robots(mirror=True)))
        gait = draw(sequence_gaits(robot))
        region = gait_region(gait)
    steps = [draw(grid_steps("map", robot, region))]
    refine = {"name": "best", "kind": "refine", "start": {"from": "map", "best": 1},
              "maxiter": draw(st.integers(1, 12))}
    if known:
        refine.pop("maxiter")
        if draw(st.booleans()):          # as studies/flight_gait.yaml: to round-off
            refine.update(xatol=1e-10, fatol=1e-18, maxiter=2000, maxfev=4000)
    steps.append(refine)
    floquet = known is not None or draw(st.booleans())
    replays = ("gait", "open_loop")
    if floquet:
        steps.append({"name": "multipliers", "kind": "floquet", "from": "best"})
        # a continuation needs exact timing; a cycle that ends hanging from B needs
        # mirror-image links, which a mass ratio other than 1 breaks
        parameters = () if gait["tick"] != 0 else tuple(
            p for p in SEQUENCE_PARAMETERS if p != "mass_ratio" or not ends_on_b(gait))
        if known or draw(st.booleans()):
            steps += draw(floquet_followers("multipliers", False, replays, parameters))
    if not floquet or draw(st.booleans()):
        steps.append(draw(stability_steps("cycles", "best", False, replays)))
    # a floquet step on another robot may find no return map to analyse (recorded in its
    # dataset, and then a later step has no fixed point to run)
    integrator = draw(integrators(2.0 if not known else 3.0))
    return study(robot, gait, steps, integrator)


@st.composite
def failing_studies(draw) -> dict:
    """A horizontal-gait study with a step that fails mid-study, steps built on it (not run)
    and later steps that do not depend on it (they must run): a refine from a grid without
    a gait, a work_precision over points without one."""
    robot = draw(st.sampled_from(["seed2009", "uniform_rod"]))
    gait = draw(horizontal_gaits(robot))
    steps = []
    if draw(st.booleans()):
        steps.append({"name": "map", "kind": "grid", "points": [[0.9, 10.9], [1.0, 11.0]]})
    failing = draw(st.lists(st.sampled_from(["refine", "work_precision"]), min_size=1,
                            max_size=2, unique=True))
    for kind in failing:
        if kind == "refine":
            steps.append(draw(grid_steps("nogait", robot, (-0.5, 0.5, 0.0, 1.0))))
            steps.append({"name": "lost", "kind": "refine",
                          "start": {"from": "nogait", "best": 1},
                          "maxiter": draw(st.integers(1, 5))})
            if draw(st.booleans()):
                steps.append(draw(stability_steps("lost_cycles", "lost", True)))
        else:
            steps.append({"name": "timing", "kind": "work_precision",
                          "points": [[0.0, 0.0], [0.1, 0.2]][:draw(st.integers(1, 2))],
                          "methods": ["rk45"], "rtols": [1e-6], "repeat": 1,
                          "scipy_methods": ["RK45"], "scipy_rtols": [1e-6], "scipy_points": 1})
    later = draw(st.sampled_from(["grid", "refine", "shoot"]))
    if later == "grid":
        steps.append(draw(grid_steps("later", robot, "horizontal")))
    elif later == "refine":
        steps.append({"name": "later", "kind": "refine", "start": [0.9, 10.9],
                      "maxiter": draw(st.integers(1, 5))})
        if draw(st.booleans()):
            steps.append(draw(stability_steps("later_cycles", "later", True)))
    else:
        steps.append({"name": "later", "kind": "shoot", "starts": [[1.44, 10.31]],
                      "method": "grazing", "max_iter": draw(st.integers(1, 8))})
    return study(robot, gait, steps, {"rtol": 1e-8, "atol": 1e-10, "max_time": 3.0})


# --- step names ----------------------------------------------------------------------------------
#: the first words of the step kinds' figure names that have two (``cycles`` of the basin
#: figure ``cycles_map``, ...): a step named ``<other step>_<word>`` may draw a figure named as
#: one of the other step's
FIGURE_WORDS = ("cycles", "swap", "kinetic", "error", "failure", "height", "mfpt", "work")

NAME_CHARS = string.ascii_letters + string.digits


def sources(step: dict) -> list[str]:
    """The steps a step names: ``from``, a refine's ``start.from``, a tick_sweep's
    ``floquet``."""
    start = step.get("start")
    out = [step.get("from"), start.get("from") if isinstance(start, dict) else None,
           step.get("floquet")]
    return [n for n in out if n]


def rename(study_: dict, names: dict[str, str]) -> dict:
    """The study with its steps renamed (``names``: old name -> new), references included."""
    steps = []
    for step in study_["steps"]:
        step = dict(step, name=names.get(step["name"], step["name"]))
        for key in ("from", "floquet"):
            if key in step:
                step[key] = names.get(step[key], step[key])
        if isinstance(step.get("start"), dict):
            start = step["start"]
            step["start"] = dict(start, **{"from": names.get(start["from"], start["from"])})
        steps.append(step)
    return dict(study_, steps=steps)


@st.composite
def step_names(draw, study_: dict) -> dict:
    """The study with odd but valid step names half the time: single characters, digits and
    underscores, long names up to :data:`NAME_MAX`, a name that is another's with
    ``_<word>`` appended or its last ``_<word>`` dropped; a basin step and a grid or design
    step named ``X`` and ``X_cycles`` half the time they are both there (their figures share
    a file name: the loader refuses it)."""
    if draw(st.booleans()):
        return study_
    steps = study_["steps"]
    old = [s["name"] for s in steps]
    names: dict[str, str] = {}

    def free(name: str) -> bool:
        return (name not in names.values() and 0 < len(name) <= NAME_MAX
                and name[0] in NAME_CHARS)

    basins = [s["name"] for s in steps if s["kind"] == "basin"]
    maps = [s["name"] for s in steps if s["kind"] in ("grid", "design")]
    if basins and maps and draw(st.booleans()):
        x = draw(st.sampled_from(["b", "x1", "cycles", "basin_1"]))
        names[draw(st.sampled_from(basins))] = x
        names[draw(st.sampled_from(maps))] = f"{x}_cycles"
    for name in draw(st.permutations(old)):
        if name in names:
            continue
        taken = list(names.values())
        choice = draw(st.integers(0, 6))
        if choice == 0:
            new = draw(st.sampled_from(NAME_CHARS))
        elif choice == 1:
            new = draw(st.sampled_from(["0", "1_2", "x_1", "a_b_c", "9.5", "s-1", "A_"]))
        elif choice == 2:
            size = draw(st.integers(NAME_MAX - 20, NAME_MAX))
            new = (draw(st.sampled_from(NAME_CHARS))
                   + draw(st.text(NAME_CHARS + "_.-", min_size=size - 1, max_size=size - 1)))
        elif choice == 3 and taken:
            new = f"{draw(st.sampled_from(taken))}_{draw(st.sampled_from(FIGURE_WORDS))}"
        elif choice == 4 and taken:
            other = draw(st.sampled_from(taken))
            new = other.rsplit("_", 1)[0] if "_" in other else other[:-1]
        else:
            new = name
        while not free(new):
            new = (new + draw(st.sampled_from(NAME_CHARS)))[-NAME_MAX:] if new else name
            if len(new) >= NAME_MAX:
                new = f"{name}_{len(names)}"
        names[name] = new
    return rename(study_, names)


def studies() -> st.SearchStrategy[dict]:
    """Valid studies: a quarter each of horizontal-gait studies (a sixth of them with a design
    step), sequence-gait studies, horizontal-gait studies with a design step and studies with
    a failing step, every one with odd step names half the time."""
    return st.one_of(horizontal_studies(), sequence_studies(), horizontal_studies(design=True),
                     failing_studies()).flatmap(step_names)


def design_studies() -> st.SearchStrategy[dict]:
    """Horizontal-gait studies with a design step."""
    return horizontal_studies(design=True)


# --- the study as text ---------------------------------------------------------------------------
def study_text(study_: dict) -> str:
    """The study as a file's text (JSON, which is YAML 1.2): one key a line, each step on a
    line of its own block."""
    return "\n".join(study_lines(study_)[0]) + "\n"


def study_lines(study_: dict) -> tuple[list[str], dict[tuple, int]]:
    """The lines of :func:`study_text` and the line (1-based) of each key by its path
    (``("steps", 2, "from")``): top-level keys, each step's keys and the keys of the dicts
    in a step (``("steps", 0, "dtheta1", "num")``)."""
    lines = ["{"]
    where: dict[tuple, int] = {}
    items = list(study_.items())
    for n, (key, value) in enumerate(items):
        end = "," if n < len(items) - 1 else ""
        where[(key,)] = len(lines) + 1
        if key == "steps":
            lines.append(f' "steps": [')
            for i, step in enumerate(value):
                lines.append("  {")
                keys = list(step.items())
                for m, (k, v) in enumerate(keys):
                    comma = "," if m < len(keys) - 1 else ""
                    where[("steps", i, k)] = len(lines) + 1
                    if isinstance(v, dict):
                        lines.append(f"   {json.dumps(k)}: {{")
                        sub = list(v.items())
                        for j, (kk, vv) in enumerate(sub):
                            where[("steps", i, k, kk)] = len(lines) + 1
                            lines.append(f"    {json.dumps(kk)}: {json.dumps(vv)}"
                                         + ("," if j < len(sub) - 1 else ""))
                        lines.append("   }" + comma)
                    else:
                        lines.append(f"   {json.dumps(k)}: {json.dumps(v)}{comma}")
                lines.append("  }" + ("," if i < len(value) - 1 else ""))
            lines.append(" ]" + end)
        else:
            lines.append(f" {json.dumps(key)}: {json.dumps(value)}{end}")
    lines.append("}")
    return lines, where


# --- studies with several problems -------------------------------------------------------------
#: per kind, a setting and a value out of its range (the path below the step, and the value)
BAD_SETTINGS = {
    "grid": (("dtheta1", "num"), 0), "refine": (("maxiter",), 0),
    "stability": (("cycles",), 0), "shoot": (("max_iter",), 0), "floquet": (("fd_step",), 0),
    "tick_sweep": (("cycles",), 0), "basin": (("max_cycles",), 0),
    "continuation": (("steps",), 0), "work_precision": (("repeat",), 0),
    "stress": (("energy_drift", "periods"), 1.0), "survival": (("runs",), 0),
    "design": (("refine", "max_evaluations"), 0),
}


def _set(step: dict, path: tuple, value) -> dict:
    if len(path) == 1:
        return dict(step, **{path[0]: value})
    return dict(step, **{path[0]: _set(dict(step.get(path[0]) or {}), path[1:], value)})


def _source_key(step: dict) -> tuple | None:
    """Where a step names its source: ``("from",)`` or a refine's ``("start", "from")``."""
    if "from" in step:
        return ("from",)
    if isinstance(step.get("start"), dict):
        return ("start", "from")
    return None


@st.composite
def invalid_studies(draw) -> tuple[dict, list[tuple]]:
    """A drawn study made invalid in two or three places at once, and the paths of the keys
    each problem is at: a setting out of range (or an unknown key, or a gait setting out of
    range), a ``from:`` naming a later step, and perhaps a step renamed as an earlier one."""
    study_ = draw(st.one_of(horizontal_studies(), sequence_studies(), failing_studies()))
    steps = list(study_["steps"])
    expected = []
    # a field error: in a step (its kind's setting, or an unknown key), or in the gait
    where = draw(st.sampled_from(["step", "step", "unknown", "gait"]))
    bad = None
    if where == "gait":
        study_ = dict(study_, gait=dict(study_["gait"], tick=-0.001))
        expected.append(("gait", "tick"))
    else:
        bad = draw(st.integers(0, len(steps) - 1))
        step = steps[bad]
        path, value = BAD_SETTINGS[step["kind"]]
        if where == "unknown":
            path, value = ("cylces",), 3
        elif step["kind"] == "grid" and "points" in step:
            path, value = ("points",), []
        steps[bad] = _set(step, path, value)
        expected.append(("steps", bad) + path)
    # a from: naming a later step, in a step that is not the invalid one
    named = [i for i, s in enumerate(steps) if _source_key(s) and i != bad
             and i < len(steps) - 1 and "floquet" not in s]
    if named:
        i = draw(st.sampled_from(named))
        later = steps[draw(st.integers(i + 1, len(steps) - 1))]["name"]
        key = _source_key(steps[i])
        steps[i] = _set(steps[i], key, later)
        expected.append(("steps", i) + key)
    # a step named as an earlier one: a step no other names, not the invalid one
    named_by = {n for s in steps for n in sources(s)}
    leaves = [i for i, s in enumerate(steps) if i > 0 and i != bad
              and s["name"] not in named_by and ("steps", i, "from") not in expected
              and ("steps", i, "start", "from") not in expected]
    if leaves and draw(st.booleans()):
        d = draw(st.sampled_from(leaves))
        steps[d] = dict(steps[d], name=steps[draw(st.integers(0, d - 1))]["name"])
        expected.append(("steps", d, "name"))
    return dict(study_, steps=steps), expected


def key_text(path: tuple) -> str:
    """A key's path as the loader names it: ``steps[2].dtheta1.num``."""
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else p)
    return out
