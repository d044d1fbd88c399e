"""The ``work_precision`` step: run time per gait against error for the kernel's integrators over
a tolerance ladder, and scipy ``solve_ivp`` on a subset of the points
(:mod:`monkeystudy.analysis.precision`). Timings depend on the machine and its load: the
dataset's times are not bit-reproducible (its errors and counts are)."""
from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal, Union

import numpy as np
from pydantic import Discriminator, Field, Tag, ValidationInfo, field_validator

from ...analysis.precision import work_precision
from ...reference.scipy_gait import ScipyGait
from .. import datasets as D
from ..blocks import Task
from ..models import Axis, Name, Point, StrictModel, unique
from ..spec import GaitSpec
from .base import Figure, StepContext, StepKind

#: the tolerance ladder of the work-precision step (``monkeystudy.precision.RTOLS``)
WORK_PRECISION_RTOLS = [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13]


class PointAxes(StrictModel):
    dtheta1: Axis = Field(description="axis of dtheta1 [rad s-1]")
    dtheta2: Axis = Field(description="axis of dtheta2 [rad s-1]")


def _points_tag(v: Any) -> str | None:
    if isinstance(v, list):
        return "list"
    if isinstance(v, (dict, PointAxes)):
        return "axes"
    return None


PointsSpec = Annotated[
    Union[Annotated[list[Point], Tag("list")], Annotated[PointAxes, Tag("axes")]],
    Discriminator(_points_tag, custom_error_type="points_type",
                  custom_error_message="must be a list of points [[dtheta1, dtheta2], ...] "
                                       "or {dtheta1: {start, stop, num}, dtheta2: {...}}"),
]


class WorkPrecisionStep(StrictModel):
    """Run time per gait against error, for kernel integrators over a tolerance ladder and
    scipy solve_ivp on a subset (``monkeystudy.precision.work_precision``). Timings depend on
    the machine and its load: this step's dataset is not bit-reproducible."""

    name: Name
    kind: Literal["work_precision"]
    points: PointsSpec = Field(description="gait start points [rad s-1]: a list or axes")
    methods: list[Literal["rk45", "dop853", "vern9", "rk45+pi", "dop853+pi", "vern9+pi"]] = Field(
        ["rk45", "dop853"], min_length=1,
        description="kernel integrators; '+pi': with the PI step-size controller")
    rtols: list[Annotated[float, Field(ge=100 * np.finfo(float).eps, lt=1.0)]] = Field(
        WORK_PRECISION_RTOLS, min_length=1, description="relative tolerances [1]")
    atol_ratio: float = Field(1e-2, gt=0, le=1.0, description="atol = rtol * atol_ratio "
                                                             "[rad, rad s-1]")
    repeat: int = Field(3, ge=1, le=100, description="timed repetitions (the best is kept)")
    scipy_methods: list[Literal["RK45", "DOP853", "LSODA"]] = Field(
        ["RK45", "DOP853", "LSODA"], min_length=1, description="scipy solve_ivp methods")
    scipy_rtols: list[Annotated[float, Field(ge=100 * np.finfo(float).eps, lt=1.0)]] = Field(
        [1e-6, 1e-8, 1e-10], min_length=1, description="scipy relative tolerances [1]")
    scipy_points: int = Field(4, ge=1, le=10_000, description="points run by scipy (the "
                              "first ones kept)")
    first_swing_only: bool = Field(True, description="keep gaits that swap on the first "
                                   "swing and end before 1.2 s (well-conditioned ones)")

    @field_validator("methods", "rtols", "scipy_methods", "scipy_rtols")
    @classmethod
    def _distinct(cls, v: list, info: ValidationInfo) -> list:
        return unique(v, info.field_name)

    @property
    def n_points(self) -> int:
        if isinstance(self.points, PointAxes):
            return self.points.dtheta1.num * self.points.dtheta2.num
        return len(self.points)

    def point_array(self) -> np.ndarray:
        if isinstance(self.points, PointAxes):
            g1, g2 = np.meshgrid(self.points.dtheta1.values(), self.points.dtheta2.values(),
                                 indexing="ij")
            return np.stack([g1.ravel(), g2.ravel()], axis=1)
        return np.array(self.points, dtype=np.float64).reshape(-1, 2)


# --- tasks (run on the workers) ------------------------------------------------------------------
def work_precision_task(spec: GaitSpec, points: np.ndarray, **options) -> dict[str, Any]:
    """:func:`monkeystudy.analysis.precision.work_precision` on the study's robot and torque
    (``options``: methods, rtols, atol_ratio, repeat, scipy_methods, scipy_rtols,
    scipy_points, first_swing_only). Wall times: not reproducible bit for bit."""
    robot = spec.robot
    pts = np.asarray(points, float).reshape(-1, 2)
    # the first solve_ivp call of a process imports and sets up scipy's solvers: pay for it
    # here, not in the first timed cell
    sg = ScipyGait(robot, spec.torque, "scalar")
    for m in options.get("scipy_methods", ("RK45", "DOP853", "LSODA")):
        sg.gait(pts[0, 0], pts[0, 1], 1e-6, 1e-8, method=m)
    return work_precision(pts, robot=robot, torque=spec.torque, **options)


# --- the dataset ---------------------------------------------------------------------------------
#: the note stored with work-precision datasets
NOT_REPRODUCIBLE = ("wall-clock timings depend on the machine and its load: time variables "
                    "differ between runs (errors and counts do not)")


