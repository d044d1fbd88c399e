"""Small but real datasets of the six analysis step kinds, for the plotting tests.

Every number comes from :mod:`monkeystudy.analysis` and :mod:`monkeystudy.precision` called
directly (the exact grazing gait of ``seed2009`` shot from (1.44, 10.31) rad s-1, its
multipliers, tick sweep, basin, continuation, and a tiny work-precision measurement); the
results are labelled as ``docs/datasets.md`` ("Analysis steps") prescribes: the same
variables, dims, units, long names and attributes the study runner writes, plus the global
attributes of every dataset. Nothing here goes through ``monkeystudy.study``, so these tests
do not depend on the runner.

``build_analysis_study(folder)`` writes one study folder with all of them (about a second).
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import json
import math
from functools import partial
from pathlib import Path

import numpy as np
import xarray as xr

import monkeystudy
from monkeystudy import Robot
from monkeystudy import analysis as A
from monkeystudy.analysis import precision as P
from monkeystudy.kernel import layout as L

from plotdata import write_nc

TORQUE = 0.6354
#: the start of the grazing shoot and its swap-time guess (tests/analysis/test_analysis.py)
GRAZING_START, T_GUESS = (1.44, 10.31), 0.433
#: a Gauss-Newton start: it stalls near the grazing border (a second, unconverged solution)
GN_START = (1.0, 12.0)
#: the state-based controller's attracting gait on the section (theta2, dtheta1, dtheta2)
SEARCH_START = (0.0248, -1.0869, 16.0168)
TICKS = (1e-3, 1e-5, 0.0)
TICK_CYCLES = 80
ERROR_BOUND = 1e-2
BASIN_OFFSETS = np.linspace(-1e-3, 1e-3, 5)
BASIN_CYCLES = 60
WP_POINTS = [[0.9, 10.9], [1.0, 11.0], [0.95, 10.95], [1.1, 11.2], [0.8, 10.8], [1.2, 11.5]]
WP_RTOLS = (1e-6, 1e-8, 1e-10)
NEUTRAL_TOL = 1e-6
GROWTH_WINDOW = (1e-10, 1e-4)

STUDY_TEXT = """\
schema_version: 1
name: {name}
description: plotting-test analysis study (tiny, real)
robot: seed2009
gait: {{kind: horizontal, motor_torque: 0.6354, tick: 0.0}}
integrator: {{method: dop853, rtol: 1.0e-13, atol: 1.0e-13}}
steps:
  - {{name: shoot, kind: shoot, starts: [[1.44, 10.31], [1.0, 12.0]]}}
  - {{name: floquet, kind: floquet, from: shoot}}
  - {{name: ticks, kind: tick_sweep, from: shoot, ticks: [0.001, 1.0e-5, 0.0], cycles: 80}}
  - name: basin
    kind: basin
    from: shoot
    offsets: {{d_dtheta1: {{start: -1.0e-3, stop: 1.0e-3, num: 5}},
              d_dtheta2: {{start: -1.0e-3, stop: 1.0e-3, num: 5}}}}
    max_cycles: 60
  - {{name: family, kind: continuation, from: shoot, parameter: gravity, ds: 0.5, steps: 4}}
  - {{name: family_com, kind: continuation, from: shoot, parameter: com, ds: 0.01, steps: 6}}
  - name: timing
    kind: work_precision
    points: [[0.9, 10.9], [1.0, 11.0], [0.95, 10.95], [1.1, 11.2], [0.8, 10.8], [1.2, 11.5]]
    rtols: [1.0e-6, 1.0e-8, 1.0e-10]
    repeat: 1
