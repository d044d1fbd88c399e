"""The ``stability`` step: a gait run for many cycles from its start, the study's figures 5-8.

From a refine step's start or a floquet step's fixed point (:mod:`.gait_source`), as its own
controller or replayed open-loop (:mod:`monkeystudy.analysis.replay`): the horizontal gait's
replay keeps the refined gait's recorded ``t_switch``, ``t_motor`` (the clock restarted at each
vertical crossing, or running on with the gait's period). Per cycle: the error against the
start, the kinetic energy and the attached end's height; and a sampled trajectory.
"""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any, Literal, Optional

import numpy as np
from pydantic import Field

from ...analysis.gait_kind import gait_kind_text
from ...analysis.replay import sequence_cycles
from ...controllers import SequenceGait
from ...simulation import STATUS_NAMES, Status, evaluate_cycle_gaits
from .. import datasets as D
from ..blocks import Task
from ..models import Name, OpenLoopSettings, Replay, StrictModel
from ..spec import GaitSpec
from .base import Figure, StepContext, StepKind, max_drop_of
from .gait_source import run_problems


class StabilityStep(StrictModel):
    """Repeat a refined gait open-loop from its recorded times for ``cycles`` cycles."""

    name: Name
    kind: Literal["stability"]
    from_: Name = Field(alias="from")  # described by the kind (accepts)
    cycles: int = Field(ge=1, le=100_000, description="number of cycles")
    controller: OpenLoopSettings = Field(default_factory=OpenLoopSettings)
    replay: Replay = None
    start_index: Optional[int] = Field(None, ge=0, description="which start of a multi-start "
                                       "refine step (default: the lowest error)")
    sample_dt: float = Field(0.005, gt=0, le=1.0,
                             description="trajectory sampling interval [s]")
    max_drop: Optional[float] = Field(None, gt=0, description="stop ('fell') when the "
                                      "attached end sinks this far [m] (default: link 1's "
                                      "length)")


# --- tasks (run on the workers) ------------------------------------------------------------------
def empty_record(cycles: int) -> dict[str, Any]:
    """The record of a run that was not run: every cycle NaN, no samples."""
    nan = np.full(cycles, np.nan)
    return {
        "status": int(Status.OK), "cycles_completed": 0,
        "error": nan.copy(), "kinetic_energy": nan.copy(), "pivot_height": nan.copy(),
        "x_advance": nan.copy(), "t_cross": nan.copy(), "t_swap": nan.copy(),
        "time": np.empty(0), "A": np.empty((0, 2)), "joint": np.empty((0, 2)),
        "B": np.empty((0, 2)), **{name: np.empty(0) for name, _ in D.TRAJECTORY_ANGLES},
        "attached_end": np.empty(0, np.int8), "phase": np.empty(0, np.int8),
        "motor_torque": np.empty(0), "steps": 0, "nfev": 0,
    }


#: the per-cycle records of a stability dataset (:class:`~monkeystudy.analysis.replay.
#: SequenceCycles` fields)
PER_CYCLE = ("error", "kinetic_energy", "pivot_height", "x_advance", "t_cross", "t_swap")


def stability_task(spec: GaitSpec, gait: SequenceGait, z0, *, times, cycles: int,
                   tick: float | None, sample_dt: float, max_drop: float,
                   replay: str) -> dict[str, Any]:
    """Run ``gait`` for ``cycles`` cycles from section state ``z0 = (theta2 [rad], dtheta1,
    dtheta2 [rad s-1])`` (a running clock: ``(theta1, theta2, dtheta1, dtheta2)``) as its own
    controller or replayed open-loop (:func:`~monkeystudy.analysis.replay.sequence_cycles`),
    on the controller ``tick`` [s] (None: the gait's).

    ``times`` [s]: the start's recorded segment exit times, which an open-loop replay keeps
    (None: the cycle's own from ``z0``). Per cycle, as the gait records it: the error against
    the start, the kinetic energy, the attached end's height and advance, the section
    crossing ``t_cross`` and the cycle's swap ``t_swap`` [s] (NaN padded to ``cycles``); the
    run's status, counts and sampled trajectory; ``t_segment``, the cycle's segment exit
    times from ``z0`` [s]. A start whose cycle does not close is not run: ``status`` is its
    status and every cycle is NaN.
    """
    robot, integ = spec.robot, spec.integrator
    out = dict(empty_record(cycles), t_segment=np.full(len(gait.all_segments()), np.nan))
    z0 = np.asarray(z0, float)
    one = evaluate_cycle_gaits([[z0[-2], z0[-1]]], dataclasses.replace(gait, theta2=z0[-3]),
                               robot=robot, integrator=integ)
    if int(one["status"][0]) != Status.OK:
        out["status"] = int(one["status"][0])
        return out
    out["t_segment"] = one["t_segment"][0].copy()
    r = sequence_cycles(gait, z0, cycles=cycles, robot=robot, integrator=integ,
                        replay=replay, times=out["t_segment"] if times is None else times,
                        tick=tick, max_drop=max_drop, sample_dt=sample_dt)
    for key in PER_CYCLE:
        v = getattr(r, key)[:cycles]
        out[key][:len(v)] = v
    out.update(D.run_record(r.run))
    return out


