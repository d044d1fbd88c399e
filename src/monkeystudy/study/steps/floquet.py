"""The ``floquet`` step: Floquet multipliers of a gait's return map at its fixed point, by
variational equations (saltation matrices) beside fourth-order central differences.

Horizontal gait: ``open_loop`` (a shoot step's gait replayed with its times) and ``search``
(the state-based controller's own fixed point, polished by Newton). Sequence gait: its own
cycle, from a refine step's result polished by Newton with ``theta2`` free. Later steps of a
sequence gait start from its fixed point (:func:`sequence_start`).
"""
from __future__ import annotations

import dataclasses
import math
from functools import partial
from pathlib import Path
from typing import Any, Literal, Optional

import netCDF4
import numpy as np
from pydantic import Field, field_validator, model_validator

from ...analysis.continuation import motor_torque
from ...analysis.floquet import floquet, solve_fixed_point, sorted_eigs
from ...analysis.sections import cycle_return_map
from ...analysis.variational import sequence_variational_jacobian
from ...controllers import SequenceGait, open_loop_gait
from ...simulate import evaluate_cycle_gaits
from .. import datasets as D
from ..blocks import Task
from ..errors import RunFailed
from ..models import Name, SectionPoint, StrictModel, unique
from ..spec import GaitSpec, mirror_problem
from .base import Figure, StepContext, StepKind, no_earlier
from .refine import RefineStep, read_refined
from .shoot import ShootStep, gait_attrs, gait_line, schedule_replay, shoot_gait

#: multipliers within this distance of 1 are neutral (excluded from ``stable``)
NEUTRAL_TOL = 1e-6

#: the state-based controller's attracting gait (theta2 [rad], dtheta1, dtheta2 [rad s-1]),
#: found by a 1000-cycle run of seed2009 at 0.6354 N m
SEARCH_START = [0.0248, -1.0869, 16.0168]


class FloquetStep(StrictModel):
    """Floquet multipliers of a gait's return map on theta1 = 0: variational equations
    (saltation matrices) beside fourth-order central differences.

    ``open_loop``: the shoot step's best solution replayed with its times (motor torque 0
    when ``t_motor`` is 0). ``search``: the state-based controller's own fixed point,
    polished by Newton from ``search_start``.
    """

    name: Name
    kind: Literal["floquet"]
    from_: Optional[Name] = Field(None, alias="from",
                                  description="an earlier shoot step (needed by open_loop)")
    controllers: list[Literal["open_loop", "search", "sequence"]] = Field(
        ["open_loop", "search"], min_length=1,
        description="return maps to analyse: open_loop, search (horizontal gaits); sequence "
                    "(a sequence gait's cycle: its only one, and its default)")
    search_start: SectionPoint = Field(SEARCH_START, description="start of the Newton "
                                       "polish of the search controller's fixed point "
                                       "(theta2 [rad], dtheta1, dtheta2 [rad s-1])")
    solution: Optional[int] = Field(None, ge=0, description="which solution of the shoot "
                                    "step (default: the lowest error)")
    fd_step: float = Field(1e-5, gt=0, le=1e-2, description="relative finite-difference "
                                                            "step [1]")

    @field_validator("controllers")
    @classmethod
    def _distinct(cls, v: list) -> list:
        return unique(v, "controllers")

    @model_validator(mode="after")
    def _from_for_open_loop(self) -> "FloquetStep":
        if "open_loop" in self.controllers and self.from_ is None:
            raise ValueError("the open_loop controller needs from: <shoot step>")
        return self

    def controllers_for(self, gait_kind: str) -> list[str]:
        """The controllers analysed for a study's gait: a sequence gait's default is its own
        cycle."""
        if gait_kind == "sequence" and "controllers" not in self.model_fields_set:
            return ["sequence"]
        return list(self.controllers)