def write_work_precision(path: Path, attrs: dict, result: dict) -> None:
    """Write a work_precision dataset from :func:`monkeystudy.analysis.precision.work_precision`."""
    with D.atomic_netcdf(path) as nc:
        D.add_label_coord(nc, "method", list(result["methods"]), "kernel integrator")
        nc.createDimension("rtol", len(result["rtols"]))
        D.add_variable(nc, "rtol", ("rtol",), np.float64, {"long_name": "relative tolerance",
                                                 "units": "1"}, result["rtols"])
        D.add_label_coord(nc, "scipy_method", list(result["scipy_methods"]),
                     "scipy.integrate.solve_ivp method")
        nc.createDimension("scipy_rtol", len(result["scipy_rtols"]))
        D.add_variable(nc, "scipy_rtol", ("scipy_rtol",), np.float64,
             {"long_name": "relative tolerance of the scipy runs", "units": "1"},
             result["scipy_rtols"])
        mr, sr = ("method", "rtol"), ("scipy_method", "scipy_rtol")
        D.add_variable(nc, "time_per_gait", mr, np.float64,
             {"long_name": "wall time per gait evaluation (best of repeat)", "units": "s"},
             result["time"])
        D.add_variable(nc, "rhs_per_gait", mr, np.float64,
             {"long_name": "right-hand-side evaluations per gait (mean)", "units": "1"},
             result["nfev"])
        D.add_variable(nc, "error_value", mr, np.float64,
             {"long_name": "max |gait error - reference gait error|",
              "units": D.ERROR_UNITS},
             result["error_value"])
        D.add_variable(nc, "error_times", mr, np.float64,
             {"long_name": "max |event time - reference| (t_switch, t_motor, t_end)",
              "units": "s"}, result["error_times"])
        D.add_variable(nc, "status_mismatch", mr, np.int32,
             {"long_name": "points whose status differs from the reference", "units": "1"},
             result["status_mismatch"])
        D.add_variable(nc, "scipy_time_per_gait", sr, np.float64,
             {"long_name": "wall time per gait evaluation, scipy solve_ivp with events",
              "units": "s"}, result["scipy_time"])
        D.add_variable(nc, "scipy_error_value", sr, np.float64,
             {"long_name": "max |gait error - reference gait error|, scipy",
              "units": D.ERROR_UNITS},
             result["scipy_error_value"])
        D.add_variable(nc, "scipy_error_times", sr, np.float64,
             {"long_name": "max |event time - reference|, scipy", "units": "s"},
             result["scipy_error_times"])
        D.add_variable(nc, "kernel_time_same_points", ("scipy_rtol",), np.float64,
             {"long_name": "wall time per gait of the kernel's dop853 on the scipy points",
              "units": "s"}, result["kernel_time_same_points"])
        D.set_global_attrs(nc, dict(attrs, reference=result["reference"],
                               n_points=int(result["n_points"]), bit_reproducible=0,
                               reproducibility=NOT_REPRODUCIBLE))


# --- the kind ------------------------------------------------------------------------------------
class WorkPrecisionKind(StepKind):
    name = "work_precision"
    model = WorkPrecisionStep
    unit = "measurements"
    reproducible = False
    figures = (
        Figure("work_precision", "wall time per gait against error",
               "Time per gait against the error of the gait error, one line per integrator: "
               "lower left is better; the ratio to scipy's solve_ivp on the same gaits is in "
               "the legend."),
    )

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        return [Task(0, work_precision_task, (ctx.spec, st.point_array()),
                     {"methods": tuple(st.methods), "rtols": tuple(st.rtols),
                      "atol_ratio": st.atol_ratio, "repeat": st.repeat,
                      "scipy_methods": tuple(st.scipy_methods),
                      "scipy_rtols": tuple(st.scipy_rtols), "scipy_points": st.scipy_points,
                      "first_swing_only": st.first_swing_only}, exclusive=True)]

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        st = ctx.step
        r = ctx.results[0]
        attrs.update(repeat=st.repeat, atol_ratio=st.atol_ratio,
                     first_swing_only=int(st.first_swing_only),
                     n_points_requested=st.n_points, scipy_points=st.scipy_points)
        write_work_precision(ctx.path, attrs, r)
        n_m, n_r, n_p = len(r["methods"]), len(r["rtols"]), r["n_points"]
        return (f"{n_m} method{'s' if n_m != 1 else ''} x {n_r} rtol{'s' if n_r != 1 else ''} "
                f"on {n_p} point{'s' if n_p != 1 else ''} (timings are machine-dependent)")

    def describe(self, ds) -> list[str]:
        a = ds.attrs
        out = [f"{a.get('n_points')} points, reference {a.get('reference')}; "
               f"{a.get('reproducibility', '')}"]
        for i, m in enumerate(ds["method"].values):
            t = ds["time_per_gait"].values[i]
            e = ds["error_value"].values[i]
            cells = ", ".join(f"{r:.0e}: {1e6 * ti:.3g} us / {ei:.2g}"
                              for r, ti, ei in zip(ds["rtol"].values, t, e))
            out.append(f"{m} (rtol: time per gait / error): {cells}")
        for i, m in enumerate(ds["scipy_method"].values):
            t = ds["scipy_time_per_gait"].values[i]
            k = ds["kernel_time_same_points"].values
            cells = ", ".join(f"{r:.0e}: {ti / ki:.3g}x" for r, ti, ki in
                              zip(ds["scipy_rtol"].values, t, k))
            out.append(f"scipy {m} time / kernel dop853 time: {cells}")
        return out