def motor_frame_torque(torque: np.ndarray, frame: np.ndarray, time: np.ndarray,
                       t_cross: np.ndarray, gait: SequenceGait) -> np.ndarray:
    """Sampled motor torques [N m] on ``theta2`` of the frame (``frame``: 0 hanging from A,
    1 from B) restated in the motor frame of each sample's cycle: the frame of the end that
    cycle started from (A for the first; for a gait whose cycle ends on B, the ends take
    turns), so the values are the ones the study wrote
    (:func:`~monkeystudy.controllers.motor_frame_signs`). ``time`` [s] of the samples,
    ``t_cross`` [s] the section crossings that end the cycles (NaN: not reached)."""
    crossings = np.sort(np.asarray(t_cross, float)[np.isfinite(t_cross)])
    cycle = np.searchsorted(crossings, np.asarray(time, float), side="right")
    start_frame = (cycle % 2) if gait.end_attached() == "B" else np.zeros_like(cycle)
    torque = np.asarray(torque, float)
    sign = np.where(np.asarray(frame) == start_frame, 1.0, -1.0)
    return np.where(torque == 0.0, torque, sign * torque)


def uncrossed_cycles(error: np.ndarray, status: int) -> np.ndarray:
    """The cycles (1-based) of a run recorded from the swap whose error is NaN because no
    section crossing came between their swap and the next (a running clock can pass its
    period without reaching the section): every NaN of a run that ran its cycles (status
    ok), else those before its last recorded cycle (the later ones did not run)."""
    e = np.asarray(error, float)
    finite = np.flatnonzero(np.isfinite(e))
    end = e.size if status == Status.OK else (int(finite[-1]) + 1 if finite.size else 0)
    return np.flatnonzero(np.isnan(e[:end])) + 1


def run_summary(result: dict, cycles: int, records: str) -> str:
    """The step's line in the run's log: the cycles run and the status, and when the run
    stopped early, where and why (:attr:`~monkeystudy.simulation.Status.message`); the
    cycles recorded from the swap that reached no section crossing."""
    status = Status(int(result["status"]))
    done = int(result["cycles_completed"])
    if status == Status.OK:
        text = f"{done} cycles, status ok"
    else:
        text = (f"STOPPED after {done} of {cycles} cycles: status {STATUS_NAMES[status]} "
                f"({status.message})")
    if records == "swap":
        missed = uncrossed_cycles(result["error"], int(status))
        if missed.size:
            text += (f"; {missed.size} cycle(s) ({', '.join(str(c) for c in missed)}) "
                     "reached no vertical crossing before the next swap (error NaN)")
    return text


# --- the dataset ---------------------------------------------------------------------------------
#: the frame's angles and rates of the sampled trajectory
ANGLE_NAMES = {"theta1": "link 1's angle from the downward vertical",
               "theta2": "link 2's angle relative to link 1"}