# --- tasks (run on the workers) ------------------------------------------------------------------
def floquet_task(spec: GaitSpec, controller: str, *, gait: SequenceGait, z0,
                 newton: bool, keep_unconverged: bool = False, schedule=None,
                 fd_step: float = 1e-5) -> dict[str, Any]:
    """Multipliers of ``gait``'s return map (:func:`~monkeystudy.analysis.cycle_return_map`,
    exact timing) at a fixed point, labelled ``controller`` in the dataset.

    ``z0 = (theta2 [rad], dtheta1, dtheta2 [rad s-1])`` is the fixed point, or with
    ``newton`` the start of its Newton polish (:func:`~monkeystudy.analysis.floquet.
    solve_fixed_point` with the variational Jacobian, ``theta2`` free); an unconverged
    polish keeps its last iterate with ``keep_unconverged`` (a start far from the gait), the
    start otherwise. ``schedule``: the recorded swap time and motor duration [s] of an
    open-loop replay, reported as they are (else the cycle's). The Jacobian by variational
    equations (:func:`~monkeystudy.analysis.variational.sequence_variational_jacobian`) and
    by central differences, both sets of multipliers (sorted by decreasing modulus),
    ``map_defect = |P(z) - z|``, ``agreement = max|J - J_fd| / max|J|``, ``stable`` (from
    the variational multipliers, neutral ones excluded), and the cycle at the fixed point
    (segment exit times [s], advance [m], error).
    """
    robot, integ = spec.robot, spec.integrator
    gait = dataclasses.replace(gait, tick=0.0)
    fmap = partial(cycle_return_map, gait=gait, robot=robot, integrator=integ)

    def jac(q):
        return sequence_variational_jacobian(gait, q, robot=robot, integrator=integ)

    out: dict[str, Any] = {"controller": controller, "newton_converged": 1,
                           "newton_history": np.empty(0)}
    z = np.asarray(z0, float)
    if newton:
        try:
            fp = solve_fixed_point(fmap, z, jacobian=jac)
            out["newton_converged"] = int(bool(fp.converged))
            out["newton_history"] = np.asarray(fp.history, float)
            if fp.converged or keep_unconverged:
                z = fp.z
        except RuntimeError:
            out["newton_converged"] = 0
    Jv = jac(z)
    fl = floquet(fmap, z, step=fd_step, neutral_tol=NEUTRAL_TOL)
    lam = sorted_eigs(Jv)
    neutral = np.abs(lam - 1.0) < NEUTRAL_TOL
    at = dataclasses.replace(gait, theta2=float(z[0]))
    r = evaluate_cycle_gaits(np.array([[z[1], z[2]]]), at, robot=robot, integrator=integ)
    t = r["t_segment"][0]
    t_switch, t_motor = ((float(t[0]), float(t[1] - t[0])) if schedule is None else
                         (float(schedule[0]), float(schedule[1])))
    out.update({
        "fixed_point": z, "map_defect": float(fl.map_defect), "jacobian": Jv,
        "jacobian_fd": fl.jacobian, "multipliers": lam, "multipliers_fd": fl.multipliers,
        "stable": int(bool(np.all(np.abs(lam[~neutral]) < 1.0))),
        "neutral": int(neutral.sum()),
        "agreement": float(np.abs(Jv - fl.jacobian).max() / np.abs(Jv).max()),
        "t_switch": t_switch, "t_motor": t_motor, "torque": sequence_torque(gait),
        "t_segment": t.copy(), "x_advance": float(r["x_advance"][0]),
        "y_advance": float(r["y_advance"][0]), "error": float(r["error"][0]),
    })
    return out