"""


def _status_attrs(long_name: str) -> dict:
    return {"long_name": long_name, "units": "1",
            "flag_values": np.arange(len(L.STATUS_NAMES), dtype=np.int8),
            "flag_meanings": " ".join(L.STATUS_NAMES)}


def _v(dims, data, long_name, units, **extra):
    return (dims, data, dict({"long_name": long_name, "units": units}, **extra))


def global_attrs(study_name: str, step_name: str, step_kind: str, text: str) -> dict:
    """The global attributes every dataset carries (docs/datasets.md), for the tight
    analysis integrator and exact event timing."""
    import netCDF4
    import numba
    import scipy
    return {
        "study_name": study_name, "step_name": step_name, "step_kind": step_kind,
        "study_text": text, "study_sha256": hashlib.sha256(text.encode()).hexdigest(),
        "robot": json.dumps(Robot.preset("seed2009").to_dict()),
        "gait": json.dumps({"kind": "horizontal", "motor_torque": TORQUE, "tick": 0.0}),
        "integrator": json.dumps({"method": "dop853", "rtol": 1e-13, "atol": 1e-13,
                                  "max_time": 3.0}),
        "monkeystudy_version": monkeystudy.__version__, "git_revision": "test",
        "library_versions": json.dumps({"numpy": np.__version__, "scipy": scipy.__version__,
                                        "numba": numba.__version__, "xarray": xr.__version__,
                                        "netCDF4": netCDF4.__version__}),
        "history": f"{_dt.datetime.now(_dt.timezone.utc).isoformat(timespec='seconds')} "
                   "tests/plotting/analysisdata.py",
        "Conventions": "CF-1.10",
    }


def gait_attrs(gait: dict) -> dict:
    """Attributes naming the gait a step analysed (as the runner adds them)."""
    return {"shoot_step": "shoot", "solution": 0, "dtheta1": gait["dtheta1"],
            "dtheta2": gait["dtheta2"], "t_switch": gait["t_switch"], "t_motor": 0.0,
            "gait_error": gait["error"], "gait_method": "grazing"}


def _grazing_replay(dtheta1: float, dtheta2: float, t_switch: float, *, cycles: int,
                    tick: float = 0.0):
    """A motorless gait swapping at ``t_switch`` [s] replayed open loop (the shoot's grazing
    gait as the tick_sweep and basin steps run it)."""
    return A.sequence_cycles(A.motorless(monkeystudy.horizontal_gait(0.6354)),
                             [0.0, dtheta1, dtheta2], cycles=cycles, replay="open_loop",
                             times=[t_switch, t_switch], tick=tick)


# --- shoot -----------------------------------------------------------------------------------
def shoot_solutions() -> list[dict]:
    """The grazing solution from :data:`GRAZING_START` and the Gauss-Newton one from
    :data:`GN_START` (more than the 1e-6 dedup tolerance apart: two solutions)."""
    gr = A.shoot_grazing(GRAZING_START, T_GUESS)
    z = np.array([0.0, gr.dtheta1, gr.dtheta2])
    zn, st = A.open_loop_return_map(z, t_switch=gr.t_switch, t_motor=0.0, torque=0.0)
    one = _grazing_replay(gr.dtheta1, gr.dtheta2, gr.t_switch, cycles=1)
    grazing = {"dtheta1": gr.dtheta1, "dtheta2": gr.dtheta2, "t_switch": gr.t_switch,
               "t_motor": 0.0, "t_end": float(one.t_cross[0]),
               "error": float(np.sum((zn - z) ** 2)),
               "residual_norm": float(np.linalg.norm(gr.residual)),
               "converged": int(gr.converged), "method": 1, "status": int(st),
               "history": np.asarray(gr.history), "start_index": 0,
               "message": f"grazing from t_guess {T_GUESS} s: converged after "
                          f"{len(gr.history) - 1} iterations"}
    sh = A.shoot_horizontal(GN_START)
    gn = {"dtheta1": sh.dtheta1, "dtheta2": sh.dtheta2, "t_switch": sh.t_switch,
          "t_motor": sh.t_motor, "t_end": sh.t_end, "error": sh.error,
          "residual_norm": float(np.linalg.norm(sh.residual)),
          "converged": int(sh.converged), "method": 0, "status": int(sh.status),
          "history": np.asarray(sh.history), "start_index": 1,
          "message": f"gauss_newton: {sh.message} after {sh.iterations} iterations"}
    assert math.hypot(gn["dtheta1"] - gr.dtheta1, gn["dtheta2"] - gr.dtheta2) > 1e-6
    return [grazing, gn]


def shoot_dataset(sols: list[dict], attrs: dict) -> xr.Dataset:
    n_it = max(len(s["history"]) for s in sols)
    hist = np.full((len(sols), n_it), np.nan)
    for i, s in enumerate(sols):
        hist[i, :len(s["history"])] = s["history"]

    def col(k, dtype=float):
        return np.array([s[k] for s in sols], dtype=dtype)

    S = ("solution",)
    return xr.Dataset(
        {
            "dtheta1": _v(S, col("dtheta1"), "fixed point, initial angular rate of link 1",
                          "rad s-1"),
            "dtheta2": _v(S, col("dtheta2"), "fixed point, initial relative angular rate of "
                          "link 2", "rad s-1"),
            "t_switch": _v(S, col("t_switch"), "time of the swap after the gait start", "s"),
            "t_motor": _v(S, col("t_motor"), "motor-on duration after the swap", "s"),
            "t_end": _v(S, col("t_end"), "time of the vertical crossing ending the gait", "s"),
            "error": _v(S, col("error"), "gait error of the solution (docs/model.md section 4)",
                        "1"),
            "residual_norm": _v(S, col("residual_norm"), "norm of the Newton residual at the "
                                "solution", "1"),
            "converged": _v(S, col("converged", np.int8), "Newton met its tolerance (1) or "
                            "stopped (0)", "1"),
            "method": _v(S, col("method", np.int8), "how the fixed point was found", "1",
                         flag_values=np.array([0, 1], np.int8),
                         flag_meanings="gauss_newton grazing"),
            "status": (S, col("status", np.int8), _status_attrs("outcome of the solution's "
                                                                "gait cycle")),
            "start_index": _v(S, col("start_index", np.int32), "first start that found the "
                              "solution", "1"),
            "history": _v(("solution", "iteration"), hist, "residual norm per Newton "
                          "iteration (NaN: padding)", "1"),
        },
        coords={"solution": ("solution", np.arange(len(sols), dtype=np.int32),
                             {"long_name": "solution index", "units": "1"}),
                "iteration": ("iteration", np.arange(n_it, dtype=np.int32),
                              {"long_name": "Newton iteration (0: the start)", "units": "1"})},
        attrs=dict(attrs, message=json.dumps([s["message"] for s in sols]),
                   starts=json.dumps([list(GRAZING_START), list(GN_START)]),
                   method="both", dedup_tol=1e-6, tol=1e-14, max_iter=40, best_solution=0),
    )


# --- floquet ---------------------------------------------------------------------------------
def _sorted(lam):
    lam = np.asarray(lam, complex)
    return lam[np.argsort(-np.abs(lam), kind="stable")]


def floquet_dataset(gait: dict, attrs: dict) -> xr.Dataset:
    """Both controllers: the grazing gait's open-loop map (motorless) and the state-based
    controller's own fixed point (Newton from :data:`SEARCH_START`)."""
    rows = []
    z = np.array([0.0, gait["dtheta1"], gait["dtheta2"]])
    fmap = partial(A.open_loop_return_map, t_switch=gait["t_switch"], t_motor=0.0, torque=0.0)
    Jv = A.variational_jacobian("open_loop", z, t_switch=gait["t_switch"], t_motor=0.0,
                                torque=0.0)
    rows.append(("open_loop", z, fmap, Jv, gait["t_switch"], 0.0, 0.0))

    def jac(q):
        return A.variational_jacobian("search", q, torque=TORQUE)

    smap = partial(A.search_return_map, torque=TORQUE)
    fp = A.solve_fixed_point(smap, np.array(SEARCH_START), jacobian=jac)
    rows.append(("search", fp.z, smap, jac(fp.z), math.nan, math.nan, TORQUE))
    out = {k: [] for k in ("lam", "lam_fd", "J", "Jfd", "z", "defect", "stable", "neutral",
                           "agree", "ts", "tm", "tau")}
    for name, zz, f, J, ts, tm, tau in rows:
        fl = A.floquet(f, zz, neutral_tol=NEUTRAL_TOL)
        lam = _sorted(np.linalg.eigvals(J))
        neutral = np.abs(lam - 1.0) < NEUTRAL_TOL
        if name == "search":
            res = monkeystudy.run_controller(monkeystudy.HorizontalSearch(TORQUE),
                                             A.section_state(zz), log_capacity=16)
            ts = float(res.segment_times[0])
            tm = float(res.segment_times[1] - res.segment_times[0])
        for k, v in (("lam", lam), ("lam_fd", fl.multipliers), ("J", J), ("Jfd", fl.jacobian),
                     ("z", zz), ("defect", fl.map_defect),
                     ("stable", int(np.all(np.abs(lam[~neutral]) < 1.0))),
                     ("neutral", int(neutral.sum())),
                     ("agree", float(np.abs(J - fl.jacobian).max() / np.abs(J).max())),
                     ("ts", ts), ("tm", tm), ("tau", tau)):
            out[k].append(v)
    lam, lam_fd = np.array(out["lam"]), np.array(out["lam_fd"])
    C, CK, CRC = ("controller",), ("controller", "k"), ("controller", "row", "col")
    return xr.Dataset(
        {
            "multipliers_real": _v(CK, lam.real, "Floquet multipliers by variational "
                                   "equations (decreasing modulus), real part", "1"),
            "multipliers_imag": _v(CK, lam.imag, "Floquet multipliers by variational "
                                   "equations (decreasing modulus), imaginary part", "1"),
            "multipliers_fd_real": _v(CK, lam_fd.real, "Floquet multipliers by finite "
                                      "differences, real part", "1"),
            "multipliers_fd_imag": _v(CK, lam_fd.imag, "Floquet multipliers by finite "
                                      "differences, imaginary part", "1"),
            "jacobian": _v(CRC, np.array(out["J"]), "Jacobian of the return map by "
                           "variational equations", "1"),
            "jacobian_fd": _v(CRC, np.array(out["Jfd"]), "Jacobian of the return map by "
                              "central differences", "1"),
            "fixed_point": _v(CK, np.array(out["z"]), "fixed point on the section theta1 = 0",
                              "1", components="theta2 dtheta1 dtheta2"),
            "map_defect": _v(C, np.array(out["defect"]), "|P(z) - z| at the fixed point", "1"),
            "stable": _v(C, np.array(out["stable"], np.int8), "all multipliers inside the "
                         "unit circle (1), neutral ones excluded", "1"),
            "neutral": _v(C, np.array(out["neutral"], np.int8), "neutral multipliers", "1"),
            "agreement": _v(C, np.array(out["agree"]), "max |J - J_fd| / max |J|", "1"),
            "t_switch": _v(C, np.array(out["ts"]), "swap time of the fixed point's cycle", "s"),
            "t_motor": _v(C, np.array(out["tm"]), "motor-on duration of the cycle", "s"),
            "motor_torque": _v(C, np.array(out["tau"]), "motor torque of the return map",
                               "N m"),
        },
        coords={"controller": ("controller", ["open_loop", "search"],
                               {"long_name": "return map", "units": "1"}),
                "k": ("k", np.arange(3, dtype=np.int32), {"long_name": "multiplier",
                                                          "units": "1"})},
        attrs=dict(attrs, **gait_attrs(gait), fd_step=1e-5, neutral_tol=NEUTRAL_TOL,
                   search_start=json.dumps(list(SEARCH_START)),
                   controllers=json.dumps(["open_loop", "search"])),
    )


