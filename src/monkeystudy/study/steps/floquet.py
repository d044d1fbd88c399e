"""The ``floquet`` step: Floquet multipliers of a gait's return map at its fixed point, by
variational equations (saltation matrices) beside fourth-order central differences.

Return maps: ``open_loop`` (a shoot step's gait replayed with its times), ``search`` (the
gait's own controller, its fixed point polished by Newton from ``search_start``) and
``sequence`` (the gait's own cycle from a refine step's result polished by Newton with
``theta2`` free); the study's gait names the ones it has (:class:`~monkeystudy.study.models.
Conventions`). Later steps start from the fixed point
(:func:`~monkeystudy.study.steps.gait_source.floquet_start`).
"""
from __future__ import annotations

import dataclasses
import math
from functools import partial
from pathlib import Path
from typing import Any, ClassVar, Literal, Optional

import numpy as np
from pydantic import Field, field_validator, model_validator

from ...analysis.multipliers import floquet, jacobian_fd, solve_fixed_point, sorted_eigs
from ...analysis.sections import (
    bar_catch_rows, cycle_catches, cycle_full_map, cycle_map_error, cycle_return_map,
)
from ...analysis.variational import sequence_variational_jacobian
from ...controllers import SequenceGait, open_loop_gait
from ...simulation import evaluate_cycle_gaits
from .. import datasets as D
from ..blocks import Task
from ..models import Name, SectionPoint, StrictModel, unique
from ..spec import GaitSpec, mirror_problem
from .base import Dependency, Figure, StepContext, StepKind
from .gait_source import (
    floquet_start, gait_line, motor_torque_of, no_start_attrs, option_problems, read_start,
)

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
    from_: Optional[Name] = Field(None, alias="from")  # described by the kind (accepts)
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
    height_in_map: bool = Field(False, description="also analyse the full map (y, theta2, "
                                "dtheta1, dtheta2), y the attached end's height relative to "
                                "the start (with the gait's rise, to the route's planned "
                                "height) [m]: its Jacobian by variational equations and by "
                                "finite differences, its multipliers and spectral radius "
                                "(the height is neutral unless a guard senses a world "
                                "height, e.g. a catch until: free_end_y; a catch until: bar "
                                "resets it to the bar's, so its row is zero)")

    recorded_when_set: ClassVar[frozenset[str]] = frozenset({"height_in_map"})

    @field_validator("controllers")
    @classmethod
    def _distinct(cls, v: list) -> list:
        return unique(v, "controllers")

    @model_validator(mode="after")
    def _from_for_open_loop(self) -> "FloquetStep":
        if "open_loop" in self.controllers and self.from_ is None:
            raise ValueError("the open_loop controller needs from: <shoot step>")
        return self

    def controllers_for(self, gait) -> list[str]:
        """The controllers analysed for a study's ``gait`` (its model): by default the ones
        its conventions name (:class:`~monkeystudy.study.models.Conventions`)."""
        if "controllers" not in self.model_fields_set:
            return list(gait.conventions.floquet_controllers)
        return list(self.controllers)