# --- the dataset ---------------------------------------------------------------------------------
def write_floquet(path: Path, attrs: dict, results: list[dict], swap_motor: bool) -> None:
    """Write a floquet dataset from :func:`floquet_task` results, one per controller (in the
    step's order); the cycle's times as the 2009 study named them (``swap_motor``:
    ``t_switch``, ``t_motor``, ``motor_torque``) or per segment (``t_segment``, the advance,
    the error; the 2009 names NaN)."""
    with D.atomic_netcdf(path) as nc:
        D.add_label_coord(nc, "controller", [r["controller"] for r in results],
                     "return map: open_loop (recorded times) or search (state-based)")
        D.add_index_coord(nc, "k", 3, "multiplier (by decreasing modulus) or fixed-point component")
        D.add_index_coord(nc, "row", 3, "Jacobian row: d(theta2, dtheta1, dtheta2) after a cycle")
        D.add_index_coord(nc, "col", 3, "Jacobian column: d(theta2, dtheta1, dtheta2) before")

        def stack(key, dtype=np.float64):
            return np.array([r[key] for r in results], dtype=dtype)

        D.add_complex(nc, "multipliers", ("controller", "k"), stack("multipliers", complex),
                      "Floquet multipliers by variational equations (decreasing modulus)")
        D.add_complex(nc, "multipliers_fd", ("controller", "k"),
                      stack("multipliers_fd", complex),
                      "Floquet multipliers by finite differences (decreasing modulus)")
        D.add_variable(nc, "jacobian", ("controller", "row", "col"), np.float64,
             {"long_name": "Jacobian of the return map by variational equations (saltation "
                           "matrices at the events), " + D.SECTION_NOTE, "units": "1"},
             stack("jacobian"))
        D.add_variable(nc, "jacobian_fd", ("controller", "row", "col"), np.float64,
             {"long_name": "Jacobian of the return map by fourth-order central differences, "
                           + D.SECTION_NOTE, "units": "1"}, stack("jacobian_fd"))
        D.add_variable(nc, "fixed_point", ("controller", "k"), np.float64,
             {"long_name": "fixed point " + D.SECTION_NOTE, "units": "1",
              "components": "theta2 dtheta1 dtheta2", "component_units": "rad, rad s-1, rad s-1"},
             stack("fixed_point"))
        D.add_variable(nc, "map_defect", ("controller",), np.float64,
             {"long_name": "|P(z) - z| at the fixed point", "units": "1"}, stack("map_defect"))
        D.add_variable(nc, "stable", ("controller",), np.int8,
             {"long_name": "all multipliers inside the unit circle (1), neutral ones "
                           "(|lambda - 1| < 1e-6) excluded", "units": "1"},
             stack("stable", np.int8))
        D.add_variable(nc, "neutral", ("controller",), np.int8,
             {"long_name": "neutral multipliers (|lambda - 1| < 1e-6)", "units": "1"},
             stack("neutral", np.int8))
        D.add_variable(nc, "agreement", ("controller",), np.float64,
             {"long_name": "max |J - J_fd| / max |J|", "units": "1"}, stack("agreement"))
        def named(key):
            return stack(key) if swap_motor else np.full(len(results), np.nan)

        D.add_variable(nc, "t_switch", ("controller",), np.float64,
             {"long_name": "swap time of the fixed point's cycle", "units": "s"},
             named("t_switch"))
        D.add_variable(nc, "t_motor", ("controller",), np.float64,
             {"long_name": "motor-on duration of the fixed point's cycle", "units": "s"},
             named("t_motor"))
        D.add_variable(nc, "motor_torque", ("controller",), np.float64,
             {"long_name": "motor torque of the return map", "units": "N m"}, named("torque"))
        if not swap_motor:       # the cycle's segments
            D.add_index_coord(nc, "segment", len(results[0]["t_segment"]), D.SEGMENT_NOTE)
            D.add_variable(nc, "t_segment", ("controller", "segment"), np.float64,
                 D.GAIT_ATTRS["t_segment"], stack("t_segment"))
            for key in ("x_advance", "y_advance"):
                D.add_variable(nc, key, ("controller",), np.float64, D.GAIT_ATTRS[key], stack(key))
            D.add_variable(nc, "error", ("controller",), np.float64, D.SEQUENCE_ATTRS["error"],
                 stack("error"))
        D.add_variable(nc, "newton_converged", ("controller",), np.int8,
             {"long_name": "Newton polish of the fixed point converged (1; open_loop: the "
                           "shoot's point, 1)", "units": "1"},
             stack("newton_converged", np.int8))
        D.set_global_attrs(nc, attrs)


