"""A synthetic dataset of the ``route`` step kind, in its exact layout, for the plotting tests.

The wall is a 10 m x 3 m plate with a window; the plan is a real least-cost route over it
(:func:`monkeystudy.analysis.route.plan_route`) with a small atlas of gaits; the walks are
drawn from that plan (each catch the planned one plus noise, failures of several causes drawn
per step); the noiseless walk is the plan walked kinematically (each free end swung round its
attached magnet, the joint where two 0.61 m links meet), not simulated: it has the variables
and attributes :func:`monkeystudy.plotting.gait.write_animation` reads.
"""
from __future__ import annotations

import json

import numpy as np
import xarray as xr

from monkeystudy import Robot
from monkeystudy.analysis.route import AtlasGait, Transition, plan_route
from monkeystudy.wall import Goal, Region, Start, Wall

#: the robot's link lengths [m] (seed2009)
LINK = 0.61
#: the gaits of the atlas: name -> (dx, dy [m], duration [s], energy [J], rho, survival runs,
#: failed runs, MFPT [steps]: a lower bound, the survival window, when no run failed); a
#: mirrored gait's numbers are its own gait's
GAITS = {
    "level": (0.75, 0.0, 1.10, 0.80, 0.36, 100, 0, 300.0),
    "climb": (0.50, 0.45, 1.30, 2.10, 0.62, 100, 60, 120.0),
    "descend": (0.50, -0.45, 1.20, 0.40, np.nan, 100, 75, 80.0),
}
#: the chance that a step slips far (its catch 0.15 m off the planned one, not 0.03 m)
SLIP = 0.03
#: every gait, the mirrored ones after their own (the atlas the planner uses)
GAIT_NAMES = ["level", "level (mirrored)", "climb", "climb (mirrored)", "descend",
              "descend (mirrored)"]
#: the failure causes the walks end by, with their per-step weights
CAUSES = {"fell": 0.45, "no_catch": 0.3, "stalled": 0.25}


def route_wall() -> Wall:
    """A 10 m x 3 m steel plate with a window (4.0 to 6.0 m along, 0.8 to 2.4 m up)."""
    plate = Region([(0, 0), (10, 0), (10, 3), (0, 3)],
                   holes=[[(4.0, 0.8), (6.0, 0.8), (6.0, 2.4), (4.0, 2.4)]])
    return Wall([plate], Start((0.5, 1.5), "A"), Goal((9.5, 1.5), 0.25), margin=0.05)


def _base(name: str) -> str:
    return name.replace(" (mirrored)", "")


def _atlas():
    atlas = []
    for name, (dx, dy, dur, en, _rho, runs, failed, mfpt) in GAITS.items():
        steps = runs * mfpt
        p = failed / steps if failed == 0 else 1.0 / mfpt
        upper = 1.0 - 0.025 ** (1.0 / steps) if failed == 0 else 1.5 / mfpt
        atlas.append(AtlasGait(name, dx, dy, duration=dur, energy=en, p_fail=p,
                               p_fail_upper=upper))
    return atlas


def _gait_table(atlas) -> dict:
    by_name = {g.name: g for g in atlas}
    out = {k: [] for k in ("dx", "dy", "duration", "energy", "p_fail", "p_fail_upper",
                           "rho", "mfpt", "low", "high", "censored", "runs", "failed")}
    for name in GAIT_NAMES:
        g = by_name[_base(name)]
        dx, dy, dur, en, rho, runs, failed, mfpt = GAITS[_base(name)]
        out["dx"].append(-dx if name.endswith("(mirrored)") else dx)
        out["dy"].append(dy)
        out["duration"].append(dur)
        out["energy"].append(en)
        out["p_fail"].append(g.p_fail)
        out["p_fail_upper"].append(g.p_fail_upper)
        out["rho"].append(rho)
        censored = failed == 0
        out["mfpt"].append(mfpt)                 # a lower bound when no run failed
        out["low"].append(np.nan if censored else mfpt * 0.55)
        out["high"].append(np.nan if censored else mfpt * 2.1)
        out["censored"].append(censored)
        out["runs"].append(runs)
        out["failed"].append(failed)
    return out