# --- tasks (run on the workers) ------------------------------------------------------------------
def floquet_task(spec: GaitSpec, controller: str, *, gait: SequenceGait, z0,
                 newton: bool, keep_unconverged: bool = False, schedule=None,
                 fd_step: float = 1e-5, height: bool = False) -> dict[str, Any]:
    """Multipliers of ``gait``'s return map (:func:`~monkeystudy.analysis.cycle_return_map`,
    exact timing) at a fixed point, labelled ``controller`` in the dataset.

    ``z0 = (theta2 [rad], dtheta1, dtheta2 [rad s-1])`` is the fixed point, or with
    ``newton`` the start of its Newton polish (:func:`~monkeystudy.analysis.multipliers.
    solve_fixed_point` with the variational Jacobian, ``theta2`` free, a residual within
    the map's error level accepted); an unconverged polish keeps its last iterate with
    ``keep_unconverged`` (a start far from the gait), the start otherwise, and says so in
    ``newton_stop``. ``map_error`` is the map's error level at ``z0`` (:func:`~monkeystudy.
    analysis.sections.cycle_map_error`: the map at a tenth of the integrator's
    tolerances). ``schedule``: the recorded swap time and motor duration [s] of an
    open-loop replay, reported as they are (else the cycle's). The Jacobian by variational
    equations (:func:`~monkeystudy.analysis.variational.sequence_variational_jacobian`) and
    by central differences, both sets of multipliers (sorted by decreasing modulus),
    ``map_defect = |P(z) - z|``, ``agreement = max|J - J_fd| / max|J|``, ``stable`` (from
    the variational multipliers, neutral ones excluded), and the cycle at the fixed point
    (segment exit times [s], advance [m], error). With ``height``, the same for the full
    map (:func:`full_map_analysis`): keys ``full_*``. A gait that catches bars adds each
    catch's offset margin and the hook's speed just before it (:func:`catch_measures`).
    """
    robot, integ = spec.robot, spec.integrator
    gait = dataclasses.replace(gait, tick=0.0)
    fmap = partial(cycle_return_map, gait=gait, robot=robot, integrator=integ)

    def jac(q):
        return sequence_variational_jacobian(gait, q, robot=robot, integrator=integ)

    z = np.asarray(z0, float)
    error_level = cycle_map_error(z, gait, robot=robot, integrator=integ)
    out: dict[str, Any] = {"controller": controller, "newton_converged": 1,
                           "newton_history": np.empty(0), "map_error": error_level,
                           "newton_stop": ""}
    if newton:
        try:
            fp = solve_fixed_point(fmap, z, jacobian=jac, map_error=error_level)
            out["newton_converged"] = int(bool(fp.converged))
            out["newton_history"] = np.asarray(fp.history, float)
            out["newton_stop"] = fp.message
            if fp.converged or keep_unconverged:
                z = fp.z
            if not fp.converged:
                out["newton_stop"] += (": analysed at Newton's last iterate" if
                                       keep_unconverged else ": analysed at its start")
        except RuntimeError as exc:
            out["newton_converged"] = 0
            out["newton_stop"] = f"not converged: {exc}: analysed at its start"
    at = dataclasses.replace(gait, theta2=float(z[0]))
    r = evaluate_cycle_gaits(np.array([[z[1], z[2]]]), at, robot=robot, integrator=integ)
    if bar_catch_rows(gait):
        out.update(catch_measures(spec, gait, z))
    try:
        Jv = jac(z)
        fl = floquet(fmap, z, step=fd_step, neutral_tol=NEUTRAL_TOL)
        if height:
            out.update(full_map_analysis(spec, gait, z, fd_step))
    except RuntimeError as exc:
        # no cycle from z, or one whose events the variational run meets in another order:
        # a finding about this gait at this point, recorded rather than ending the run
        return not_analysed(out, z, gait, r, schedule, str(exc), height)
    lam = sorted_eigs(Jv)
    neutral = np.abs(lam - 1.0) < NEUTRAL_TOL
    t = r["t_segment"][0]
    t_switch, t_motor = ((float(t[0]), float(t[1] - t[0])) if schedule is None else
                         (float(schedule[0]), float(schedule[1])))
    out.update({
        "failure": "",
        "fixed_point": z, "map_defect": float(fl.map_defect), "jacobian": Jv,
        "jacobian_fd": fl.jacobian, "multipliers": lam, "multipliers_fd": fl.multipliers,
        "stable": int(bool(np.all(np.abs(lam[~neutral]) < 1.0))),
        "neutral": int(neutral.sum()),
        "agreement": float(np.abs(Jv - fl.jacobian).max() / np.abs(Jv).max()),
        "t_switch": t_switch, "t_motor": t_motor, "torque": motor_torque_of(gait),
        "t_segment": t.copy(), "x_advance": float(r["x_advance"][0]),
        "y_advance": float(r["y_advance"][0]), "error": float(r["error"][0]),
    })
    return out