def read_floquet_point(path: Path, controller: str = "sequence") -> dict:
    """One controller's analysed point of a floquet dataset: ``{fixed_point (3,), map_defect,
    newton_converged, t_switch, t_motor [s], motor_torque [N m]}`` (``newton_converged`` -1
    when the dataset has none; the times NaN for a sequence gait)."""
    with netCDF4.Dataset(path, "r") as nc:
        nc.set_auto_mask(False)
        labels = [str(x) for x in np.atleast_1d(nc.variables["controller"][...])]
        if controller not in labels:
            raise ValueError(f"{Path(path).name} has no {controller} controller")
        i = labels.index(controller)
        out = {"fixed_point": np.array(nc.variables["fixed_point"][i, :], float),
               "map_defect": float(nc.variables["map_defect"][i])}
        nc_conv = nc.variables.get("newton_converged")
        out["newton_converged"] = int(nc_conv[i]) if nc_conv is not None else -1
        for key in ("t_switch", "t_motor", "motor_torque"):
            out[key] = float(nc.variables[key][i]) if key in nc.variables else math.nan
    return out


def read_floquet_multipliers(path: Path, controller: str = "open_loop") -> np.ndarray:
    """The variational multipliers of one controller of a floquet dataset (complex)."""
    with netCDF4.Dataset(path, "r") as nc:
        nc.set_auto_mask(False)
        labels = [str(x) for x in np.atleast_1d(nc.variables["controller"][...])]
        if controller not in labels:
            raise ValueError(f"{Path(path).name} has no {controller} controller")
        i = labels.index(controller)
        re = np.array(nc.variables["multipliers_real"][i, :])
        im = np.array(nc.variables["multipliers_imag"][i, :])
    return re + 1j * im


# --- the fixed point later steps of a sequence gait use ------------------------------------------
def sequence_start(ctx: StepContext, max_map_defect: float | None = None) -> dict:
    """Where a sequence gait's multi-cycle step starts: ``{z: (theta2, dtheta1, dtheta2),
    source, source_kind, ...}`` from its ``from:`` floquet step (the fixed point) or refine
    step (the refined rates at the section's theta2). A floquet point whose Newton polish
    stopped short is refused, unless the map moves it less than ``max_map_defect`` [1]."""
    st = ctx.step
    src = ctx.deps[st.from_]
    section_theta1 = ctx.study.gait.section.theta1
    if src.kind == "refine":
        g, idx = read_refined(src.path, getattr(st, "start_index", None))
        if g["status"] != 0 or not math.isfinite(g["error"]):
            raise RunFailed(f"{ctx.name}: refine step {st.from_!r} found no cycle to run "
                            f"(status {g['status']})")
        theta2 = ctx.study.gait.section.theta2
        return {"z": np.array([theta2, g["dtheta1"], g["dtheta2"]]), "source": st.from_,
                "source_kind": "refine", "index": idx, "gait_error": g["error"],
                "section_theta1": section_theta1}
    fp = read_floquet_point(src.path, "sequence")
    close = max_map_defect is not None and fp["map_defect"] <= max_map_defect
    if (fp["newton_converged"] == 0 and not close) or not np.all(np.isfinite(fp["fixed_point"])):
        raise RunFailed(f"{ctx.name}: floquet step {st.from_!r} did not converge to a fixed "
                        f"point (map defect {fp['map_defect']:.3g}): nothing to run")
    return {"z": np.asarray(fp["fixed_point"], float), "source": st.from_,
            "source_kind": "floquet", "index": -1, "map_defect": fp["map_defect"],
            "section_theta1": section_theta1}


def sequence_attrs(gait: dict, replay: str) -> dict:
    """Global attributes naming a sequence gait's start and how it was run."""
    z = gait["z"]
    out = {"replay": replay, f"{gait['source_kind']}_step": gait["source"],
           "start_theta2": float(z[0]), "dtheta1": float(z[1]), "dtheta2": float(z[2]),
           "section_theta1": float(gait["section_theta1"])}
    if gait["source_kind"] == "refine":
        out.update(refine_start=int(gait["index"]), gait_error=float(gait["gait_error"]))
    else:
        out["map_defect"] = float(gait["map_defect"])
    return out


