"""Synthetic-but-real study datasets for the plotting tests (fixtures: conftest.py).

Until the study runner (``monkeystudy.study``) lands, these builders call the simulator
directly (:func:`monkeystudy.evaluate_gaits`, :func:`monkeystudy.run_controller`) and label the
results exactly as ``docs/datasets.md`` prescribes (grid / refine / stability files with the
global attributes, units, long names and CF status flags). The numbers are real simulation
output on small grids and short runs, so the figures are drawn from genuine data.

``build_study(folder, ...)`` writes a whole study folder; :func:`run_runner_study` runs a tiny
study with the project's runner for the real file layout.
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import monkeystudy
from monkeystudy import (
    Integrator, OpenLoop, Robot, evaluate_gaits, initial_state, run_controller,
)
from monkeystudy.kernel import layout as L
from monkeystudy.kernel.dynamics import kinetic_energy
from monkeystudy.simulation import physical_points

TORQUE = 0.6354
TICK = 0.001
STATUS_NAMES = " ".join(L.STATUS_NAMES)

STUDY_TEXT = """\
schema_version: 1
name: {name}
description: plotting-test study (small grid, short runs)
robot: seed2009
gait: {{kind: horizontal, motor_torque: 0.6354, tick: 0.001}}
integrator: {{method: dop853, rtol: 1.0e-10, atol: 1.0e-12, max_time: 3.0}}
steps:
  - {{name: error_map, kind: grid, dtheta1: {{start: {d1[0]}, stop: {d1[1]}, num: {d1[2]}}},
     dtheta2: {{start: {d2[0]}, stop: {d2[1]}, num: {d2[2]}}}}}
  - {{name: refine_1, kind: refine, start: [1.0, 12.0]}}
  - {{name: refine_2, kind: refine, start: [0.5, 11.75]}}
  - {{name: stability_1, kind: stability, from: refine_1, cycles: {cycles}}}
  - {{name: stability_2, kind: stability, from: refine_2, cycles: {cycles}}}