# --- tick sweep ------------------------------------------------------------------------------
def _growth(error) -> float:
    e = np.sqrt(np.asarray(error, float))
    with np.errstate(invalid="ignore"):
        lin = np.isfinite(e) & (e > GROWTH_WINDOW[0]) & (e < GROWTH_WINDOW[1])
    if lin.sum() < 3:
        return math.nan
    return float(np.exp(np.polyfit(np.flatnonzero(lin) + 1.0, np.log(e[lin]), 1)[0]))


def tick_sweep_dataset(gait: dict, leading: float, attrs: dict) -> xr.Dataset:
    n = len(TICKS)
    err = np.full((n, TICK_CYCLES), np.nan)
    piv = np.full((n, TICK_CYCLES), np.nan)
    to_bound, done, status, growth = (np.zeros(n, np.int32), np.zeros(n, np.int32),
                                      np.zeros(n, np.int8), np.full(n, np.nan))
    for i, tick in enumerate(TICKS):
        run = _grazing_replay(gait["dtheta1"], gait["dtheta2"], gait["t_switch"],
                              cycles=TICK_CYCLES, tick=tick)
        e = np.asarray(run.error)[:TICK_CYCLES]
        p = np.asarray(run.pivot_height)[:TICK_CYCLES]
        err[i, :e.size], piv[i, :p.size] = e, p
        bad = np.flatnonzero(~(e <= ERROR_BOUND))
        to_bound[i] = bad[0] + 1 if bad.size else e.size
        done[i], status[i], growth[i] = e.size, int(run.status), _growth(e)
    T, TC = ("tick",), ("tick", "cycle")
    return xr.Dataset(
        {
            "error": _v(TC, err, "error against the gait start at the vertical crossing "
                        "ending the cycle (NaN: not reached)", "1"),
            "pivot_height": _v(TC, piv, "world height of the attached end after the cycle's "
                               "swap", "m"),
            "cycles_to_bound": _v(T, to_bound, "first cycle whose error exceeds error_bound",
                                  "1"),
            "cycles_completed": _v(T, done, "cycles that reached their vertical crossing",
                                   "1"),
            "status": (T, status, _status_attrs("why the run stopped")),
            "growth_per_cycle": _v(T, growth, "fitted geometric growth of sqrt(error) per "
                                   "cycle", "1"),
        },
        coords={"tick": ("tick", np.array(TICKS), {"long_name": "controller tick (0: exact "
                                                                "event timing)", "units": "s"}),
                "cycle": ("cycle", np.arange(1, TICK_CYCLES + 1, dtype=np.int32),
                          {"long_name": "cycle number", "units": "1"})},
        attrs=dict(attrs, **gait_attrs(gait), leading_multiplier=float(leading),
                   leading_multiplier_source="floquet step floquet (variational equations)",
                   error_bound=ERROR_BOUND, cycles=TICK_CYCLES, motor_torque=0.0,
                   max_drop=Robot.preset("seed2009").link1.length),
    )