#: the variables of a stability dataset (docs/datasets.md); the long_names' fields say where
#: a cycle is recorded (the section or the vertical after the swap) and the torque's frame
VARIABLES = {
    "cycle": D.index_coordinate("cycle", "cycle number"),
    "xy": D.label_coordinate("xy", "world axis"),
    "error": D.Variable(("cycle",), np.float64, D.ERROR_UNITS,
                        "error against the initial state at the {crossing} ending the cycle "
                        "(docs/model.md{section_error})"),
    "kinetic_energy": D.Variable(("cycle",), np.float64, "J", "kinetic energy at that {crossing}"),
    "pivot_height": D.Variable(("cycle",), np.float64, "m",
                               "world height of the attached end {pivot_when}"),
    "x_advance": D.Variable(("cycle",), np.float64, "m",
                            "horizontal displacement of the attached end in the cycle"),
    "t_cross": D.Variable(("cycle",), np.float64, "s", "time of the {crossing} ending the cycle"),
    "t_swap": D.Variable(("cycle",), np.float64, "s", "time of the cycle's {swap}"),
    "status": D.Variable.of((), np.int8, D.STATUS_ATTRS,
                            long_name="why the run stopped (ok: all cycles ran)"),
    "dtheta1": D.Variable.of((), np.float64, D.DTHETA1,
                             long_name="replayed " + D.DTHETA1["long_name"]),
    "dtheta2": D.Variable.of((), np.float64, D.DTHETA2,
                             long_name="replayed " + D.DTHETA2["long_name"]),
    "time": D.Variable(("sample",), np.float64, "s", "time"),
    **{key: D.Variable(("sample", "xy"), np.float64, "m", f"world position of {what}")
       for key, what in (("A", "end A"), ("joint", "the joint"), ("B", "end B"))},
    **{name: D.Variable(("sample",), np.float64, D.RATE if name.endswith("_dot") else "rad",
                        ("rate of " if name.endswith("_dot") else "")
                        + ANGLE_NAMES[name.removesuffix("_dot")]
                        + " in the frame of the attached end")
       for name, _ in D.TRAJECTORY_ANGLES},
    "attached_end": D.Variable(("sample",), np.int8, "1",
                               "the end the frame hangs from (its x, y end)",
                               {"flag_values": np.array([0, 1], np.int8),
                                "flag_meanings": "A B"}),
    "phase": D.Variable.of(("sample",), np.int8, D.PHASE_ATTRS),
    "motor_torque": D.Variable(("sample",), np.float64, "N m", "motor torque {torque_frame}"),
}


def write_stability(path: Path, attrs: dict, result: dict, z, records: str,
                    torque_frame: str = "attached_end") -> None:
    """Write a stability dataset from a :func:`stability_task` result run from section state
    ``z`` (its rates [rad s-1] are the dataset's ``dtheta1``, ``dtheta2``), the cycles recorded
    at the section or from the swap (``records``, :class:`~monkeystudy.controllers.
    SequenceGait`); the sampled ``motor_torque`` as it is stated in ``torque_frame``
    (``motor``: already restated by :func:`motor_frame_torque`)."""
    n = len(result["error"])
    ns = len(result["time"])
    section = records == "section"
    fields = {
        "crossing": "section crossing" if section else "vertical crossing",
        "section_error": "; the section error" if section else "",
        "pivot_when": "at that section crossing" if section else "after the cycle's swap",
        "swap": "first magnet action (NaN: none)" if section else "swap",
        "torque_frame": ("in the motor frame (the physical torque, its sign fixed to the "
                         "links over each cycle: on theta2 of the frame of the end the cycle "
                         "started from)" if torque_frame == "motor"
                         else "on theta2 of the frame"),
    }
    with D.atomic_netcdf(path) as nc:
        nc.createDimension("cycle", n)
        nc.createDimension("sample", ns)
        nc.createDimension("xy", 2)

        def write(name, data, coordinates=""):
            D.write_declared(nc, VARIABLES, name, data, coordinates=coordinates, **fields)

        write("cycle", np.arange(1, n + 1))
        write("xy", np.array(["x", "y"], object))
        for key in ("error", "kinetic_energy", "pivot_height", "x_advance", "t_cross", "t_swap"):
            write(key, result[key])
        write("status", result["status"])
        write("dtheta1", z[-2])
        write("dtheta2", z[-1])
        write("time", result["time"])
        for key in ("A", "joint", "B"):
            write(key, result[key], coordinates="time")
        for name, _ in D.TRAJECTORY_ANGLES:
            write(name, result[name], coordinates="time")
        write("attached_end", result["attached_end"], coordinates="time")
        write("phase", result["phase"], coordinates="time")
        write("motor_torque", result["motor_torque"], coordinates="time")
        D.set_global_attrs(nc, dict(attrs,
                               cycles_completed=int(result["cycles_completed"]),
                               steps=int(result["steps"]), nfev=int(result["nfev"])))


