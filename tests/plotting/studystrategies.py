"""Hypothesis strategies for valid studies with small budgets (tests/plotting/test_report_property.py).

A study is drawn as plain data (``dict``) and written as text by :func:`study_text` (JSON is
YAML 1.2, the loader's language), so that a failing example can be kept verbatim as a
regression case. Every study drawn is valid by construction; the property test asserts that
the loader agrees, so a strategy that drifts from the schema fails loudly rather than being
filtered out.

What is drawn:

* robots: the presets, or two links within physical bounds: mass 0.2-5 kg, length 0.2-1.5 m,
  the CG strictly inside the link (5-95 % of its length), the inertia about the CG positive
  and at most ``m c (L - c)`` (all the mass at the two ends: no rigid link has more), gravity
  2-25 m s-2; mirror-image links half the time (a return map of one cycle and a run of many
  compare like with like only when the frame's flip at the swap leaves the robot the same, so
  the loader asks for them in every multi-cycle or return-map step);
* the horizontal gait (a motor torque of 1-30 % of ``(m1 + m2) g L1``, either sign; exact
  timing or a 1 or 5 ms tick) or a sequence gait (two swings before the swap, no flight; or a
  release, a flight and a catch), each from a template with drawn values;
* grids of 1-8 points per axis, or 1-4 explicit points, over rate ranges scaled to the robot's
  pendulum frequency that often reach past the region where a gait exists;
* short chains on the grid: refine (from the grid's minima or a point, a few iterations),
  stability of the refined gait (a few cycles, sometimes a small ``max_drop`` so it falls),
  shoot, floquet, basin, survival (nothing failing or everything failing at once), and a
  design step with a tiny grid (exact timing).
"""
from __future__ import annotations

import json
import math

from hypothesis import strategies as st

SEED2009 = {"mass": 1.0, "length": 0.61, "com": 0.543754, "inertia": 0.01808704}


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


@st.composite
def axes(draw, lo: float, hi: float, span_max: float, scale: float) -> dict:
    """An axis of 1-8 values inside ``[lo, hi] * scale``."""
    num = draw(st.integers(1, 8))
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
def grid_steps(draw, name: str, robot, region: str) -> dict:
    s = rate_scale(robot)
    lo1, hi1, lo2, hi2 = REGIONS[region]
    if draw(st.integers(0, 4)) == 0:
        n = draw(st.integers(1, 4))
        pts = [[_r(s * draw(st.floats(lo1, hi1))), _r(s * draw(st.floats(lo2, hi2)))]
               for _ in range(n)]
        pts = [p for i, p in enumerate(pts) if p not in pts[:i]]
        return {"name": name, "kind": "grid", "points": pts}
    return {"name": name, "kind": "grid", "dtheta1": draw(axes(lo1, hi1, hi1 - lo1, s)),
            "dtheta2": draw(axes(lo2, hi2, hi2 - lo2, s))}


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
def survival_steps(draw, name: str, source: str, replay: str | None = None) -> dict:
    step = {"name": name, "kind": "survival", "from": source,
            "runs": draw(st.integers(1, 5)), "max_cycles": draw(st.integers(2, 12)),
            "seed": draw(st.integers(0, 3)), "noise": {"timing": draw(timing_noise())}}
    if replay:
        step["replay"] = replay
    if draw(st.booleans()):
        step["max_drop"] = _r(draw(st.floats(0.01, 0.5)))
    return step