def _replay(wall: Wall, catches: np.ndarray, durations: list[float], dt: float = 0.01):
    """The plan walked without noise: per step the free end swings round the attached magnet
    (below it) from where it let go to the next catch; the two ends alternate."""
    start = np.asarray(wall.start.position, float)
    held = start
    free = start + np.array([0.05, -0.95])            # hanging at rest below the magnet
    end = 0 if wall.start.attached == "A" else 1
    t0 = 0.0
    ts, As, Js, Bs, ends, torque, t_cross = [], [], [], [], [], [], []
    for catch, dur in zip(catches, durations):
        r0, r1 = np.hypot(*(free - held)), np.hypot(*(catch - held))
        a0 = np.arctan2(*(free - held)[::-1])
        a1 = np.arctan2(*(catch - held)[::-1])
        forward = catch[0] >= held[0]
        # the free end passes below the magnet: counter-clockwise going +x, else clockwise
        if forward:
            a1 = a1 + 2 * np.pi * np.ceil((a0 - a1) / (2 * np.pi))
        else:
            a1 = a1 - 2 * np.pi * np.ceil((a1 - a0) / (2 * np.pi))
        n = max(int(round(dur / dt)), 2)
        s = np.arange(n) / n
        r = np.minimum((1 - s) * r0 + s * r1 + 0.25 * np.sin(np.pi * s), 2 * LINK - 0.02)
        a = (1 - s) * a0 + s * a1
        f = held + r[:, None] * np.column_stack([np.cos(a), np.sin(a)])
        mid = 0.5 * (held + f)
        half = np.maximum(np.hypot(*(f - held).T) / 2, 1e-9)
        h = np.sqrt(np.maximum(LINK ** 2 - half ** 2, 0.0))
        u = (f - held) / (2 * half[:, None])
        perp = np.column_stack([u[:, 1], -u[:, 0]])
        perp *= np.where(perp[:, 1] > 0, -1.0, 1.0)[:, None]     # the joint hangs below
        joint = mid + h[:, None] * perp
        held_xy = np.repeat(held[None, :], n, axis=0)
        A, B = (held_xy, f) if end == 0 else (f, held_xy)
        ts.append(t0 + s * dur)
        As.append(A)
        Js.append(joint)
        Bs.append(B)
        ends.append(np.full(n, end, np.int8))
        torque.append(np.where((s > 0.3) & (s < 0.7), 0.6354, 0.0))
        t0 += dur
        t_cross.append(t0)
        free, held, end = held, catch, 1 - end
    return (np.concatenate(ts), np.concatenate(As), np.concatenate(Js), np.concatenate(Bs),
            np.concatenate(ends), np.concatenate(torque), np.array(t_cross))