def catch_measures(spec: GaitSpec, gait: SequenceGait, z) -> dict:
    """The bar catches of the cycle from section state ``z``
    (:func:`~monkeystudy.analysis.sections.cycle_catches`), one value per catching segment
    of the gait (:func:`~monkeystudy.analysis.sections.bar_catch_rows`, in order):
    ``catch_offset_margin`` [m] (the bar's window less the free end's horizontal distance
    from it at the catch) and ``catch_speed`` [m s-1] (the free end's speed just before
    it); NaN for a segment that made no catch (a cycle that stopped before it)."""
    rows = bar_catch_rows(gait)
    margin, speed = np.full(len(rows), np.nan), np.full(len(rows), np.nan)
    c = cycle_catches(z, gait, robot=spec.robot, integrator=spec.integrator)
    for k, seg in enumerate(c.segment):
        if seg in rows:
            margin[rows.index(seg)], speed[rows.index(seg)] = c.margin[k], c.speed[k]
    return {"catch_segment": np.array(rows, int), "catch_offset_margin": margin,
            "catch_speed": speed}


def catches_text(r: dict) -> str:
    """A result's catches in words: offset margins [mm] and catch speeds [m s-1]."""
    return ("catch offset margin " + ", ".join(f"{1e3 * m:.4g}" for m in
                                               r["catch_offset_margin"]) + " mm, speed "
            + ", ".join(f"{v:.4g}" for v in r["catch_speed"]) + " m/s")


def full_map_analysis(spec: GaitSpec, gait: SequenceGait, z, fd_step: float) -> dict:
    """The full map (:func:`~monkeystudy.analysis.cycle_full_map`: ``(y [m], theta2 [rad],
    dtheta1, dtheta2 [rad s-1])``, the cycle started at height ``y = 0``) at the section
    state ``z``: its Jacobian by variational equations and by fourth-order central
    differences (relative step ``fd_step``), both sets of multipliers (decreasing modulus),
    the spectral radius of each, ``max|J - J_fd| / max|J|`` and ``full_stable`` (every
    multiplier inside the unit circle: a neutral height is not stable). ``RuntimeError`` when
    the cycle or its variational run fails."""
    robot, integ = spec.robot, spec.integrator
    w = np.concatenate([[0.0], np.asarray(z, float)])
    Jv = sequence_variational_jacobian(gait, w, robot=robot, integrator=integ, height=True)
    Jfd = jacobian_fd(partial(cycle_full_map, gait=gait, robot=robot, integrator=integ), w,
                      fd_step)
    lam, lam_fd = sorted_eigs(Jv), sorted_eigs(Jfd)
    return {"full_jacobian": Jv, "full_jacobian_fd": Jfd, "full_multipliers": lam,
            "full_multipliers_fd": lam_fd,
            "full_spectral_radius": float(np.abs(lam).max()),
            "full_spectral_radius_fd": float(np.abs(lam_fd).max()),
            "full_agreement": float(np.abs(Jv - Jfd).max() / np.abs(Jv).max()),
            "full_stable": int(bool(np.all(np.abs(lam) < 1.0)))}


def not_analysed(out: dict, z, gait: SequenceGait, cycle: dict, schedule,
                 reason: str, height: bool = False) -> dict[str, Any]:
    """The result of a return map that could not be analysed at ``z``: the point tried, its
    ``cycle`` as :func:`~monkeystudy.simulation.evaluate_cycle_gaits` ran it, NaN multipliers
    and Jacobians (the full map's too, with ``height``), not stable, and the ``reason`` (the
    analysis' error)."""
    nan3, nan33 = np.full(3, np.nan), np.full((3, 3), np.nan)
    if height:
        nan4, nan44 = np.full(4, np.nan), np.full((4, 4), np.nan)
        out.update({"full_jacobian": nan44, "full_jacobian_fd": nan44.copy(),
                    "full_multipliers": nan4.astype(complex),
                    "full_multipliers_fd": nan4.astype(complex),
                    "full_spectral_radius": math.nan, "full_spectral_radius_fd": math.nan,
                    "full_agreement": math.nan, "full_stable": 0})
    t = cycle["t_segment"][0]
    t_switch, t_motor = ((float(t[0]), float(t[1] - t[0])) if schedule is None else
                         (float(schedule[0]), float(schedule[1])))
    out.update({
        "failure": reason, "fixed_point": np.asarray(z, float), "map_defect": math.nan,
        "jacobian": nan33, "jacobian_fd": nan33, "multipliers": nan3.astype(complex),
        "multipliers_fd": nan3.astype(complex), "stable": 0, "neutral": 0,
        "agreement": math.nan, "t_switch": t_switch, "t_motor": t_motor,
        "torque": motor_torque_of(gait), "t_segment": cycle["t_segment"][0].copy(),
        "x_advance": float(cycle["x_advance"][0]), "y_advance": float(cycle["y_advance"][0]),
        "error": float(cycle["error"][0]),
    })
    return out