# --- basin -----------------------------------------------------------------------------------
def basin_dataset(gait: dict, attrs: dict) -> xr.Dataset:
    B = A.sequence_basin(A.motorless(monkeystudy.horizontal_gait(0.6354)),
                         [0.0, gait["dtheta1"], gait["dtheta2"]], BASIN_OFFSETS,
                         BASIN_OFFSETS, max_cycles=BASIN_CYCLES, error_bound=ERROR_BOUND,
                         replay="open_loop", times=[gait["t_switch"], gait["t_switch"]])
    off = {"units": "rad s-1"}
    return xr.Dataset(
        {"cycles": _v(("d_dtheta1", "d_dtheta2"), B.astype(np.int32), "cycles survived "
                      "before the error against the gait exceeded error_bound", "1")},
        coords={"d_dtheta1": ("d_dtheta1", BASIN_OFFSETS,
                              dict(off, long_name="offset of the start's dtheta1")),
                "d_dtheta2": ("d_dtheta2", BASIN_OFFSETS,
                              dict(off, long_name="offset of the start's dtheta2"))},
        attrs=dict(attrs, **gait_attrs(gait), max_cycles=BASIN_CYCLES,
                   error_bound=ERROR_BOUND, tick=0.0, motor_torque=0.0),
    )


# --- continuation ----------------------------------------------------------------------------
UNITS = {"com": "m", "inertia": "kg m2", "gravity": "m s-2"}