def route_dataset(*, walks: int = 200, max_steps: int = 30, seed: int = 7,
                  with_replay: bool = True) -> xr.Dataset:
    """The dataset of a route step over :func:`route_wall` (module docstring)."""
    wall = route_wall()
    atlas = _atlas()
    switches = [Transition(a.name, b.name, p_fail=1e-3, extra_time=0.2, extra_energy=0.1)
                for a in atlas for b in atlas if a is not b]
    route = plan_route(wall, atlas, switches, cost="time", risk_weight=2.0, resolution=0.01)
    plan = route.catches
    plan_gaits = [s.gait for s in route.steps]
    index = {name: k for k, name in enumerate(GAIT_NAMES)}
    table = _gait_table(atlas)
    rng = np.random.default_rng(seed)

    catch = np.full((walks, max_steps), np.nan)
    catch_y = np.full((walks, max_steps), np.nan)
    sensed = np.full((walks, max_steps), np.nan)
    sensed_y = np.full((walks, max_steps), np.nan)
    step_gait = np.full((walks, max_steps), -1, np.int32)
    arrived = np.zeros(walks, bool)
    failure = np.full(walks, "", dtype=object)
    walked = np.zeros(walks, np.int32)
    walk_time = np.zeros(walks)
    walk_energy = np.zeros(walks)
    fail_x = np.full(walks, np.nan)
    fail_y = np.full(walks, np.nan)
    causes = list(CAUSES)
    weights = np.array(list(CAUSES.values()))
    for run in range(walks):
        held = np.asarray(wall.start.position, float)
        cause = ""
        k = 0
        for k, (target, name) in enumerate(zip(plan, plan_gaits)):
            g = index[name]
            if k and name != plan_gaits[k - 1]:           # the transition's extras
                walk_time[run] += 0.2
                walk_energy[run] += 0.1
            # replanning keeps it near the plan, but now and then a step slips far
            t = target + rng.normal(0.0, 0.15 if rng.uniform() < SLIP else 0.03, 2)
            walk_time[run] += table["duration"][g] * rng.uniform(0.97, 1.05)
            walk_energy[run] += table["energy"][g] * rng.uniform(0.95, 1.08)
            if rng.uniform() < 2.0 * table["p_fail"][g]:  # the step failed (noisier than
                #                                             the atlas's survival runs)
                cause = str(rng.choice(causes, p=weights / weights.sum()))
                where = held if cause != "no_catch" else t
                fail_x[run], fail_y[run] = where
                break
            if not wall.can_catch(t)[0]:
                cause = "off_steel"
                fail_x[run], fail_y[run] = t
                break
            catch[run, k], catch_y[run, k] = t
            sensed[run, k], sensed_y[run, k] = t + rng.normal(0.0, 0.01, 2)
            step_gait[run, k] = g
            held = t
            walked[run] = k + 1
        else:
            if wall.goal.distance(held)[0] > 0.0:
                # short of the goal's disc: the replanned route's one more step catches in it
                k = walked[run]
                t = np.asarray(wall.goal.position) + rng.normal(0.0, 0.03, 2)
                catch[run, k], catch_y[run, k] = t
                sensed[run, k], sensed_y[run, k] = t + rng.normal(0.0, 0.01, 2)
                step_gait[run, k] = index["level"]
                walk_time[run] += table["duration"][index["level"]]
                walk_energy[run] += table["energy"][index["level"]]
                walked[run] = k + 1
        failure[run] = cause
        arrived[run] = cause == ""
    # one run wanders about the goal's disc, stepping level to and fro, until it is out of
    # steps; one finds no route from a catch beside the window
    for run, cause in ((walks - 3, "max_steps"), (walks - 7, "no_route")):
        n = len(plan) - 2 if cause == "max_steps" else 5
        catch[run], catch_y[run] = np.nan, np.nan
        step_gait[run] = -1
        catch[run, :n], catch_y[run, :n] = plan[:n].T
        step_gait[run, :n] = [index[g] for g in plan_gaits[:n]]
        if cause == "max_steps":
            x0, y0 = plan[n - 1]
            for k in range(n, max_steps):
                back = (k - n) % 2 == 1
                catch[run, k] = x0 + (0.0 if back else 0.75)
                catch_y[run, k] = y0
                step_gait[run, k] = index["level (mirrored)" if back else "level"]
            n = max_steps
        sensed[run], sensed_y[run] = catch[run] + 0.004, catch_y[run] - 0.003
        walked[run] = n
        arrived[run] = False
        failure[run] = cause
        fail_x[run], fail_y[run] = catch[run, n - 1], catch_y[run, n - 1]

    runs = np.arange(walks)
    steps = np.arange(1, max_steps + 1)
    vars_ = {
        "gait_dx": ("gait", np.array(table["dx"]), {"units": "m"}),
        "gait_dy": ("gait", np.array(table["dy"]), {"units": "m"}),
        "gait_duration": ("gait", np.array(table["duration"]), {"units": "s"}),
        "gait_energy": ("gait", np.array(table["energy"]), {"units": "J"}),
        "gait_p_fail": ("gait", np.array(table["p_fail"]), {"units": "1"}),
        "gait_p_fail_upper": ("gait", np.array(table["p_fail_upper"]), {"units": "1"}),
        "gait_spectral_radius": ("gait", np.array(table["rho"]), {"units": "1"}),
        "gait_mfpt": ("gait", np.array(table["mfpt"]), {"units": "1"}),
        "gait_mfpt_low": ("gait", np.array(table["low"]), {"units": "1"}),
        "gait_mfpt_high": ("gait", np.array(table["high"]), {"units": "1"}),
        "gait_mfpt_censored": ("gait", np.array(table["censored"], bool)),
        "gait_survival_runs": ("gait", np.array(table["runs"], np.int32)),
        "gait_survival_failed": ("gait", np.array(table["failed"], np.int32)),
        "plan_gait": ("plan_step", np.array(plan_gaits, dtype=object)),
        "plan_catch_x": ("plan_step", plan[:, 0], {"units": "m"}),
        "plan_catch_y": ("plan_step", plan[:, 1], {"units": "m"}),
        "arrived": ("run", arrived),
        "failure": ("run", failure.astype(str).astype(object)),
        "steps_walked": ("run", walked),
        "walk_time": ("run", walk_time, {"units": "s"}),
        "walk_energy": ("run", walk_energy, {"units": "J"}),
        "catch_x": (("run", "step"), catch, {"units": "m"}),
        "catch_y": (("run", "step"), catch_y, {"units": "m"}),
        "sensed_x": (("run", "step"), sensed, {"units": "m"}),
        "sensed_y": (("run", "step"), sensed_y, {"units": "m"}),
        "step_gait": (("run", "step"), step_gait),
        "failure_x": ("run", fail_x, {"units": "m"}),
        "failure_y": ("run", fail_y, {"units": "m"}),
    }
    coords = {"gait": ("gait", np.array(GAIT_NAMES, dtype=object)),
              "plan_step": ("plan_step", np.arange(1, len(plan) + 1, dtype=np.int32)),
              "run": ("run", runs), "step": ("step", steps)}
    n_arrived = int(arrived.sum())
    attrs = {
        "study_name": "route_test", "step_name": "route", "step_kind": "route",
        "robot": json.dumps(Robot.preset("seed2009").to_dict()),
        "wall": json.dumps(wall.to_dict()), "cost": "time", "risk_weight": 2.0,
        "walks": walks, "seed": seed, "max_steps": max_steps,
        "sensor": json.dumps({"position": 0.01}),
        "arrived_runs": n_arrived, "arrived_fraction": n_arrived / walks,
        "planned_p_arrive": route.p_arrive, "planned_p_arrive_low": route.p_arrive_low,
        "planned_p_arrive_survival": route.p_arrive_survival,
        "planned_time": route.expected_time, "planned_energy": route.expected_energy,
        "planned_steps": len(route.steps),
    }
    if with_replay:
        durations = [table["duration"][index[g]] for g in plan_gaits]
        t, A, J, B, ends, torque, t_cross = _replay(wall, plan, durations)
        xy = {"units": "m"}
        vars_.update({
            "A": (("sample", "xy"), A, dict(xy, long_name="world position of end A")),
            "joint": (("sample", "xy"), J, dict(xy, long_name="world position of the joint")),
            "B": (("sample", "xy"), B, dict(xy, long_name="world position of end B")),
            "attached_end": ("sample", ends),
            "phase": ("sample", np.zeros(t.size, np.int8)),
            "motor_torque": ("sample", torque, {"units": "N m"}),
            "t_cross": ("cycle", t_cross, {"units": "s"}),
            "status": ((), np.int8(0)),
        })
        coords.update({"time": ("sample", t, {"units": "s"}), "xy": ("xy", ["x", "y"]),
                       "cycle": ("cycle", np.arange(1, t_cross.size + 1, dtype=np.int32))})
        attrs["cycles_completed"] = int(t_cross.size)
    return xr.Dataset(vars_, coords=coords, attrs=attrs)