def sequence_torque(gait) -> float:
    """A sequence gait's reference motor torque [N m] (0 when it never runs its motor)."""
    try:
        return motor_torque(gait)
    except ValueError:
        return 0.0


def check_sequence_replay(study, i: int, s, seen: dict) -> list:
    """A sequence gait's multi-cycle runs start from a floquet step's fixed point (a
    stability step also from a refine step's start)."""
    out: list[tuple[tuple, str]] = []
    ref = seen.get(s.from_)
    kinds = (FloquetStep, RefineStep) if s.kind == "stability" else (FloquetStep,)
    if not isinstance(ref, kinds):
        out.append((("steps", i, "from"), no_earlier(
            s.from_, "floquet or refine" if s.kind == "stability" else "floquet", ref)))
    if s.kind == "stability":
        if s.controller.clock != "reset_at_vertical":
            out.append((("steps", i, "controller", "clock"), "a sequence gait's clock "
                        "restarts at each section crossing (reset_at_vertical)"))
        if s.start_index is not None and isinstance(ref, RefineStep):
            k = ref.n_starts
            if s.start_index >= k:
                out.append((("steps", i, "start_index"),
                            f"must be < {k} (the starts of {ref.name!r})"))
        elif s.start_index is not None:
            out.append((("steps", i, "start_index"), "start_index picks a refine step's "
                        "start; a floquet step has one fixed point"))
    if s.kind in ("tick_sweep", "basin") and s.solution is not None:
        out.append((("steps", i, "solution"), "solution picks a shoot step's solution; a "
                    "floquet step has one fixed point"))
    if s.kind == "tick_sweep" and s.floquet is not None:
        out.append((("steps", i, "floquet"), "a sequence gait's tick_sweep takes its fixed "
                    "point and multipliers from its from: floquet step"))
    if study.gait.gait().end_attached() == "B":
        problem = mirror_problem(study.to_robot())
        if problem:
            out.append((("steps", i, "kind"), f"a {s.kind} step of a cycle ending on end B "
                        f"{problem}"))
    return out