# --- the dataset ---------------------------------------------------------------------------------
#: the full map's components, with units
FULL_COMPONENTS = "y theta2 dtheta1 dtheta2"
FULL_UNITS = "m, rad, rad s-1, rad s-1"
FULL_NOTE = ("of the full map on the section, components (y [m]: the attached end's height "
             "relative to {planned}, theta2 [rad], dtheta1 [rad s-1], dtheta2 [rad s-1])")
#: what the full map's height is measured from: the start, or with a gait's rise the route's
#: staircase (:func:`~monkeystudy.analysis.cycle_full_map`)
FULL_FROM_START = "the start"
FULL_FROM_STAIRCASE = ("its planned height (the start's plus the gait's rise, attribute, per "
                       "cycle)")


#: the variables of a floquet dataset (docs/datasets.md): a sequence gait's cycle adds its
#: segments, ``height_in_map: true`` the full map's (``full_``) variables
VARIABLES = {
    "controller": D.label_coordinate("controller", "return map: open_loop (recorded times) "
                                     "or search (state-based)"),
    "k": D.index_coordinate("k", "multiplier (by decreasing modulus) or fixed-point component"),
    "row": D.index_coordinate("row", "Jacobian row: d(theta2, dtheta1, dtheta2) after a cycle"),
    "col": D.index_coordinate("col", "Jacobian column: d(theta2, dtheta1, dtheta2) before"),
    **D.complex_variables("multipliers", ("controller", "k"), "Floquet multipliers by "
                          "variational equations (decreasing modulus)"),
    **D.complex_variables("multipliers_fd", ("controller", "k"), "Floquet multipliers by "
                          "finite differences (decreasing modulus)"),
    "jacobian": D.Variable(("controller", "row", "col"), np.float64, "1",
                           "Jacobian of the return map by variational equations (saltation "
                           "matrices at the events), " + D.SECTION_NOTE),
    "jacobian_fd": D.Variable(("controller", "row", "col"), np.float64, "1",
                              "Jacobian of the return map by fourth-order central "
                              "differences, " + D.SECTION_NOTE),
    "fixed_point": D.Variable(("controller", "k"), np.float64, "1",
                              "fixed point " + D.SECTION_NOTE,
                              {"components": "theta2 dtheta1 dtheta2",
                               "component_units": "rad, rad s-1, rad s-1"}),
    "map_defect": D.Variable(("controller",), np.float64, "1", "|P(z) - z| at the fixed point"),
    "stable": D.Variable(("controller",), np.int8, "1",
                         "all multipliers inside the unit circle (1), neutral ones "
                         "(|lambda - 1| < 1e-6) excluded"),
    "neutral": D.Variable(("controller",), np.int8, "1",
                          "neutral multipliers (|lambda - 1| < 1e-6)"),
    "agreement": D.Variable(("controller",), np.float64, "1", "max |J - J_fd| / max |J|"),
    "t_switch": D.Variable(("controller",), np.float64, "s",
                           "swap time of the fixed point's cycle"),
    "t_motor": D.Variable(("controller",), np.float64, "s",
                          "motor-on duration of the fixed point's cycle"),
    "motor_torque": D.Variable(("controller",), np.float64, "N m",
                               "motor torque of the return map"),
    "segment": D.index_coordinate("segment", D.SEGMENT_NOTE, optional=True),
    "t_segment": D.Variable.of(("controller", "segment"), np.float64,
                               D.GAIT_ATTRS["t_segment"], optional=True),
    "x_advance": D.Variable.of(("controller",), np.float64, D.GAIT_ATTRS["x_advance"],
                               optional=True),
    "y_advance": D.Variable.of(("controller",), np.float64, D.GAIT_ATTRS["y_advance"],
                               optional=True),
    "error": D.Variable.of(("controller",), np.float64, D.SEQUENCE_ATTRS["error"],
                           optional=True),
    "failure": D.Variable(("controller",), str, "1", "why the return map was not analysed "
                          "at its point (empty: analysed)"),
    "newton_converged": D.Variable(("controller",), np.int8, "1",
                                   "Newton polish of the fixed point converged (1; "
                                   "open_loop: the shoot's point, 1)"),
    "newton_stop": D.Variable(("controller",), str, "1", "why the Newton polish stopped, "
                              "and where an unconverged one was analysed (empty: no "
                              "polish, open_loop)"),
    "map_error": D.Variable(("controller",), np.float64, "1",
                            "error level of the return map at the start: |P(z) - P'(z)|, P' "
                            "the map at a tenth of the integrator's tolerances (Newton "
                            "accepts a residual within it)"),
    # the full map (height_in_map: true)
    "full_k": D.index_coordinate("full_k", "full-map multiplier (by decreasing modulus)",
                                 optional=True),
    "full_row": D.index_coordinate("full_row", "full-map Jacobian row: d(y, theta2, dtheta1, "
                                   "dtheta2) after a cycle", optional=True),
    "full_col": D.index_coordinate("full_col", "full-map Jacobian column: d(y, theta2, "
                                   "dtheta1, dtheta2) before", optional=True),
    **D.complex_variables("full_multipliers", ("controller", "full_k"),
                          "multipliers of the full map (height included) by variational "
                          "equations (decreasing modulus)", optional=True),
    **D.complex_variables("full_multipliers_fd", ("controller", "full_k"),
                          "multipliers of the full map (height included) by finite "
                          "differences (decreasing modulus)", optional=True),
    **{key: D.Variable(("controller", "full_row", "full_col"), np.float64, "1",
                       f"Jacobian by {how} " + FULL_NOTE,
                       {"components": FULL_COMPONENTS, "component_units": FULL_UNITS},
                       optional=True)
       for key, how in (("full_jacobian", "variational equations (saltation matrices at the "
                         "events)"), ("full_jacobian_fd", "fourth-order central differences"))},
    **{key: D.Variable(("controller",), np.float64, "1", "spectral radius of the full map "
                       f"(height included) by {how}: the largest multiplier modulus",
                       optional=True)
       for key, how in (("full_spectral_radius", "variational equations"),
                        ("full_spectral_radius_fd", "finite differences"))},
    "full_agreement": D.Variable(("controller",), np.float64, "1",
                                 "max |J - J_fd| / max |J| of the full map", optional=True),
    "full_stable": D.Variable(("controller",), np.int8, "1",
                              "every multiplier of the full map inside the unit circle (1; "
                              "a neutral height, multiplier 1, is not stable)", optional=True),
    # a gait that catches bars (until: bar)
    "catch": D.index_coordinate("catch", "bar catch of the cycle, in the order of its "
                                "segments", optional=True),
    "catch_segment": D.Variable(("catch",), np.int32, "1", "segment (from 0) whose until: "
                                "bar guard makes the catch", optional=True),
    "catch_offset_margin": D.Variable(("controller", "catch"), np.float64, "m",
                                      "the bar's window less the free end's horizontal "
                                      "distance from the bar at the catch (positive: caught; "
                                      "small: close to missing the bar; NaN: no catch)",
                                      optional=True),
    "catch_speed": D.Variable(("controller", "catch"), np.float64, "m s-1",
                              "speed of the free end (the hook) just before the catch",
                              optional=True),
}