"""


def _flags(attrs: dict | None = None) -> dict:
    a = {"long_name": "outcome of the run", "units": "1",
         "flag_values": np.arange(len(L.STATUS_NAMES), dtype=np.int8),
         "flag_meanings": STATUS_NAMES}
    a.update(attrs or {})
    return a


def global_attrs(study_name: str, step_name: str, step_kind: str, study_text: str) -> dict:
    """The global attributes every dataset carries (docs/datasets.md)."""
    import netCDF4
    import numba
    import scipy
    robot = Robot.preset("seed2009")
    return {
        "study_name": study_name, "step_name": step_name, "step_kind": step_kind,
        "study_text": study_text,
        "study_sha256": hashlib.sha256(study_text.encode()).hexdigest(),
        "robot": json.dumps(robot.to_dict()),
        "gait": json.dumps({"kind": "horizontal", "motor_torque": TORQUE, "tick": TICK}),
        "integrator": json.dumps({"method": "dop853", "rtol": 1e-10, "atol": 1e-12,
                                  "max_time": 3.0}),
        "monkeystudy_version": monkeystudy.__version__, "git_revision": "test",
        "library_versions": json.dumps({"numpy": np.__version__, "scipy": scipy.__version__,
                                        "numba": numba.__version__, "xarray": xr.__version__,
                                        "netCDF4": netCDF4.__version__}),
        "history": f"{_dt.datetime.now(_dt.timezone.utc).isoformat(timespec='seconds')} "
                   "tests/plotting/conftest.py",
        "Conventions": "CF-1.10",
    }


def grid_dataset(d1: np.ndarray, d2: np.ndarray, attrs: dict) -> xr.Dataset:
    pts = np.array([(a, b) for a in d1 for b in d2])
    r = evaluate_gaits(pts, torque=TORQUE, tick=TICK)
    shape = (len(d1), len(d2))
    dims = ("dtheta1", "dtheta2")

    def var(name, dtype, long_name, units):
        return (dims, r[name].reshape(shape).astype(dtype),
                {"long_name": long_name, "units": units})

    ds = xr.Dataset(
        {
            "error": var("error", float, "horizontal-gait error (docs/model.md section 4)", "1"),
            "status": (dims, r["status"].reshape(shape).astype(np.int8), _flags()),
            "t_switch": var("t_switch", float, "time of the magnet swap", "s"),
            "t_motor": var("t_motor", float, "motor-on duration", "s"),
            "t_end": var("t_end", float, "time of the vertical crossing ending the gait", "s"),
            "steps": var("steps", np.int32, "integration steps", "1"),
            "nfev": var("nfev", np.int32, "right-hand-side evaluations", "1"),
            "rejected": var("rejected", np.int32, "rejected steps", "1"),
        },
        coords={
            "dtheta1": ("dtheta1", d1, {"long_name": "initial rate of link 1",
                                        "units": "rad s-1"}),
            "dtheta2": ("dtheta2", d2, {"long_name": "initial rate of link 2 (relative)",
                                        "units": "rad s-1"}),
        },
        attrs=dict(attrs, skipped_fraction=float(np.mean(r["status"] == L.ST_UNREACHABLE))),
    )
    return ds


def refine_dataset(start: tuple[float, float], attrs: dict, maxiter: int = 60) -> xr.Dataset:
    """Nelder-Mead on the ticked gait error, iterates recorded as the runner does."""
    from scipy.optimize import minimize

    def f(x):
        r = evaluate_gaits([x], torque=TORQUE, tick=TICK)
        return float(r["error"][0]) if r["status"][0] == 0 else 1e3

    its = []

    def cb(xk):
        its.append((xk[0], xk[1], f(xk)))

    res = minimize(f, np.asarray(start, float), method="Nelder-Mead", callback=cb,
                   options={"xatol": 1e-4, "fatol": 1e-8, "maxiter": maxiter})
    best = evaluate_gaits([res.x], torque=TORQUE, tick=TICK)
    its = np.array(its) if its else np.zeros((0, 3))

    def s(v, long_name, units):
        return ((), v, {"long_name": long_name, "units": units})

    n = its.shape[0]
    return xr.Dataset(
        {
            "dtheta1": s(float(res.x[0]), "initial rate of link 1 at the minimum", "rad s-1"),
            "dtheta2": s(float(res.x[1]), "initial rate of link 2 at the minimum", "rad s-1"),
            "error": s(float(best["error"][0]), "horizontal-gait error at the minimum", "1"),
            "status": ((), np.int8(best["status"][0]), _flags()),
            "t_switch": s(float(best["t_switch"][0]), "time of the magnet swap", "s"),
            "t_motor": s(float(best["t_motor"][0]), "motor-on duration", "s"),
            "t_end": s(float(best["t_end"][0]), "time of the vertical crossing", "s"),
            "iterate_dtheta1": ("iteration", its[:, 0], {"long_name": "best vertex dtheta1",
                                                         "units": "rad s-1"}),
            "iterate_dtheta2": ("iteration", its[:, 1], {"long_name": "best vertex dtheta2",
                                                         "units": "rad s-1"}),
            "iterate_error": ("iteration", its[:, 2], {"long_name": "best vertex error",
                                                       "units": "1"}),
            "iterate_nfev": ("iteration", np.arange(1, n + 1, dtype=np.int32) * 2,
                             {"long_name": "cumulative evaluations", "units": "1"}),
        },
        coords={"iteration": ("iteration", np.arange(1, n + 1))},
        attrs=dict(attrs, method="nelder-mead", xatol=1e-4, fatol=1e-8,
                   start=json.dumps(list(map(float, start))), converged=int(res.success),
                   message=str(res.message)),
    )


def stability_dataset(dtheta1: float, dtheta2: float, t_switch: float, t_motor: float,
                      cycles: int, attrs: dict, sample_dt: float = 0.01) -> xr.Dataset:
    """Open-loop repetition, per-cycle quantities taken from the kernel's event log."""
    robot = Robot.preset("seed2009")
    ctrl = OpenLoop(t_switch, t_motor, TORQUE, tick=TICK)
    res = run_controller(ctrl, initial_state(dtheta1, dtheta2), robot=robot,
                         integrator=Integrator(), cycles=cycles, sample_dt=sample_dt,
                         max_drop=2.0)
    log = res.log
    kind, ident = log[:, L.L_KIND], log[:, L.L_ID]
    swaps = np.flatnonzero((kind == L.LOG_SEGMENT) & (ident == 0))
    ends = np.flatnonzero((kind == L.LOG_SEGMENT) & (ident == 2))
    obs = np.flatnonzero(kind == L.LOG_OBSERVER)
    rows = []
    for j in ends:
        prev_obs = obs[obs < j]
        prev_swap = swaps[swaps < j]
        if len(prev_obs) == 0 or len(prev_swap) == 0:
            continue
        o, sw = log[prev_obs[-1]], log[prev_swap[-1]]
        st = o[L.L_STATE:L.L_STATE + 8]
        p = res.params[int(o[L.L_FLIPPED])]
        err = st[3] ** 2 + (dtheta1 - st[6]) ** 2 + (dtheta2 - st[7]) ** 2
        ke = kinetic_energy(p, st[2], st[3], st[4], st[5], st[6], st[7])
        rows.append((err, ke, sw[L.L_STATE + 1], sw[L.L_STATE], o[L.L_T]))
    rows = np.array(rows).reshape(-1, 5)
    x_prev = np.concatenate([[0.0], rows[:-1, 3]])
    n = rows.shape[0]
    flipped = res.sample_mode[:, L.M_FLIPPED]
    pts = physical_points(res.params, res.sample_state, flipped)
    xy = {"long_name": "", "units": "m"}
    return xr.Dataset(
        {
            "error": ("cycle", rows[:, 0], {"long_name": "error at the vertical crossing",
                                            "units": "1"}),
            "kinetic_energy": ("cycle", rows[:, 1], {"long_name": "kinetic energy at the "
                                                     "vertical crossing", "units": "J"}),
            "pivot_height": ("cycle", rows[:, 2], {"long_name": "height of the attached end "
                                                   "after the swap", "units": "m"}),
            "x_advance": ("cycle", rows[:, 3] - x_prev,
                          {"long_name": "horizontal advance of the attached end",
                           "units": "m"}),
            "t_cross": ("cycle", rows[:, 4], {"long_name": "time of the vertical crossing",
                                              "units": "s"}),
            "status": ((), np.int8(res.status), _flags({"long_name": "why the run stopped"})),
            "A": (("sample", "xy"), pts["A"], dict(xy, long_name="position of end A")),
            "joint": (("sample", "xy"), pts["joint"], dict(xy, long_name="position of the joint")),
            "B": (("sample", "xy"), pts["B"], dict(xy, long_name="position of end B")),
            "phase": ("sample", res.sample_mode[:, L.M_PHASE].astype(np.int8),
                      {"long_name": "phase of motion", "units": "1",
                       "flag_values": np.array([0, 1, 2], np.int8),
                       "flag_meanings": "swing flight fixed"}),
            "motor_torque": ("sample", res.sample_mode[:, L.M_TORQUE],
                             {"long_name": "motor torque", "units": "N m"}),
        },
        coords={
            "cycle": ("cycle", np.arange(1, n + 1, dtype=np.int32),
                      {"long_name": "gait cycle", "units": "1"}),
            "time": ("sample", res.sample_t, {"long_name": "time", "units": "s"}),
            "xy": ("xy", ["x", "y"]),
        },
        attrs=dict(attrs, t_switch=float(t_switch), t_motor=float(t_motor),
                   controller=json.dumps({"tick": TICK, "clock": "reset_at_vertical"}),
                   sample_dt=float(sample_dt)),
    )


