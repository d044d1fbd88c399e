"""The ``work_precision`` step: run time per gait against error for the kernel's integrators over
a tolerance ladder, and scipy ``solve_ivp`` on a subset of the points
(:mod:`monkeystudy.analysis.precision`). Timings depend on the machine and its load: the
dataset's times are not bit-reproducible (its errors and counts are)."""
from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal, Union

import numpy as np
from pydantic import Discriminator, Field, Tag, ValidationInfo, field_validator

from ...analysis.precision import NoGaitToMeasure, work_precision
from .. import datasets as D
from ..blocks import Task
from ..errors import RunFailed
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
    scipy_points, first_swing_only). Wall times: not reproducible bit for bit. Refused
    (:class:`~monkeystudy.study.errors.RunFailed`) when no point has a gait to measure."""
    pts = np.asarray(points, float).reshape(-1, 2)
    try:
        return work_precision(pts, robot=spec.robot, torque=spec.torque, **options)
    except NoGaitToMeasure as exc:   # the points' outcome, not a fault: one line, exit 1
        raise RunFailed(str(exc)) from None


# --- the dataset ---------------------------------------------------------------------------------
#: the note stored with work-precision datasets
NOT_REPRODUCIBLE = ("wall-clock timings depend on the machine and its load: time variables "
                    "differ between runs (errors and counts do not)")


#: dims of the kernel's and of scipy's measurements
KERNEL_RUNS = ("method", "rtol")
SCIPY_RUNS = ("scipy_method", "scipy_rtol")

#: the variables of a work_precision dataset (docs/datasets.md)
VARIABLES = {
    "method": D.label_coordinate("method", "kernel integrator"),
    "rtol": D.Variable(("rtol",), np.float64, "1", "relative tolerance"),
    "scipy_method": D.label_coordinate("scipy_method", "scipy.integrate.solve_ivp method"),
    "scipy_rtol": D.Variable(("scipy_rtol",), np.float64, "1",
                             "relative tolerance of the scipy runs"),
    "time_per_gait": D.Variable(KERNEL_RUNS, np.float64, "s",
                                "wall time per gait evaluation (best of repeat)"),
    "rhs_per_gait": D.Variable(KERNEL_RUNS, np.float64, "1",
                               "right-hand-side evaluations per gait (mean)"),
    "error_value": D.Variable(KERNEL_RUNS, np.float64, D.ERROR_UNITS,
                              "max |gait error - reference gait error|"),
    "error_times": D.Variable(KERNEL_RUNS, np.float64, "s",
                              "max |event time - reference| (t_switch, t_motor, t_end)"),
    "status_mismatch": D.Variable(KERNEL_RUNS, np.int32, "1",
                                  "points whose status differs from the reference"),
    "scipy_time_per_gait": D.Variable(SCIPY_RUNS, np.float64, "s",
                                      "wall time per gait evaluation, scipy solve_ivp with "
                                      "events"),
    "scipy_error_value": D.Variable(SCIPY_RUNS, np.float64, D.ERROR_UNITS,
                                    "max |gait error - reference gait error|, scipy"),
    "scipy_error_times": D.Variable(SCIPY_RUNS, np.float64, "s",
                                    "max |event time - reference|, scipy"),
    "kernel_time_same_points": D.Variable(("scipy_rtol",), np.float64, "s",
                                          "wall time per gait of the kernel's dop853 on the "
                                          "scipy points"),
}


def write_work_precision(path: Path, attrs: dict, result: dict) -> None:
    """Write a work_precision dataset from :func:`monkeystudy.analysis.precision.work_precision`."""
    with D.atomic_netcdf(path) as nc:
        for name, key in (("method", "methods"), ("rtol", "rtols"),
                          ("scipy_method", "scipy_methods"), ("scipy_rtol", "scipy_rtols")):
            D.write_coordinate(nc, VARIABLES, name, list(result[key]))
        for name, key in (("time_per_gait", "time"), ("rhs_per_gait", "nfev"),
                          ("error_value", "error_value"), ("error_times", "error_times"),
                          ("status_mismatch", "status_mismatch"),
                          ("scipy_time_per_gait", "scipy_time"),
                          ("scipy_error_value", "scipy_error_value"),
                          ("scipy_error_times", "scipy_error_times"),
                          ("kernel_time_same_points", "kernel_time_same_points")):
            D.write_declared(nc, VARIABLES, name, result[key])
        D.set_global_attrs(nc, dict(attrs, reference=result["reference"],
                               n_points=int(result["n_points"]), bit_reproducible=0,
                               reproducibility=NOT_REPRODUCIBLE))


# --- the kind ------------------------------------------------------------------------------------
class WorkPrecisionKind(StepKind):
    name = "work_precision"
    model = WorkPrecisionStep
    variables = VARIABLES
    unit = "measurements"
    reproducible = False
    figures = (
        Figure("work_precision"),
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