def write_floquet(path: Path, attrs: dict, results: list[dict], swap_motor: bool,
                  height: bool = False, rise: float = 0.0) -> None:
    """Write a floquet dataset from :func:`floquet_task` results, one per controller (in the
    step's order); the cycle's times as the 2009 study named them (``swap_motor``:
    ``t_switch``, ``t_motor``, ``motor_torque``) or per segment (``t_segment``, the advance,
    the error; the 2009 names NaN); with ``height`` the full map's variables
    (:func:`write_full_map`, its height from the staircase of the gait's ``rise`` [m per
    cycle])."""
    with D.atomic_netcdf(path) as nc:
        D.write_coordinate(nc, VARIABLES, "controller", [r["controller"] for r in results])
        for dim in ("k", "row", "col"):
            D.write_coordinate(nc, VARIABLES, dim, np.arange(3))

        def stack(key, dtype=np.float64):
            return np.array([r[key] for r in results], dtype=dtype)

        D.write_complex(nc, VARIABLES, "multipliers", stack("multipliers", complex))
        D.write_complex(nc, VARIABLES, "multipliers_fd", stack("multipliers_fd", complex))
        for key in ("jacobian", "jacobian_fd", "fixed_point", "map_defect"):
            D.write_declared(nc, VARIABLES, key, stack(key))
        D.write_declared(nc, VARIABLES, "stable", stack("stable", np.int8))
        D.write_declared(nc, VARIABLES, "neutral", stack("neutral", np.int8))
        D.write_declared(nc, VARIABLES, "agreement", stack("agreement"))

        def named(key):
            return stack(key) if swap_motor else np.full(len(results), np.nan)

        D.write_declared(nc, VARIABLES, "t_switch", named("t_switch"))
        D.write_declared(nc, VARIABLES, "t_motor", named("t_motor"))
        D.write_declared(nc, VARIABLES, "motor_torque", named("torque"))
        if not swap_motor:       # the cycle's segments
            D.write_coordinate(nc, VARIABLES, "segment", np.arange(len(results[0]["t_segment"])))
            for key in ("t_segment", "x_advance", "y_advance", "error"):
                D.write_declared(nc, VARIABLES, key, stack(key))
        D.write_declared(nc, VARIABLES, "failure",
                         np.array([r["failure"] for r in results], object))
        D.write_declared(nc, VARIABLES, "newton_converged", stack("newton_converged", np.int8))
        D.write_declared(nc, VARIABLES, "newton_stop",
                         np.array([r["newton_stop"] for r in results], object))
        D.write_declared(nc, VARIABLES, "map_error", stack("map_error"))
        if height:
            write_full_map(nc, results, rise)
        if "catch_segment" in results[0]:
            write_catches(nc, results)
        D.set_global_attrs(nc, attrs)