# --- the kind ------------------------------------------------------------------------------------
class StabilityKind(StepKind):
    name = "stability"
    model = StabilityStep
    variables = VARIABLES
    gait_kinds = ("horizontal", "sequence")
    accepts = ("refine", "floquet")
    unit = "runs"
    figures = (
        Figure("error"),
        Figure("kinetic_energy"),
        Figure("height"),
        Figure("filmstrip"),
        Figure("animation"),
        Figure("ladder"),
        Figure("error_comparison", across=True),
    )

    def check_step(self, study, index, step: StabilityStep, ref, seen) -> list:
        return run_problems(study, index, step, ref)

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        tick = st.controller.tick if st.controller.tick is not None else ctx.study.gait.tick
        g = ctx.handed_on(start_index=st.start_index, replay=st.replay,
                          clock=st.controller.clock)
        kw = {"cycles": st.cycles, "tick": tick, "sample_dt": st.sample_dt,
              "max_drop": max_drop_of(st, ctx.spec), "replay": g.replay, "times": g.times}
        ctx.state.update(gait=g, options=kw)
        return [Task(0, stability_task, (ctx.spec, g.gait, g.z), kw)]

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        g, kw = ctx.state["gait"], ctx.state["options"]
        r = ctx.results[0]
        # a sequence gait's recorded cycle: the schedule an open-loop replay keeps
        recorded = r["t_segment"] if g.times is None else g.times
        attrs.update(g.attrs("run", t_segment=recorded),
                     controller={"tick": kw["tick"], "clock": g.clock},
                     sample_dt=kw["sample_dt"], max_drop=kw["max_drop"], cycles=kw["cycles"])
        frame = ctx.spec.torque_frame
        if frame == "motor":
            r = dict(r, motor_torque=motor_frame_torque(r["motor_torque"], r["attached_end"],
                                                        r["time"], r["t_cross"], g.gait))
        write_stability(ctx.path, attrs, r, g.z, g.gait.records, frame)
        return run_summary(r, kw["cycles"], g.gait.records)

    def describe(self, ds) -> list[str]:
        a = ds.attrs
        lines = []
        err = ds["error"].values
        n_ok = int(np.isfinite(err).sum())
        lines.append(f"status {STATUS_NAMES[int(ds['status'])]}, "
                     f"{a.get('cycles_completed', '?')} of {err.size} cycles completed, "
                     f"{n_ok} vertical crossings")
        if n_ok:
            lines.append(f"error: first {err[0]:.4g}, last {err[np.isfinite(err)][-1]:.4g}")
            ph = ds["pivot_height"].values
            lines.append(f"pivot height: first {ph[0]:.4g} m, last "
                         f"{ph[np.isfinite(ph)][-1]:.4g} m")
        # times on a tick are differences of tick instants: 12 digits hide the last-bit noise
        if "t_switch" in a:
            lines.append(f"replayed t_switch {_seconds(a.get('t_switch'))} s, t_motor "
                         f"{_seconds(a.get('t_motor'))} s, controller {a.get('controller')}")
        else:                          # a sequence gait: its cycle's segment exits
            recorded = a.get("t_segment", [])
            if isinstance(recorded, str):     # a list attribute is stored as JSON
                recorded = json.loads(recorded)
            times = ", ".join(_seconds(t) for t in np.atleast_1d(recorded))
            lines.append(f"{a.get('replay')} replay, its cycle's segment exits ({times}) s, "
                         f"controller {a.get('controller')}")
        if int(a.get("vertical_passes_before_swap", -1)) >= 0:
            lines.append(f"the replayed gait {gait_kind_text(int(a['vertical_passes_before_swap']))}")
        return lines


def _seconds(value) -> str:
    """A time attribute [s] to 12 significant digits (or as stored when not a number)."""
    try:
        return f"{float(value):.12g}"
    except (TypeError, ValueError):
        return str(value)