def write_nc(ds: xr.Dataset, path: Path) -> Path:
    """Atomic write, as the runner does (temporary file in the folder, then os.replace)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(suffix=".nc.tmp", dir=path.parent)
    os.close(fd)
    ds.to_netcdf(tmp, engine="netcdf4")
    os.replace(tmp, path)
    return path


def build_study(folder: Path, *, name: str = "plot_test", d1=(0.0, 2.0, 13),
                d2=(9.0, 14.0, 11), cycles: int = 12, sample_dt: float = 0.02,
                refine_iter: int = 40) -> Path:
    """Write grid, refine and stability datasets of one small study into ``folder``."""
    folder = Path(folder)
    text = STUDY_TEXT.format(name=name, d1=d1, d2=d2, cycles=cycles)

    def attrs(step, kind):
        return global_attrs(name, step, kind, text)

    g = grid_dataset(np.linspace(*d1[:2], d1[2]), np.linspace(*d2[:2], d2[2]),
                     attrs("error_map", "grid"))
    write_nc(g, folder / "error_map.nc")
    for i, start in enumerate([(1.0, 12.0), (0.5, 11.75)], 1):
        r = refine_dataset(start, attrs(f"refine_{i}", "refine"), maxiter=refine_iter)
        write_nc(r, folder / f"refine_{i}.nc")
        s = stability_dataset(float(r.dtheta1), float(r.dtheta2), float(r.t_switch),
                              float(r.t_motor), cycles, attrs(f"stability_{i}", "stability"),
                              sample_dt=sample_dt)
        write_nc(s, folder / f"stability_{i}.nc")
    return folder


#: A tiny study for the real runner (monkeystudy.study): every step kind, multi-start refine,
#: both open-loop clock modes.
RUNNER_STUDY = """\
schema_version: 1
name: plot_runner
description: plotting tests through the real study runner
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
integrator: {method: dop853, rtol: 1.0e-8, atol: 1.0e-10, max_time: 3.0}
steps:
  - {name: coarse_map, kind: grid, dtheta1: {start: 0.0, stop: 1.5, num: 7},
     dtheta2: {start: 9.5, stop: 12.0, num: 9}, block_size: 32}
  - {name: gait1, kind: refine, start: [1.0, 11.0], maxiter: 25}
  - {name: minima, kind: refine, start: {from: coarse_map, best: 2}, maxiter: 15}
  - {name: gait1_cycles, kind: stability, from: gait1, cycles: 3}
  - {name: minima_cycles, kind: stability, from: minima, cycles: 2,
     controller: {clock: run_on}, sample_dt: 0.01}
"""


def run_runner_study(folder: Path, text: str = RUNNER_STUDY) -> Path:
    """Run ``text`` with the project's study runner into ``folder`` (skips if unavailable)."""
    runner = pytest.importorskip("monkeystudy.study.runner")
    loader = pytest.importorskip("monkeystudy.study.loader")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    study_file = folder.parent / "plot_runner.yaml"
    study_file.write_text(text)
    loaded = loader.load_study(study_file)
    runner.run_study(loaded, folder, workers=1)
    return folder


#: Animation settings for tests: a few frames keep them quick.
FAST = dict(fps=5.0, max_frames=6)