def write_full_map(nc, results: list[dict], rise: float = 0.0) -> None:
    """The full map's variables of a floquet dataset (dims ``full_k``, ``full_row``,
    ``full_col``: 4), from :func:`full_map_analysis` results; ``rise`` [m per cycle]: the
    gait's (the height measured from its staircase)."""
    planned = FULL_FROM_STAIRCASE if rise != 0.0 else FULL_FROM_START
    for dim in ("full_k", "full_row", "full_col"):
        D.write_coordinate(nc, VARIABLES, dim, np.arange(4))

    def stack(key, dtype=np.float64):
        return np.array([r[key] for r in results], dtype=dtype)

    D.write_complex(nc, VARIABLES, "full_multipliers", stack("full_multipliers", complex))
    D.write_complex(nc, VARIABLES, "full_multipliers_fd", stack("full_multipliers_fd", complex))
    for key in ("full_jacobian", "full_jacobian_fd", "full_spectral_radius",
                "full_spectral_radius_fd", "full_agreement"):
        D.write_declared(nc, VARIABLES, key, stack(key), planned=planned)
    D.write_declared(nc, VARIABLES, "full_stable", stack("full_stable", np.int8))


def write_catches(nc, results: list[dict]) -> None:
    """The bar catches' variables of a floquet dataset (dim ``catch``), from
    :func:`catch_measures` results."""
    D.write_coordinate(nc, VARIABLES, "catch", np.arange(len(results[0]["catch_segment"])))
    D.write_declared(nc, VARIABLES, "catch_segment", results[0]["catch_segment"])
    for key in ("catch_offset_margin", "catch_speed"):
        D.write_declared(nc, VARIABLES, key, np.array([r[key] for r in results], float))