# --- the kind ------------------------------------------------------------------------------------
class FloquetKind(StepKind):
    name = "floquet"
    model = FloquetStep
    gait_kinds = ("horizontal", "sequence")
    unit = "controllers"
    figures = (
        Figure("multipliers", "multipliers and the unit circle",
               "The return map's Floquet multipliers in the complex plane: any outside the "
               "unit circle makes the gait unstable; variational equations (filled) and finite "
               "differences (open) must coincide."),
    )

    def check(self, study, index, step: FloquetStep, seen) -> list:
        out = []
        if study.gait.kind == "sequence":
            if step.controllers_for("sequence") != ["sequence"]:
                out.append((("steps", index, "controllers"), "a sequence gait has one return "
                            "map: controllers: [sequence] (the default)"))
            if step.from_ is None or not isinstance(seen.get(step.from_), RefineStep):
                out.append((("steps", index, "from"),
                            "a sequence gait's floquet step needs from: <refine step>"
                            if step.from_ is None else
                            no_earlier(step.from_, "refine", seen.get(step.from_))))
            if study.gait.gait().end_attached() == "B":
                problem = mirror_problem(study.to_robot())
                if problem:
                    out.append((("steps", index, "kind"), f"a floquet step of a cycle ending "
                                f"on end B {problem}"))
            return out
        if step.from_ is not None and not isinstance(seen.get(step.from_), ShootStep):
            out.append((("steps", index, "from"), no_earlier(step.from_, "shoot",
                                                             seen.get(step.from_))))
        if "sequence" in step.controllers:
            out.append((("steps", index, "controllers"), "the sequence controller needs a "
                        "sequence gait (gait: {kind: sequence, ...})"))
        problem = mirror_problem(study.to_robot())
        if problem:
            out.append((("steps", index, "kind"), f"a {step.kind} step {problem}"))
        return out

    def n_tasks(self, step: FloquetStep, gait_kind: str) -> int:
        return len(step.controllers_for(gait_kind))

    def needs_variational(self, step) -> bool:
        return True

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        controllers = st.controllers_for(ctx.gait_kind)
        if controllers == ["sequence"]:
            g, idx = read_refined(ctx.deps[st.from_].path)
            if g["status"] != 0 or not math.isfinite(g["error"]):
                raise RunFailed(f"{ctx.name}: refine step {st.from_!r} found no cycle to "
                                f"analyse (status {g['status']})")
            g["index"] = idx
        else:
            g = shoot_gait(ctx, st.from_, st.solution) if "open_loop" in controllers else None
        ctx.state["gait"] = g
        tasks = []
        for i, c in enumerate(controllers):
            kw = {"fd_step": st.fd_step}
            if c == "open_loop":       # the shoot's gait replayed with its times
                gait, z, times = schedule_replay(ctx.spec, g)
                kw.update(gait=open_loop_gait(gait, times), z0=z, newton=False,
                          schedule=(float(g["t_switch"]), float(g["t_motor"])))
            elif c == "search":        # the gait's own controller from search_start
                kw.update(gait=ctx.spec.sequence, z0=list(st.search_start), newton=True,
                          keep_unconverged=True)
            else:                      # the gait's own controller from the refined start
                kw.update(gait=ctx.spec.sequence, newton=True,
                          z0=[ctx.spec.sequence.theta2, g["dtheta1"], g["dtheta2"]])
            tasks.append(Task(i, floquet_task, (ctx.spec, c), kw))
        return tasks

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        st = ctx.step
        results = ctx.task_results()
        controllers = st.controllers_for(ctx.gait_kind)
        g = ctx.state["gait"]
        if controllers == ["sequence"]:
            attrs.update(refine_step=st.from_, refine_start=int(g["index"]),
                         dtheta1=g["dtheta1"], dtheta2=g["dtheta2"], gait_error=g["error"])
        else:
            attrs.update(gait_attrs(st.from_, g))
            attrs["search_start"] = list(st.search_start)
        attrs.update(fd_step=st.fd_step, neutral_tol=NEUTRAL_TOL, controllers=controllers)
        write_floquet(ctx.path, attrs, results, swap_motor=ctx.spec.horizontal)
        parts = []
        for r in results:
            lam = np.abs(r["multipliers"])
            parts.append(f"{r['controller']}: |lambda| {', '.join(f'{x:.4g}' for x in lam)} "
                         f"({'stable' if r['stable'] else 'unstable'}, agreement "
                         f"{r['agreement']:.2g})")
        return "; ".join(parts)

    def describe(self, ds) -> list[str]:
        a = ds.attrs
        out = [gait_line(a)]
        lam, lam_fd = D.dataset_complex(ds, "multipliers"), D.dataset_complex(ds, "multipliers_fd")
        for i, c in enumerate(ds["controller"].values):
            fp = ds["fixed_point"].values[i]
            out.append(f"{c}: multipliers {np.array2string(lam[i], precision=6)} (|lambda| "
                       f"{D.moduli(lam[i])}), {'stable' if int(ds['stable'][i]) else 'unstable'}")
            out.append(f"  finite differences |lambda| {D.moduli(lam_fd[i])}; agreement "
                       f"{float(ds['agreement'][i]):.2g}; map defect "
                       f"{float(ds['map_defect'][i]):.2g}")
            out.append(f"  fixed point (theta2, dtheta1, dtheta2) = ({fp[0]:.8g}, {fp[1]:.8g}, "
                       f"{fp[2]:.8g}); t_switch {float(ds['t_switch'][i]):.6g} s, t_motor "
                       f"{float(ds['t_motor'][i]):.6g} s")
        return out