def continuation_dataset(gait: dict, parameter: str, value0: float, ds: float,
                         steps: int, attrs: dict) -> xr.Dataset:
    grazing = A.GrazingResult(gait["dtheta1"], gait["dtheta2"], gait["t_switch"],
                              np.zeros(3), True, [])
    b = A.continue_grazing(grazing, parameter, value0, ds=ds, steps=steps)
    P_, PK = ("point",), ("point", "k")
    return xr.Dataset(
        {
            "parameter_value": _v(P_, b.value, f"continuation parameter {parameter}",
                                  UNITS[parameter]),
            "dtheta1": _v(P_, b.dtheta1, "collisionless gait, initial angular rate of link 1",
                          "rad s-1"),
            "dtheta2": _v(P_, b.dtheta2, "collisionless gait, initial relative angular rate "
                          "of link 2", "rad s-1"),
            "t_switch": _v(P_, b.t_switch, "swap time (B at A's height at rest)", "s"),
            "residual": _v(P_, b.residual, "|G| after correction", "1"),
            "multipliers_real": _v(PK, b.multipliers.real, "Floquet multipliers, real part",
                                   "1"),
            "multipliers_imag": _v(PK, b.multipliers.imag, "Floquet multipliers, imaginary "
                                   "part", "1"),
        },
        coords={"point": ("point", np.arange(len(b.value), dtype=np.int32),
                          {"long_name": "point on the branch", "units": "1"}),
                "k": ("k", np.arange(3, dtype=np.int32), {"long_name": "multiplier",
                                                          "units": "1"})},
        attrs=dict(attrs, **gait_attrs(gait), parameter=parameter,
                   parameter_units=UNITS[parameter], value0=float(value0),
                   folds=json.dumps(b.folds), period_doublings=json.dumps(b.period_doublings),
                   ds=ds, steps=steps),
    )