# --- the kind ------------------------------------------------------------------------------------
class FloquetKind(StepKind):
    name = "floquet"
    model = FloquetStep
    variables = VARIABLES
    gait_kinds = ("horizontal", "sequence")
    accepts = ("shoot", "refine")
    provides = "its fixed point (the return map's a step runs)"
    unit = "controllers"
    figures = (
        Figure("multipliers"),
    )

    def check_step(self, study, index, step: FloquetStep, ref, seen) -> list:
        out = []
        allowed = study.gait.conventions.floquet_controllers
        controllers = step.controllers_for(study.gait)
        if "sequence" in controllers and "sequence" not in allowed:
            out.append((("steps", index, "controllers"), "the sequence controller needs a "
                        "sequence gait (gait: {kind: sequence, ...})"))
        elif not set(controllers) <= set(allowed):
            out.append((("steps", index, "controllers"), "a sequence gait has one return "
                        "map: controllers: [sequence] (the default)"))
        # the open-loop replay analyses a shoot step's exact gait; the gait's own cycle is
        # polished from a refine step's start (or, the search controller, from search_start)
        needs = {"open_loop": "shoot", "sequence": "refine"}
        for c in controllers:
            if c in needs and step.from_ is None:
                out.append((("steps", index, "from"), f"the {c} controller needs from: "
                            f"<{needs[c]} step>"))
            elif c in needs and ref is not None and ref.kind != needs[c]:
                out.append((("steps", index, "from"), f"the {c} controller analyses a "
                            f"{needs[c]} step's gait, {ref.name!r} is a {ref.kind} step"))
        if study.gait.gait().end_attached() == "B":
            problem = mirror_problem(study.to_robot())
            if problem:
                out.append((("steps", index, "kind"), f"a {step.kind} step {problem}"))
        return out + option_problems(step, ref, index)

    def n_tasks(self, step: FloquetStep, gait) -> int:
        return len(step.controllers_for(gait))

    def needs_variational(self, step) -> bool:
        return True

    def hand_on(self, dep: Dependency, ctx: StepContext, **options):
        return read_start(floquet_start, dep, ctx, options)

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        controllers = st.controllers_for(ctx.study.gait)
        g = None
        if "open_loop" in controllers:
            g = ctx.handed_on(solution=st.solution)
        elif "sequence" in controllers:
            g = ctx.handed_on(require="analyse")
        ctx.state["gait"] = g
        tasks = []
        for i, c in enumerate(controllers):
            kw = {"fd_step": st.fd_step, "height": st.height_in_map}
            if c == "open_loop":       # the shoot's gait replayed with its times
                kw.update(gait=open_loop_gait(g.gait, g.times), z0=list(g.z), newton=False,
                          schedule=(g.source["t_switch"], g.source["t_motor"]))
            elif c == "search":        # the gait's own controller from search_start
                kw.update(gait=ctx.spec.sequence, z0=list(st.search_start), newton=True,
                          keep_unconverged=True)
            else:                      # the gait's own controller from the refined start
                kw.update(gait=ctx.spec.sequence, z0=list(g.z), newton=True)
            tasks.append(Task(i, floquet_task, (ctx.spec, c), kw))
        return tasks

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        st = ctx.step
        results = ctx.task_results()
        controllers = st.controllers_for(ctx.study.gait)
        g = ctx.state["gait"]
        attrs.update(g.attrs("analysis") if g is not None else no_start_attrs(st.from_))
        if "search" in ctx.conventions.floquet_controllers:
            attrs["search_start"] = list(st.search_start)
        attrs.update(fd_step=st.fd_step, neutral_tol=NEUTRAL_TOL, controllers=controllers)
        if st.height_in_map:
            attrs.update(height_in_map=1, full_components=FULL_COMPONENTS)
        write_floquet(ctx.path, attrs, results, swap_motor=ctx.spec.swap_motor_times,
                      height=st.height_in_map,
                      rise=g.gait.rise if g is not None else ctx.spec.sequence.rise)
        parts = []
        for r in results:
            unpolished = ("" if r["newton_converged"] else
                          f"Newton {r['newton_stop'] or 'not converged'}; ")
            if r["failure"]:
                parts.append(f"{r['controller']}: {unpolished}not analysed ({r['failure']})")
                continue
            lam = np.abs(r["multipliers"])
            parts.append(f"{r['controller']}: {unpolished}"
                         f"|lambda| {', '.join(f'{x:.4g}' for x in lam)} "
                         f"({'stable' if r['stable'] else 'unstable'}, agreement "
                         f"{r['agreement']:.2g})")
            if st.height_in_map:
                parts[-1] += (f", full map rho {r['full_spectral_radius']:.6g} (finite "
                              f"differences {r['full_spectral_radius_fd']:.6g}"
                              + ("; the height reset by the bar catches, multiplier 0"
                                 if "catch_segment" in r else "") + ")")
            if "catch_segment" in r:
                parts[-1] += f", {catches_text(r)}"
        return "; ".join(parts)

    def describe(self, ds) -> list[str]:
        a = ds.attrs
        out = [gait_line(a)]
        lam, lam_fd = D.dataset_complex(ds, "multipliers"), D.dataset_complex(ds, "multipliers_fd")
        n = ds.sizes["controller"]
        failures = ds["failure"].values if "failure" in ds else [""] * n
        converged = ds["newton_converged"].values if "newton_converged" in ds else [1] * n
        stops = ds["newton_stop"].values if "newton_stop" in ds else [""] * n
        for i, c in enumerate(ds["controller"].values):
            fp = ds["fixed_point"].values[i]
            if not int(converged[i]):
                out.append(f"{c}: Newton {stops[i] or 'not converged'}")
            if failures[i]:
                out.append(f"{c}: not analysed at ({fp[0]:.8g}, {fp[1]:.8g}, {fp[2]:.8g}): "
                           f"{failures[i]}")
                continue
            out.append(f"{c}: multipliers {np.array2string(lam[i], precision=6)} (|lambda| "
                       f"{D.moduli(lam[i])}), {'stable' if int(ds['stable'][i]) else 'unstable'}")
            out.append(f"  finite differences |lambda| {D.moduli(lam_fd[i])}; agreement "
                       f"{float(ds['agreement'][i]):.2g}; map defect "
                       f"{float(ds['map_defect'][i]):.2g}")
            if "t_segment" in ds:       # a cycle named per segment
                times = ", ".join(f"{t:.6g}" for t in ds["t_segment"].values[i])
                when = (f"segment exits ({times}) s, x advance "
                        f"{float(ds['x_advance'][i]):.6g} m")
            else:
                when = (f"t_switch {float(ds['t_switch'][i]):.6g} s, t_motor "
                        f"{float(ds['t_motor'][i]):.6g} s")
            out.append(f"  fixed point (theta2, dtheta1, dtheta2) = ({fp[0]:.8g}, {fp[1]:.8g}, "
                       f"{fp[2]:.8g}); {when}")
            if int(a.get("height_in_map", 0)):
                full = D.dataset_complex(ds, "full_multipliers")[i]
                full_fd = D.dataset_complex(ds, "full_multipliers_fd")[i]
                out.append(f"  full map (y, theta2, dtheta1, dtheta2): |lambda| "
                           f"{D.moduli(full)} (finite differences {D.moduli(full_fd)}); "
                           f"spectral radius {float(ds['full_spectral_radius'][i]):.10g} "
                           f"(finite differences {float(ds['full_spectral_radius_fd'][i]):.10g}"
                           f"), agreement {float(ds['full_agreement'][i]):.2g}; "
                           f"{'stable' if int(ds['full_stable'][i]) else 'not stable'}, "
                           f"height included" + ("; on a ladder the height is reset by the "
                                                 "bar catches (its multiplier 0)"
                                                 if "catch" in ds.dims else ""))
            if "catch_offset_margin" in ds:
                out.append("  " + catches_text(
                    {k: ds[k].values[i] for k in ("catch_offset_margin", "catch_speed")}))
        return out

