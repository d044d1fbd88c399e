"""The ``continuation`` step: a gait family continued in one parameter, with the Floquet
multipliers along the branch and its folds and bifurcations
(:mod:`monkeystudy.analysis.continuation`).

From a shoot step's grazing solution: the collisionless family in a mirror-symmetric parameter
(the grazing border's own equations). From a floquet step's Newton-polished fixed point: any
parameter, with an adaptive step. The source says which (its start's ``found_by``).
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any, Literal, Optional

import numpy as np
from pydantic import Field, field_validator

from ...analysis.continuation import (
    CYCLE_PARAMETERS, LINK_PARAMETERS, PARAMETER_FLOOR, continue_cycle, continue_grazing,
    parameter_of, with_parameter,
)
from ...analysis.shooting import GrazingResult
from ...controllers import SequenceGait
from ...robot import Robot
from ...simulation import evaluate_cycle_gaits
from .. import datasets as D
from ..blocks import Task
from ..models import Name, StrictModel
from ..spec import GaitSpec, mirror_problem
from .base import Figure, StepContext, StepKind
from .gait_source import gait_line


#: continuation parameters of the horizontal gait's collisionless family (mirror-symmetric)
GRAZING_PARAMETERS = ("com", "inertia", "gravity")


class ContinuationStep(StrictModel):
    """Pseudo-arclength continuation of a gait family in one parameter, with the Floquet
    multipliers along the branch and its folds and bifurcations.

    ``from:`` a shoot step: the collisionless (grazing) family of its grazing solution in a
    mirror-symmetric parameter (com, inertia, gravity). ``from:`` a floquet step, whose
    Newton-polished fixed point starts the branch at the section's theta2: any parameter,
    ``monkeystudy.continuation``.
    """

    name: Name
    kind: Literal["continuation"]
    from_: Name = Field(alias="from")  # described by the kind (accepts)
    parameter: Literal["com", "inertia", "gravity", "torque", "mass_ratio", "joint_viscous",
                       "pivot_viscous", "link1_mass", "link1_com", "link1_inertia",
                       "link2_mass", "link2_com", "link2_inertia"] = Field(
        description="com: link 1's CG from A [m] (link 2's mirrored); inertia: both links' "
                    "[kg m2]; gravity [m s-2]; sequence gaits also: torque (the first motor "
                    "segment's [N m], the others scaled with it), mass_ratio (link 2's mass "
                    "over link 1's at the same total mass, inertias scaled with the masses "
                    "[1]), joint_viscous, pivot_viscous (viscous friction [N m s]), and one "
                    "link's own mass [kg], CG distance from its proximal end [m] or inertia "
                    "about its CG [kg m2] (link1_*: the link of end A; a cycle that ends on B "
                    "is continued as its cycle of two steps)")
    ds: float = Field(description="first arclength step in (dtheta1, dtheta2, [t_switch,] "
                                  "parameter) [mixed units]; its sign picks the direction")
    ds_max: Optional[float] = Field(None, gt=0, description="sequence gaits: largest |ds| "
                                    "the adaptive step may grow to (default |ds|); a failed "
                                    "corrector halves the step down to |ds| / 256")
    steps: int = Field(20, ge=1, le=100_000, description="continuation steps")
    bounds: Optional[list[float]] = Field(None, min_length=2, max_length=2,
                                          description="[lo, hi]: stop when the parameter "
                                                      "leaves them (units of the parameter)")

    @field_validator("ds")
    @classmethod
    def _nonzero(cls, v: float) -> float:
        if v == 0.0:
            raise ValueError("must be non-zero")
        return v

    @field_validator("bounds")
    @classmethod
    def _ordered(cls, v):
        if v is not None and not v[0] < v[1]:
            raise ValueError(f"must be [lo, hi] with lo < hi, got {v}")
        return v


# --- tasks (run on the workers) ------------------------------------------------------------------
def parameter_units(parameter: str) -> str:
    """A continuation parameter's units (:data:`~monkeystudy.analysis.continuation.
    CYCLE_PARAMETERS` holds every one, the grazing family's included)."""
    return CYCLE_PARAMETERS[parameter]


def parameter_value(robot: Robot, parameter: str) -> float:
    """The robot's current value of a continuation parameter (link 1's com [m], link 1's
    inertia [kg m2], gravity [m s-2])."""
    if parameter == "com":
        return float(robot.link1.com)
    if parameter == "inertia":
        return float(robot.link1.inertia)
    if parameter == "gravity":
        return float(robot.gravity)
    raise ValueError(f"parameter must be 'com', 'inertia' or 'gravity', got {parameter!r}")


def continuation_task(spec: GaitSpec, gait: SequenceGait, z, *, method: str,
                      t_switch: float, parameter: str, ds: float, steps: int,
                      ds_max: float | None = None,
                      bounds=(-math.inf, math.inf)) -> dict[str, Any]:
    """Continue a gait family in ``parameter`` from the study's own value.

    ``method="grazing"``: the collisionless family through the grazing solution ``z =
    (theta2, dtheta1, dtheta2)`` swapping at ``t_switch`` [s]
    (:func:`~monkeystudy.analysis.continuation.continue_grazing`, fixed step); ``"cycle"``:
    ``gait``'s fixed point ``z`` (:func:`~monkeystudy.analysis.continuation.continue_cycle`,
    adaptive step up to ``ds_max``), with each branch point's segment exit times [s] and
    advance per cycle [m].
    """
    robot, integ = spec.robot, spec.integrator
    if method == "grazing":
        value0 = parameter_value(robot, parameter)
        start = GrazingResult(float(z[1]), float(z[2]), float(t_switch), np.zeros(3), True, [])
        b = continue_grazing(start, parameter, value0, robot=robot, ds=float(ds),
                             steps=int(steps), bounds=tuple(bounds), integrator=integ)
        return {"parameter": b.parameter, "value0": value0,
                "value": np.asarray(b.value, float), "dtheta1": np.asarray(b.dtheta1, float),
                "dtheta2": np.asarray(b.dtheta2, float),
                "t_switch": np.asarray(b.t_switch, float),
                "residual": np.asarray(b.residual, float),
                "multipliers": np.asarray(b.multipliers, complex), "folds": list(b.folds),
                "period_doublings": list(b.period_doublings)}
    z0 = np.asarray(z, float)
    b = continue_cycle(gait, z0, parameter, robot=robot, ds=float(ds), steps=int(steps),
                       ds_max=ds_max, bounds=tuple(bounds), integrator=integ)
    n = len(b.value)
    # a link's own parameter continues the cycle of two steps (its rows are the segments')
    cycle_gait = with_parameter(robot, gait, parameter, b.value[0])[1]
    t_seg = np.full((n, len(cycle_gait.all_segments())), np.nan)
    adv = np.full((n, 2), np.nan)
    for i in range(n):
        rb, g = with_parameter(robot, gait, parameter, b.value[i])
        g = dataclasses.replace(g, theta2=float(b.theta2[i]))
        r = evaluate_cycle_gaits(np.array([[b.dtheta1[i], b.dtheta2[i]]]), g, robot=rb,
                                 integrator=integ)
        t_seg[i] = r["t_segment"][0]
        adv[i] = r["x_advance"][0], r["y_advance"][0]
    return {"parameter": parameter, "value0": float(b.value[0]), "value": b.value,
            "theta2": b.theta2, "theta2_pinned": int(b.theta2_pinned),
            "dtheta1": b.dtheta1, "dtheta2": b.dtheta2,
            "residual": b.residual, "iterations": b.iterations, "arclength": b.arclength,
            "multipliers": b.multipliers, "neutral": b.neutral, "stable": b.stable,
            "t_segment": t_seg, "x_advance": adv[:, 0], "y_advance": adv[:, 1],
            "folds": list(b.folds), "period_doublings": list(b.period_doublings),
            "through_plus_one": list(b.through_plus_one),
            "neimark_sacker": list(b.neimark_sacker),
            "stop_reason": b.stop_reason, "stop_detail": b.stop_detail,
            "steps_per_cycle": 2 if len(cycle_gait.segments) != len(gait.segments) else 1}


# --- the dataset ---------------------------------------------------------------------------------
#: the variables of a continuation dataset (docs/datasets.md): a fixed point's family (from
#: a floquet step) adds its section state and segments, the grazing family (from a shoot
#: step) its swap time; the long_names' fields say which family it is
VARIABLES = {
    "point": D.index_coordinate("point", "point on the branch (0: the {origin})"),
    "k": D.index_coordinate("k", "multiplier (by decreasing modulus)"),
    "parameter_value": D.Variable(("point",), np.float64, "{parameter_units}",
                                  "continuation parameter {parameter}"),
    "dtheta1": D.Variable.of(("point",), np.float64, D.DTHETA1,
                             long_name="{gait}, " + D.DTHETA1["long_name"]),
    "dtheta2": D.Variable.of(("point",), np.float64, D.DTHETA2,
                             long_name="{gait}, " + D.DTHETA2["long_name"]),
    "segment": D.index_coordinate("segment", D.SEGMENT_NOTE, optional=True),
    "residual": D.Variable(("point",), np.float64, "1", "{residual} after correction"),
    "theta2": D.Variable(("point",), np.float64, "rad",
                         "theta2 of the fixed point on the section (held at the start's when "
                         "theta2_pinned)", optional=True),
    "corrector_iterations": D.Variable(("point",), np.int32, "1",
                                       "Gauss-Newton corrector iterations (0: the start)",
                                       optional=True),
    "arclength": D.Variable(("point",), np.float64, "1",
                            "cumulative arclength in (theta2, dtheta1, dtheta2, parameter)",
                            optional=True),
    "stable": D.Variable(("point",), np.int8, "1",
                         "1: every non-neutral multiplier inside the unit circle",
                         optional=True),
    "neutral": D.Variable(("point",), np.int8, "1",
                          "multipliers within 1e-6 of 1 (the free energy level)",
                          optional=True),
    "t_segment": D.Variable.of(("point", "segment"), np.float64, D.GAIT_ATTRS["t_segment"],
                               optional=True),
    "x_advance": D.Variable.of(("point",), np.float64, D.GAIT_ATTRS["x_advance"],
                               optional=True),
    "y_advance": D.Variable.of(("point",), np.float64, D.GAIT_ATTRS["y_advance"],
                               optional=True),
    "t_switch": D.Variable(("point",), np.float64, "s", "swap time (B at A's height at rest)",
                           optional=True),
    **D.complex_variables("multipliers", ("point", "k"),
                          "Floquet multipliers of the {multiplier_map} (variational equations)"),
}


def write_continuation(path: Path, attrs: dict, result: dict) -> None:
    """Write a continuation dataset from a :func:`continuation_task` result (the grazing
    family's, or a fixed point's with its segment times)."""
    n = len(result["value"])
    par = result["parameter"]
    sequence = "t_segment" in result
    fields = ({"gait": "sequence gait's fixed point", "origin": "floquet step's fixed point",
               "residual": "|P(z) - z| of the return map",
               "multiplier_map": "cycle's return map"} if sequence else
              {"gait": "collisionless gait", "origin": "shoot's gait",
               "residual": "|G| (B's height and velocity at t_switch)",
               "multiplier_map": "motorless open-loop map"})
    fields.update(parameter=par, parameter_units=parameter_units(par))
    with D.atomic_netcdf(path) as nc:

        def write(name, data):
            D.write_declared(nc, VARIABLES, name, data, **fields)

        D.write_coordinate(nc, VARIABLES, "point", np.arange(n), **fields)
        D.write_coordinate(nc, VARIABLES, "k", np.arange(3))
        write("parameter_value", result["value"])
        write("dtheta1", result["dtheta1"])
        write("dtheta2", result["dtheta2"])
        if sequence:
            D.write_coordinate(nc, VARIABLES, "segment",
                               np.arange(np.shape(result["t_segment"])[1]))
            write("residual", result["residual"])
            write("theta2", result["theta2"])
            write("corrector_iterations", result["iterations"])
            for name in ("arclength", "stable", "neutral", "t_segment", "x_advance",
                         "y_advance"):
                write(name, result[name])
            D.write_complex(nc, VARIABLES, "multipliers", result["multipliers"], **fields)
            extra = {"theta2_pinned": int(result["theta2_pinned"]),
                     "steps_per_cycle": int(result["steps_per_cycle"]),
                     "stop_reason": result["stop_reason"],
                     "through_plus_one": list(result["through_plus_one"]),
                     "neimark_sacker": list(result["neimark_sacker"])}
            if result.get("stop_detail"):
                extra["stop_detail"] = result["stop_detail"]
        else:
            write("t_switch", result["t_switch"])
            write("residual", result["residual"])
            D.write_complex(nc, VARIABLES, "multipliers", result["multipliers"], **fields)
            extra = {}
        D.set_global_attrs(nc, dict(attrs, parameter=par, parameter_units=parameter_units(par),
                               value0=float(result["value0"]), folds=list(result["folds"]),
                               period_doublings=list(result["period_doublings"]), **extra))


def stable_reach(value: np.ndarray, stable: np.ndarray) -> str:
    """How far from the start the branch stays stable: ``""`` unless the start is stable;
    the last value before the first unstable point, or the branch's last, with its change
    relative to the start."""
    if value.size == 0 or not stable[0]:
        return ""
    unstable = np.flatnonzero(stable == 0)
    last = (unstable[0] - 1) if unstable.size else value.size - 1
    what = "stable up to" if unstable.size else "stable to the branch's end,"
    rel = value[last] / value[0] - 1.0 if value[0] != 0.0 else math.nan
    return f"; {what} {value[last]:.8g} ({rel:+.3%} of the start)"


def unit_suffix(units) -> str:
    """``" N m"`` after a value; nothing for a ratio (units ``1``) or none."""
    return "" if units in (None, "", "1") else f" {units}"


# --- the kind ------------------------------------------------------------------------------------
def cycle_problems(study, i: int, s: ContinuationStep) -> list:
    """A fixed point's continuation: exact timing, a smooth flow, a motor to continue in,
    mirror symmetry where the cycle needs it."""
    out: list[tuple[tuple, str]] = []
    gait = study.gait.gait()
    if gait.tick != 0.0:
        out.append((("steps", i, "kind"), "continuation needs exact event timing (gait tick "
                    "0): on a tick the return map is not differentiable"))
    rb = study.to_robot()
    if rb.pivot_friction.coulomb or rb.joint_friction.coulomb:
        out.append((("steps", i, "kind"), "continuation needs a smooth flow: Coulomb "
                    "friction is not (the variational equations refuse it)"))
    if s.parameter == "torque" and all(seg.torque == 0.0 for seg in gait.segments) \
            and gait.section_torque == 0.0:
        out.append((("steps", i, "parameter"), "the gait never runs its motor (every torque "
                    "is 0): the motor torque does not move its fixed points"))
    floor = PARAMETER_FLOOR.get(s.parameter)
    if floor is not None and s.ds < 0 and parameter_of(rb, gait, s.parameter) <= floor:
        out.append((("steps", i, "ds"), f"{s.parameter} starts at {floor:g}, its least "
                    f"value: ds < 0 would make it smaller"))
    if s.parameter in LINK_PARAMETERS and gait.clocked:
        out.append((("steps", i, "parameter"), f"{s.parameter} is continued on the cycle of "
                    f"two steps, which needs a clock that restarts at the section (the gait's "
                    f"runs on with its period)"))
    if gait.end_attached() == "B":
        if s.parameter == "mass_ratio":
            out.append((("steps", i, "parameter"), "mass_ratio != 1 breaks the mirror "
                        "symmetry a cycle ending on end B needs: continue a cycle with two "
                        "swaps (ending on A) instead"))
        problem = mirror_problem(rb)
        if problem:
            out.append((("steps", i, "kind"), f"a continuation of a cycle ending on end B "
                        f"{problem}"))
    return out


def grazing_problems(study, i: int, s: ContinuationStep) -> list:
    """The collisionless family of a shoot step's grazing solution: a mirror-symmetric
    parameter, a fixed step, mirror-image links."""
    out = []
    if s.parameter not in GRAZING_PARAMETERS:
        out.append((("steps", i, "parameter"), f"the horizontal gait's collisionless "
                    f"family is continued in {', '.join(GRAZING_PARAMETERS)} (it is "
                    f"motorless and needs mirror-image links); {s.parameter} needs a "
                    f"sequence gait"))
    if s.ds_max is not None:
        out.append((("steps", i, "ds_max"), "the collisionless family is continued "
                    "with a fixed step; ds_max applies to sequence gaits"))
    problem = mirror_problem(study.to_robot())
    if problem:
        out.append((("steps", i, "kind"), f"a {s.kind} step {problem}"))
    return out


class ContinuationKind(StepKind):
    name = "continuation"
    model = ContinuationStep
    variables = VARIABLES
    gait_kinds = ("horizontal", "sequence")
    accepts = ("shoot", "floquet")
    unit = "branches"
    figures = (
        Figure("branch"),
    )

    def check_step(self, study, index, step: ContinuationStep, ref, seen) -> list:
        # a shoot step hands on a grazing solution (a border: its family's own equations),
        # a floquet step a fixed point of the return map
        if ref is None:
            return []
        if ref.kind == "shoot":
            return grazing_problems(study, index, step)
        return cycle_problems(study, index, step)

    def needs_variational(self, step) -> bool:
        return True

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        bounds = tuple(st.bounds) if st.bounds is not None else (-math.inf, math.inf)
        g = ctx.handed_on(grazing=True, replay="gait", require="continue")
        method = "grazing" if g.found_by == "shoot_grazing" else "cycle"
        ctx.state.update(gait=g, method=method)
        kw = {"method": method, "t_switch": g.source.get("t_switch", math.nan),
              "parameter": st.parameter, "ds": st.ds, "steps": st.steps, "bounds": bounds}
        if method == "cycle":
            kw["ds_max"] = st.ds_max
        return [Task(0, continuation_task, (ctx.spec, g.gait, g.z), kw)]

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        st = ctx.step
        r = ctx.results[0]
        cycle = ctx.state["method"] == "cycle"
        attrs.update(ctx.state["gait"].attrs("analysis"))
        if cycle:
            attrs["ds_max"] = st.ds_max if st.ds_max is not None else abs(st.ds)
        attrs.update(ds=st.ds, steps=st.steps,
                     bounds=list(st.bounds) if st.bounds is not None else [])
        write_continuation(ctx.path, attrs, r)
        v = r["value"]
        msg = (f"{len(v)} points, {st.parameter} {v[0]:.6g} -> {v[-1]:.6g}"
               f"{unit_suffix(parameter_units(st.parameter))}, folds {r['folds']}, period doublings "
               f"{r['period_doublings']}, max residual {float(np.max(r['residual'])):.2g}")
        if cycle:
            msg += (f", through +1 {r['through_plus_one']}, Neimark-Sacker "
                    f"{r['neimark_sacker']}, stopped: {r['stop_reason']}")
            if r["stop_detail"]:
                msg += f" ({r['stop_detail']})"
        return msg

    def describe(self, ds) -> list[str]:
        a = ds.attrs
        v = ds["parameter_value"].values
        lam = D.dataset_complex(ds, "multipliers")
        if "t_segment" in ds:      # a sequence gait: leave the neutral multiplier out
            rest = [np.abs(m[~(np.abs(m - 1.0) < 1e-6)]) for m in lam]
            lead = np.array([r.max() if r.size else np.nan for r in rest])
            th2 = ds["theta2"].values
            head = (f"sequence gait, theta2 {th2[0]:.6g} -> {th2[-1]:.6g} rad (pinned: "
                    f"{a.get('theta2_pinned')}), from floquet step {a.get('floquet_step')}; "
                    f"stopped: {a.get('stop_reason')}")
            if int(a.get("steps_per_cycle", 1)) == 2:
                head += "; a cycle of two steps (its multipliers are two steps')"
            if a.get("stop_detail"):
                head += f" ({a['stop_detail']})"
            marks = (f"folds {a.get('folds')}, period doublings {a.get('period_doublings')}, "
                     f"through +1 {a.get('through_plus_one')}, Neimark-Sacker "
                     f"{a.get('neimark_sacker')}; stable at {int(ds['stable'].sum())} of "
                     f"{v.size} points" + stable_reach(v, ds["stable"].values))
        else:
            lead = np.abs(lam[:, 0])
            head = gait_line(a)
            marks = f"folds {a.get('folds')}, period doublings {a.get('period_doublings')}"
        return [head,
                f"{v.size} points, {a.get('parameter')} {v[0]:.8g} -> {v[-1]:.8g}"
                f"{unit_suffix(a.get('parameter_units'))}; max residual {float(np.nanmax(ds['residual'])):.2g}",
                f"dtheta1 {float(ds['dtheta1'][0]):.8g} -> {float(ds['dtheta1'][-1]):.8g}, dtheta2 "
                f"{float(ds['dtheta2'][0]):.8g} -> {float(ds['dtheta2'][-1]):.8g} rad s-1",
                f"leading |lambda| {lead[0]:.6g} -> {lead[-1]:.6g}; " + marks]