@st.composite
def horizontal_studies(draw, design: bool | None = None) -> dict:
    """A horizontal-gait study (``design``: with a design step, or drawn)."""
    design = draw(st.integers(0, 5)) == 0 if design is None else design
    # a design needs a schedule near a stable one to find gaits at all: mostly the 2009
    # robot's (studies/open_loop_design_smoke.yaml), sometimes any robot (it finds none)
    known = design and draw(st.integers(0, 3)) > 0
    robot = "seed2009" if known else draw(robots())
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
        if is_mirror(robot) and draw(st.integers(0, 3)) > 0:
            stab = {"name": "cycles", "kind": "stability", "from": "best",
                    "cycles": draw(st.integers(1, 5)),
                    "sample_dt": draw(st.sampled_from([0.005, 0.02, 0.05]))}
            if draw(st.booleans()):
                stab["max_drop"] = _r(draw(st.floats(0.01, 0.6)))
            if draw(st.booleans()):
                stab["controller"] = {"clock": "run_on"}
            steps.append(stab)
    shoot = design or draw(st.integers(0, 2)) == 0
    if shoot:
        near = [[_r(1.44 * s), _r(10.31 * s)]] if known or draw(st.booleans()) else []
        starts = near + [[_r(s * draw(st.floats(0.0, 3.0))), _r(s * draw(st.floats(8.0, 13.0)))]]
        steps.append({"name": "exact", "kind": "shoot", "starts": starts,
                      "method": draw(st.sampled_from(["grazing", "gauss_newton", "both"])),
                      "max_iter": draw(st.integers(1, 12))})
        if is_mirror(robot) and draw(st.booleans()):
            steps.append({"name": "basin", "kind": "basin", "from": "exact",
                          "offsets": draw(small_offsets()),
                          "max_cycles": draw(st.integers(1, 8))})
    # the search controller's fixed point is polished from the 2009 robot's gait: only there
    # does its default start lie near one (elsewhere the floquet dataset records that no
    # cycle was found, and a later step has no fixed point to run)
    floquet = is_mirror(robot) and draw(st.integers(0, 3)) == 0
    if floquet:
        ctrls = ["search"] + (["open_loop"] if shoot and draw(st.booleans()) else [])
        steps.append({"name": "multipliers", "kind": "floquet", "from": "exact",
                      "controllers": ctrls} if "open_loop" in ctrls else
                     {"name": "multipliers", "kind": "floquet", "controllers": ctrls})
    sources = ([("best", None)] if refine else []) + ([("exact", None)] if shoot else []) \
        + ([("multipliers", "gait")] if floquet else [])
    if sources and is_mirror(robot) and draw(st.integers(0, 2)) == 0:
        source, replay = draw(st.sampled_from(sources))
        steps.append(draw(survival_steps("noise", source, replay)))
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
        steps.append({"name": "design", "kind": "design", "from": "exact", "parameters": grid,
                      **extra,
                      "refine": {"starts": draw(st.integers(0, 1)),
                                 "max_evaluations": draw(st.integers(1, 5))},
                      "verify": {"cycles": draw(st.integers(1, 10)),
                                 "decay_cycles": draw(st.integers(3, 6)),
                                 "basin_num": draw(st.integers(1, 3)),
                                 "basin_cycles": draw(st.integers(1, 5))}})
    return {"schema_version": 1, "name": "drawn", "robot": robot, "gait": gait,
            "integrator": {"rtol": 1e-8, "atol": 1e-10,
                           "max_time": 3.0 if known else draw(st.sampled_from([1.0, 3.0]))},
            "steps": steps}


@st.composite
def sequence_studies(draw) -> dict:
    robot = draw(st.one_of(st.just("seed2009"), robots(mirror=True)))
    gait = draw(sequence_gaits(robot))
    steps = [draw(grid_steps("map", robot, gait_region(gait)))]
    steps.append({"name": "best", "kind": "refine",
                  "start": {"from": "map", "best": 1}, "maxiter": draw(st.integers(1, 12))})
    # a floquet step on another robot may find no return map to analyse (recorded in its
    # dataset, and then a later step has no fixed point to run): drawn on every robot, the
    # steps after it from the 2009 robot's
    if draw(st.booleans()):
        steps.append({"name": "multipliers", "kind": "floquet", "from": "best"})
    if robot == "seed2009" and draw(st.booleans()):
        steps = [s for s in steps if s["kind"] != "floquet"]
        steps.append({"name": "multipliers", "kind": "floquet", "from": "best"})
        follow = draw(st.sampled_from(["stability", "basin", "survival", "none"]))
        if follow == "stability":
            steps.append({"name": "cycles", "kind": "stability", "from": "multipliers",
                          "cycles": draw(st.integers(1, 4)), "sample_dt": 0.02})
        elif follow == "basin":
            steps.append({"name": "basin", "kind": "basin", "from": "multipliers",
                          "offsets": draw(small_offsets()), "max_cycles": draw(st.integers(1, 6))})
        elif follow == "survival":
            steps.append(draw(survival_steps("noise", "multipliers")))
    elif draw(st.booleans()):
        steps.append({"name": "cycles", "kind": "stability", "from": "best",
                      "cycles": draw(st.integers(1, 4)), "sample_dt": 0.02})
    return {"schema_version": 1, "name": "drawn", "robot": robot, "gait": gait,
            "integrator": {"rtol": 1e-8, "atol": 1e-10, "max_time": 2.0},
            "steps": steps}


def studies() -> st.SearchStrategy[dict]:
    """Valid studies: a third each of horizontal-gait studies (a sixth of them with a design
    step), sequence-gait studies and horizontal-gait studies with a design step."""
    return st.one_of(horizontal_studies(), sequence_studies(), horizontal_studies(design=True))


def study_text(study: dict) -> str:
    """The study as a file's text (JSON, which is YAML 1.2)."""
    return json.dumps(study, indent=1) + "\n"


def design_studies() -> st.SearchStrategy[dict]:
    """Horizontal-gait studies with a design step."""
    return horizontal_studies(design=True)