# --- work precision --------------------------------------------------------------------------
def work_precision_dataset(attrs: dict) -> xr.Dataset:
    r = P.work_precision(WP_POINTS, rtols=WP_RTOLS, repeat=1,
                         methods=("rk45", "dop853", "vern9", "dop853+pi"))
    MR, SR = ("method", "rtol"), ("scipy_method", "scipy_rtol")
    return xr.Dataset(
        {
            "time_per_gait": _v(MR, r["time"], "wall time per gait evaluation", "s"),
            "rhs_per_gait": _v(MR, r["nfev"], "right-hand-side evaluations per gait", "1"),
            "error_value": _v(MR, r["error_value"], "max |gait error - reference gait error|",
                              "1"),
            "error_times": _v(MR, r["error_times"], "max |event time - reference|", "s"),
            "status_mismatch": _v(MR, r["status_mismatch"], "points whose status differs "
                                  "from the reference", "1"),
            "scipy_time_per_gait": _v(SR, r["scipy_time"], "wall time per gait, scipy", "s"),
            "scipy_error_value": _v(SR, r["scipy_error_value"], "max |gait error - "
                                    "reference|, scipy", "1"),
            "scipy_error_times": _v(SR, r["scipy_error_times"], "max |event time - "
                                    "reference|, scipy", "s"),
            "kernel_time_same_points": _v(("scipy_rtol",), r["kernel_time_same_points"],
                                          "wall time per gait of the kernel's dop853 on the "
                                          "scipy points", "s"),
        },
        coords={"method": ("method", list(r["methods"]), {"long_name": "kernel integrator",
                                                          "units": "1"}),
                "rtol": ("rtol", r["rtols"], {"long_name": "relative tolerance",
                                              "units": "1"}),
                "scipy_method": ("scipy_method", list(r["scipy_methods"]),
                                 {"long_name": "scipy.integrate.solve_ivp method",
                                  "units": "1"}),
                "scipy_rtol": ("scipy_rtol", r["scipy_rtols"],
                               {"long_name": "relative tolerance of the scipy runs",
                                "units": "1"})},
        attrs=dict(attrs, reference=r["reference"], n_points=int(r["n_points"]), repeat=1,
                   atol_ratio=1e-2, bit_reproducible=0),
    )


# --- the study folder ------------------------------------------------------------------------
def build_analysis_study(folder: Path, *, name: str = "analysis_plot_test") -> Path:
    """Write the seven analysis datasets of :data:`STUDY_TEXT` into ``folder``."""
    folder = Path(folder)
    text = STUDY_TEXT.format(name=name)

    def attrs(step, kind):
        return global_attrs(name, step, kind, text)

    sols = shoot_solutions()
    write_nc(shoot_dataset(sols, attrs("shoot", "shoot")), folder / "shoot.nc")
    gait = sols[0]
    fl = floquet_dataset(gait, attrs("floquet", "floquet"))
    write_nc(fl, folder / "floquet.nc")
    lead = float(np.hypot(fl["multipliers_real"][0, 0], fl["multipliers_imag"][0, 0]))
    write_nc(tick_sweep_dataset(gait, lead, attrs("ticks", "tick_sweep")),
             folder / "ticks.nc")
    write_nc(basin_dataset(gait, attrs("basin", "basin")), folder / "basin.nc")
    robot = Robot.preset("seed2009")
    write_nc(continuation_dataset(gait, "gravity", robot.gravity, 0.5, 4,
                                  attrs("family", "continuation")), folder / "family.nc")
    write_nc(continuation_dataset(gait, "com", robot.link1.com, 0.01, 6,
                                  attrs("family_com", "continuation")),
             folder / "family_com.nc")
    write_nc(work_precision_dataset(attrs("timing", "work_precision")), folder / "timing.nc")
    return folder
