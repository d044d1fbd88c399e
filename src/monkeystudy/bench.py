"""``monkeystudy bench``: speed of the simulator, as ratios to baselines measured in the same run.

Machines are shared and noisy, so every figure printed is paired with a baseline timed in the
same process moments before or after: the bare right-hand side (as a dependent chain, the way
an integrator calls it, and as independent calls), and scipy ``solve_ivp`` running the same
gait with a hand-written scalar right-hand side and with a numpy one. Errors are measured
against a reference gait at rtol 1e-13 computed by scipy (a different implementation), so the
ratios are stated at (at least) equal error.

Run ``python -m monkeystudy.bench`` (or ``monkeystudy bench``); ``--quick`` for a fast pass,
``--startup`` adds cold/cached start-up times: the first gait of each integration method and
the first runs of ``studies/horizontal.yaml`` and ``studies/smoke.yaml`` (a few minutes: each
cold run compiles its kernels afresh).
"""
from __future__ import annotations

import argparse
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from numba import njit

from .analysis.design import DesignSpace, evaluate_design
from .analysis.precision import best_of, kernel_gaits
from .analysis.sections import cycle_section_state
from .analysis.survival import Noise, survival_runs
from .controllers import (
    METHODS, HorizontalSearch, Integrator, Observer, kernel_method, settings_vector,
)
from .kernel.design import cycle_map
from .kernel.dynamics import rhs_swing
from .kernel.layout import C_MAX_CYCLES, N_COUNTS, N_LOG_COLS, N_OBS_COLS, PHASE_SWING
from .kernel.gait import (
    R_ERROR, R_NFEV, R_REJECTED, R_STEPS, R_T_END, R_T_MOTOR, R_T_SWITCH,
    horizontal_gait_batch,
)
from .kernel.trig import sincos
from .reference.scipy_gait import ScipyGait
from .robot import SEED2009_TORQUE, Robot
from .service.client import ServiceError, request
from .simulation import initial_state, run_controller

# ------------------------------------------------------------------------------------------
# kernel timings
# ------------------------------------------------------------------------------------------


# Not cached on disk: numba's cache checks only this file, so a cached chain would keep timing
# the right-hand side it was compiled with after the kernel changes (the kernel's own cache is
# keyed by a hash of all its sources, see kernel/__init__.py). Compiling the three costs ~1 s.
@njit
def _rhs_chain(p, reps, y0):
    """``reps`` RHS evaluations, each input depending on the last output (latency-bound)."""
    y = y0.copy()
    dy = np.zeros(4)
    fm = np.ones(2)
    for _ in range(reps):
        rhs_swing(p, 0.6354, fm, y, dy)
        for i in range(4):
            y[i] += 1e-9 * dy[i]
    return y[0]


@njit
def _rhs_independent(p, ys, reps):
    """``reps * len(ys)`` RHS evaluations on independent inputs (throughput-bound)."""
    dy = np.zeros(4)
    fm = np.ones(2)
    acc = 0.0
    for _ in range(reps):
        for i in range(ys.shape[0]):
            rhs_swing(p, 0.6354, fm, ys[i], dy)
            acc += dy[2]
    return acc


@njit
def _rhs_chain_states(p, reps, states):
    """``reps * len(states)`` RHS evaluations as a dependent chain over given swing states
    (each input is the next state nudged by the last output, so the calls cannot overlap)."""
    y = np.zeros(4)
    dy = np.zeros(4)
    fm = np.ones(2)
    for _ in range(reps):
        for k in range(states.shape[0]):
            for i in range(4):
                y[i] = states[k, i] + 1e-30 * dy[i]
            rhs_swing(p, 0.6354, fm, y, dy)
    return dy[0]


def gait_swing_states(pts) -> np.ndarray:
    """Packed swing states ``[theta1, theta2, dtheta1, dtheta2]`` the gaits from ``pts`` pass
    through (1 ms samples of the default integrator's trajectory)."""
    ctrl = HorizontalSearch(SEED2009_TORQUE)
    rows = []
    for a, b in pts:
        res = run_controller(ctrl, initial_state(a, b), sample_dt=1e-3)
        rows.append(res.sample_state[:, [2, 3, 6, 7]])
    return np.ascontiguousarray(np.concatenate(rows))


def rhs_cost_gait_ns(par, states) -> float:
    """ns per swing RHS evaluation as a dependent chain over the gaits' own states.

    The RHS cost at the arguments the integrator actually sees, the fair denominator for the
    overhead ratio: libm's sine and cosine took ~50 % longer beyond ~2.4 rad than near zero,
    where the gaits' joint angle runs; the kernel's own (``kernel/trig.py``) cost the same at
    every angle, and this figure shows whether that still holds.
    """
    _rhs_chain_states(par[0], 1, states[:4])
    reps = max(1, 200_000 // len(states))
    return best_of(lambda: _rhs_chain_states(par[0], reps, states)) / (reps * len(states)) * 1e9


def cost_split(nfev, seconds) -> tuple[float, float]:
    """Least-squares ``seconds = fixed + marginal * nfev`` over one method's tolerances.

    Returns ``(fixed [s per gait], marginal [s per RHS evaluation])``. The marginal cost is
    what a step costs per stage (the RHS, stage sums, error norm and step control); the fixed
    cost is what a gait pays whatever the tolerance (leg set-up, event location, the swap).
    """
    a = np.column_stack([np.ones(len(nfev)), np.asarray(nfev, dtype=float)])
    (fixed, marginal), *_ = np.linalg.lstsq(a, np.asarray(seconds, dtype=float), rcond=None)
    return float(fixed), float(marginal)


def rhs_cost_ns(par) -> tuple[float, float]:
    """ns per swing RHS evaluation: (dependent chain, independent calls)."""
    y0 = np.array([0.3, 0.5, 1.0, 10.0])
    rng = np.random.default_rng(1)
    ys = np.column_stack([rng.uniform(-1, 1, 256), rng.uniform(-1, 1, 256),
                          rng.uniform(-5, 5, 256), rng.uniform(-12, 12, 256)])
    _rhs_chain(par[0], 10, y0)
    _rhs_independent(par[0], ys, 1)
    n = 200_000
    chain = best_of(lambda: _rhs_chain(par[0], n, y0)) / n * 1e9
    indep = best_of(lambda: _rhs_independent(par[0], ys, n // 256)) / (256 * (n // 256)) * 1e9
    return chain, indep


@njit
def _sincos_chain_kernel(n, a, b):
    """``n`` pairs of the kernel's :func:`.kernel.trig.sincos` of two angles, each pair's
    angles depending on the last results (latency-bound, as in a Runge-Kutta stage)."""
    acc = 0.0
    for _ in range(n):
        s1, c1 = sincos(a)
        s2, c2 = sincos(b)
        acc += s1 * c2 + c1 * s2
        a = a + 1e-3 * (s1 * c2 + 0.3)
        b = b - 1e-3 * (c1 * s2 + 0.2)
    return acc + a + b


@njit
def _sincos_chain_libm(n, a, b):
    """:func:`_sincos_chain_kernel` with the C library's ``sin`` and ``cos``."""
    acc = 0.0
    for _ in range(n):
        s1 = np.sin(a)
        c1 = np.cos(a)
        s2 = np.sin(b)
        c2 = np.cos(b)
        acc += s1 * c2 + c1 * s2
        a = a + 1e-3 * (s1 * c2 + 0.3)
        b = b - 1e-3 * (c1 * s2 + 0.2)
    return acc + a + b


def sincos_cost_ns() -> tuple[float, float]:
    """ns per pair of dependent sine-and-cosine evaluations: (kernel's, C library's)."""
    n = 200_000
    out = []
    for chain in (_sincos_chain_kernel, _sincos_chain_libm):
        chain(10, 0.3, 2.6)
        out.append(best_of(lambda: chain(n, 0.3, 2.6)) / n * 1e9)
    return out[0], out[1]


#: the kernel configurations timed: label -> (method, step-size controller)
KERNEL_CONFIGS = {
    "dop853": ("dop853", "scipy"),
    "rk45": ("rk45", "scipy"),
    "vern9": ("vern9", "scipy"),
    "dop853+pi": ("dop853", "pi"),
    "vern9+pi": ("vern9", "pi"),
}


def gait_points(n: int, seed: int = 0) -> np.ndarray:
    """Gait starts that swap, spread over the study's valley (dtheta1 0.5-1.6, dtheta2 10-12)."""
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(0.5, 1.6, n), rng.uniform(10.0, 12.0, n)])


def _grid_block(args):
    """Process-pool task: evaluate a block of gait points (importable, no lambdas)."""
    pts, rtol = args
    robot = Robot.preset("seed2009")
    prog, _ = HorizontalSearch(SEED2009_TORQUE).program()
    settings = settings_vector(Integrator(rtol=rtol, atol=rtol * 1e-2))
    return kernel_gaits(robot.params(), prog, settings, pts, robot.swap_energy_floor())[:, 0]


def workers_throughput(n_points: int, workers: int, rtol: float) -> float:
    """Gaits per second of a grid evaluated in blocks on a process pool."""
    pts = np.column_stack([np.repeat(np.linspace(0, 3, int(math.sqrt(n_points))),
                                     int(math.sqrt(n_points))),
                           np.tile(np.linspace(9, 14, int(math.sqrt(n_points))),
                                   int(math.sqrt(n_points)))])
    blocks = [(b, rtol) for b in np.array_split(pts, 8 * workers)]
    with ProcessPoolExecutor(workers) as ex:
        list(ex.map(_grid_block, blocks[:workers]))  # warm the cache in every worker
        t0 = time.perf_counter()
        list(ex.map(_grid_block, blocks))
        dt = time.perf_counter() - t0
    return pts.shape[0] / dt


def _cold_env(cold: bool) -> dict:
    """The environment of a fresh process; cold: empty kernel and user caches."""
    env = dict(os.environ)
    if cold:
        tmp = tempfile.mkdtemp(prefix="monkeystudy-cold-")
        env["NUMBA_CACHE_DIR"] = os.path.join(tmp, "numba")
        env["XDG_CACHE_HOME"] = os.path.join(tmp, "cache")
    return env


def startup_seconds(cold: bool, method: str = "dop853") -> float:
    """Seconds from interpreter start to the first simulated gait integrated with ``method``,
    in a fresh process (each method is its own compiled specialisation)."""
    code = ("from monkeystudy.controllers import Integrator; "
            "from monkeystudy.simulation import evaluate_gaits; "
            f"evaluate_gaits([[0.9, 10.9]], integrator=Integrator(method={method!r}))")
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], env=_cold_env(cold), capture_output=True,
                   text=True, check=True)
    return time.perf_counter() - t0


def study_startup_seconds(study: Path, cold: bool) -> float:
    """Seconds of a whole ``monkeystudy run`` of ``study`` in a fresh process, into a new
    folder (cold: empty kernel and user caches)."""
    out = tempfile.mkdtemp(prefix="monkeystudy-startup-")
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "monkeystudy", "run", str(study), "--out", out],
                   env=_cold_env(cold), capture_output=True, text=True, check=True)
    return time.perf_counter() - t0


def print_startup() -> None:
    """Cold against cached start-up: the first gait of each integration method, and the
    first runs of the horizontal and smoke studies (when run from the repository)."""
    print("\nstart-up in a fresh process (cold: empty kernel and user caches):")
    for method in sorted(METHODS):
        cached = startup_seconds(cold=False, method=method)
        cold = startup_seconds(cold=True, method=method)
        print(f"  first gait, {method:7s}: cached {cached:5.2f} s, cold {cold:6.1f} s "
              f"({cold / cached:.0f}x)")
    for name in ("horizontal.yaml", "smoke.yaml"):
        study = Path("studies") / name
        if not study.exists():
            print(f"  {study}: not found (run from the repository to time it)")
            continue
        cached = study_startup_seconds(study, cold=False)   # fills the cache if empty
        cached = study_startup_seconds(study, cold=False)
        cold = study_startup_seconds(study, cold=True)
        print(f"  monkeystudy run {study}: cached {cached:5.2f} s, cold {cold:6.1f} s "
              f"({cold / cached:.0f}x)")


GRID_STUDY = """schema_version: 1
name: bench_grid
description: benchmark grid (generated by monkeystudy bench)
robot: seed2009
gait: {{kind: horizontal, motor_torque: 0.6354, tick: 0.0}}
integrator: {{method: dop853, rtol: {rtol}, atol: {atol}, max_time: 3.0}}
steps:
  - {{name: error_map, kind: grid,
     dtheta1: {{start: 0.0, stop: 3.0, num: {n1}}}, dtheta2: {{start: 9.0, stop: 14.0, num: {n2}}}}}
"""


def _served_runs(tmp: str, study: str, workers: int, repeat: int) -> tuple[float, list[float]]:
    """Start ``monkeystudy serve`` (seconds until it answers), then time ``repeat`` runs of
    ``study`` handed to it by the command line's thin client, each into a fresh folder."""
    sock = os.path.join(tmp, "serve.sock")
    t0 = time.perf_counter()
    server = subprocess.Popen([sys.executable, "-m", "monkeystudy", "serve", "--socket",
                               sock, "--workers", str(workers)], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)
    try:
        while True:
            try:
                request(sock, "ping", timeout=5.0)
                break
            except (ServiceError, OSError):
                if server.poll() is not None:
                    raise RuntimeError("monkeystudy serve exited") from None
                time.sleep(0.02)
        start = time.perf_counter() - t0
        walls = []
        for i in range(repeat):
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-m", "monkeystudy", "run", study, "--out",
                            os.path.join(tmp, f"served{i}"), "--server", "--socket", sock],
                           check=True, capture_output=True, text=True)
            walls.append(time.perf_counter() - t0)
    finally:
        server.terminate()
        server.wait(timeout=30)
    return start, walls


def grid_run(n_points: int, rtol: float = 1e-8, served: int = 0) -> dict:
    """Run a ``n_points`` error map end to end (``monkeystudy run`` in a fresh process; with
    ``served`` > 0 also that many runs handed to a resident ``monkeystudy serve``) and time the
    kernel alone on a sample of the same grid in this process."""
    n1 = max(2, int(round(math.sqrt(n_points * 3.0 / 5.0))))
    n2 = max(2, int(round(n_points / n1)))
    workers = os.cpu_count() or 1
    with tempfile.TemporaryDirectory(prefix="monkeystudy-bench-") as tmp:
        study = os.path.join(tmp, "grid.yaml")
        with open(study, "w") as fh:
            fh.write(GRID_STUDY.format(rtol=rtol, atol=rtol * 1e-2, n1=n1, n2=n2))
        before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "monkeystudy", "run", study, "--out",
                        os.path.join(tmp, "out"), "--workers", str(workers)], check=True,
                       capture_output=True, text=True)
        wall = time.perf_counter() - t0
        peak_kb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
        # xarray loads in ~0.5 s: only this optional measurement pays for it
        import xarray as xr
        with xr.open_dataset(os.path.join(tmp, "out", "error_map.nc")) as ds:
            status = ds["status"].values
            error = ds["error"].values
            if served:
                serve_start, serve_walls = _served_runs(tmp, study, workers, served)
                for i in range(served):   # the same numbers as the command line's run
                    with xr.open_dataset(os.path.join(tmp, f"served{i}",
                                                      "error_map.nc")) as other:
                        if not other["error"].equals(ds["error"]):
                            raise RuntimeError("a served run differs from the direct run")
    # kernel alone, serial, on a random sample of the same grid points
    rng = np.random.default_rng(3)
    a1 = np.linspace(0.0, 3.0, n1)
    a2 = np.linspace(9.0, 14.0, n2)
    pts = np.column_stack([rng.choice(a1, 3000), rng.choice(a2, 3000)])
    robot = Robot.preset("seed2009")
    prog, _ = HorizontalSearch(SEED2009_TORQUE).program()
    st = settings_vector(Integrator(rtol=rtol, atol=rtol * 1e-2))
    kernel_gaits(robot.params(), prog, st, pts[:5], robot.swap_energy_floor())
    per_gait = best_of(lambda: kernel_gaits(robot.params(), prog, st, pts,
                                            robot.swap_energy_floor()), 3) / len(pts)
    predicted = per_gait * n1 * n2 / workers
    extra = {} if not served else {"serve_start": serve_start, "served": serve_walls,
                                   "served_ratios": [w / predicted for w in serve_walls]}
    return {**extra, "points": n1 * n2, "wall": wall, "per_gait": per_gait,
            "predicted": predicted, "ratio": wall / predicted,
            "peak_rss_mb": max(peak_kb, before) / 1024,
            "ok_fraction": float(np.mean(status == 0)),
            "skipped_fraction": float(np.mean(status == 5)), "workers": workers,
            "finite_errors": int(np.isfinite(error).sum())}


def skipping() -> dict:
    """What skipping saves: unreachable starts (energy bound) and unrequested outputs."""
    robot = Robot.preset("seed2009")
    par = robot.params()
    floor = robot.swap_energy_floor()
    a1 = np.linspace(0.0, 3.0, 121)
    a2 = np.linspace(9.0, 14.0, 201)
    grid = np.column_stack([np.repeat(a1, a2.size), np.tile(a2, a1.size)])
    prog, _ = HorizontalSearch(SEED2009_TORQUE).program()
    st = settings_vector(Integrator())
    probe = kernel_gaits(par, prog, st, grid[::7], floor)
    unreachable = grid[::7][probe[:, 1] == 5]
    out = np.empty((len(unreachable), 16))

    method = kernel_method(st, prog, PHASE_SWING)   # outside the timing: Python work

    def run(skip):
        horizontal_gait_batch(method, par, prog, st, unreachable, floor, skip, out)
    run(True)
    run(False)
    t_skip = best_of(lambda: run(True), 3) / len(unreachable)
    t_full = best_of(lambda: run(False), 3) / len(unreachable)
    # a search evaluation (no log, no samples) against the same gait with outputs
    pts = gait_points(16)
    t_eval = best_of(lambda: kernel_gaits(par, prog, st, pts, floor), 5) / len(pts)
    ctrl = HorizontalSearch(SEED2009_TORQUE)

    def with_outputs():
        for a, b in pts:
            run_controller(ctrl, initial_state(a, b), sample_dt=1e-3, log_capacity=64)
    with_outputs()
    t_out = best_of(with_outputs, 3) / len(pts)
    return {"unreachable_fraction": float(np.mean(probe[:, 1] == 5)), "t_skip": t_skip,
            "t_unreachable_integrated": t_full, "t_eval": t_eval, "t_with_outputs": t_out}


def design_cost(repeat: int = 5) -> dict:
    """One design evaluation of the design step (the gait re-solved by Newton with the swap
    time balanced, multipliers by finite differences; then also by variational equations),
    from a start 1e-3 off the fixed point as a grid neighbour gives it, against one cycle of
    the same gait at the same tolerance (DOP853 rtol 1e-13)."""
    space = DesignSpace(Robot.preset("seed2009"), base={"t_switch": 0.4187},
                        balance="t_switch", integrator=Integrator(rtol=1e-13, atol=1e-13))
    free = {"motor_start": -0.3125, "t_motor": 0.36, "torque": -0.57186}
    res = evaluate_design(space, free, [-0.40, 5.0, 5.3])
    if not res.ok:
        raise RuntimeError(f"bench design did not solve: {res.message}")
    near = res.z + 1e-3
    start = dict(free, t_switch=res.values["t_switch"] + 1e-3)
    # the baseline: one compiled cycle of the same gait (what Newton evaluates ~70 times)
    prog, _ = space.gait(res.values).program()
    par = space.robot_for(res.values).params()
    st = settings_vector(space.integrator)
    st[C_MAX_CYCLES] = 1.0
    obs, log = np.empty((0, N_OBS_COLS)), np.empty((0, N_LOG_COLS))
    w_next, counts = np.empty(3), np.zeros(N_COUNTS, np.int64)

    method = kernel_method(st, prog, PHASE_SWING)   # outside the timing: Python work

    def one_cycle():
        cycle_map(method, par, prog, obs, st, 0.0, res.z, w_next, log, counts)
    one_cycle()
    t_cycle = best_of(one_cycle, repeat)
    t_design = best_of(lambda: evaluate_design(space, start, near), repeat)
    t_var = best_of(lambda: evaluate_design(space, start, near, variational=True), repeat)
    again = evaluate_design(space, start, near)
    return {"t_cycle": t_cycle, "t_design": t_design, "t_variational": t_var,
            "iterations": again.iterations, "nfev": again.nfev}


def survival_rate(quick: bool) -> dict:
    """Cycles per second of compiled survival runs (one core): the as-built design's gait
    (docs/findings.md section 6) under 10 us timing jitter, DOP853 rtol 1e-10, against one
    horizontal gait evaluation at the same tolerance."""
    space = DesignSpace(Robot.preset("seed2009"), base={"t_switch": 0.4187},
                        balance="t_switch", integrator=Integrator(rtol=1e-13, atol=1e-13))
    free = {"motor_start": -0.3125, "t_motor": 0.36, "torque": -0.57186}
    res = evaluate_design(space, free, [-0.40, 5.0, 5.3])
    seq = space.gait(res.values)
    n_rows = len(seq.all_segments())
    section = Observer("coord", "theta1", 0.0, "either", segment=n_rows - 1)
    runs, cycles = (4, 200) if quick else (10, 500)

    def go():
        return survival_runs(seq.controller(), cycle_section_state(seq, res.z), res.z,
                             runs=np.arange(runs), max_cycles=cycles, noise=Noise(timing=1e-5),
                             seed=0, robot=space.robot_for(res.values), section=section,
                             min_advance=0.6)
    out = go()
    t = best_of(go, 2 if quick else 3)
    done = int(out.cycles.sum())
    par, pts = Robot.preset("seed2009").params(), gait_points(16)
    prog, _ = HorizontalSearch(SEED2009_TORQUE).program()
    floor = Robot.preset("seed2009").swap_energy_floor()
    t_gait = best_of(lambda: kernel_gaits(par, prog, settings_vector(Integrator()), pts,
                                          floor), 5) / len(pts)
    return {"cycles": done, "seconds": t, "t_gait": t_gait, "runs": runs}


def print_survival_rate(quick: bool) -> None:
    r = survival_rate(quick)
    per = r["seconds"] / r["cycles"]
    print(f"\nsurvival runs (compiled, cycle after cycle; the as-built design under 10 us "
          f"jitter, {r['runs']} runs, {r['cycles']} cycles): {1 / per:.0f} cycles/s on one core "
          f"({per * 1e6:.0f} us per cycle = {per / r['t_gait']:.1f} horizontal gait "
          f"evaluations of {r['t_gait'] * 1e6:.1f} us), {60 / per:.2g} cycles/min per core")


def print_design_cost(quick: bool) -> None:
    d = design_cost(3 if quick else 7)
    print(f"\ndesign evaluation (Newton with the swap time balanced, {d['iterations']} "
          f"iterations, {d['nfev']} RHS evaluations; DOP853 rtol 1e-13): "
          f"{d['t_design'] * 1e3:.2f} ms = {d['t_design'] / d['t_cycle']:.0f} gait cycles "
          f"({d['t_cycle'] * 1e6:.0f} us each, compiled); with variational multipliers "
          f"{d['t_variational'] * 1e3:.2f} ms ({d['t_variational'] / d['t_cycle']:.0f} cycles)")


def parse_args(argv=None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="monkeystudy bench", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="fewer points and repetitions")
    ap.add_argument("--startup", action="store_true", help="also time cold/cached start-up")
    ap.add_argument("--workers", action="store_true", help="also time 1 vs all workers")
    ap.add_argument("--grid", type=int, action="append", metavar="N",
                    help="also run an N-point error map end to end (repeatable: compare peak "
                         "memory across sizes)")
    ap.add_argument("--served", type=int, default=0, metavar="K",
                    help="with --grid: also start 'monkeystudy serve' and time K runs of the "
                         "same map handed to it ('run --server --socket')")
    return ap.parse_args(argv)


def kernel_runs(robot: Robot, pts: np.ndarray, ref: np.ndarray, quick: bool) -> dict:
    """Per kernel configuration and tolerance: ``(seconds per gait, error of the gait error,
    error of the event times)``, mean RHS evaluations and the share of rejected steps."""
    par, floor, npts = robot.params(), robot.swap_energy_floor(), len(pts)
    rows, nfev, rejected = {}, {}, {}
    for label, (method, controller) in KERNEL_CONFIGS.items():
        for rtol in ((1e-6, 1e-10) if quick else (1e-6, 1e-8, 1e-10, 1e-12)):
            if method == "rk45" and rtol < 1e-10:
                continue
            integ = Integrator(method=method, rtol=rtol, atol=rtol * 1e-2, controller=controller)
            prog, _ = HorizontalSearch(SEED2009_TORQUE).program()
            st = settings_vector(integ)
            out = kernel_gaits(par, prog, st, pts, floor)
            reps = 3 if quick else 10
            dt = best_of(lambda: kernel_gaits(par, prog, st, pts, floor), reps) / npts
            e_err = np.nanmax(np.abs(out[:, R_ERROR] - ref[:, 0]))
            e_t = np.nanmax(np.abs(out[:, [R_T_SWITCH, R_T_MOTOR, R_T_END]] - ref[:, 1:4]))
            rows[(label, rtol)] = (dt, e_err, e_t)
            nfev[(label, rtol)] = out[:, R_NFEV].mean()
            # share of attempted steps the controller rejected (each costs a full step)
            rejected[(label, rtol)] = (out[:, R_REJECTED].sum()
                                       / (out[:, R_STEPS] + out[:, R_REJECTED]).sum())
    return {"rows": rows, "nfev": nfev, "rejected": rejected}


def print_kernel_table(k: dict, chain_ns: float, indep_ns: float, gait_ns: float) -> None:
    rows, nfev_of, rejected = k["rows"], k["nfev"], k["rejected"]
    print("\nkernel, per gait (errors: max |difference| of gait error and event times "
          "vs scipy DOP853 rtol 1e-13):")
    print(f"  {'method':9} {'rtol':>7} {'us/gait':>9} {'RHS/gait':>9} {'ns/RHS':>7} "
          f"{'x chain':>8} {'x indep':>8} {'x gait':>7} {'rejected':>9} {'err(error)':>11} "
          f"{'err(times)':>11}")
    for (method, rtol), (dt, e_err, e_t) in rows.items():
        nfev = nfev_of[(method, rtol)]
        print(f"  {method:9} {rtol:7.0e} {dt * 1e6:9.1f} {nfev:9.0f} {dt / nfev * 1e9:7.1f} "
              f"{dt / (nfev * chain_ns * 1e-9):8.2f} {dt / (nfev * indep_ns * 1e-9):8.2f} "
              f"{dt / (nfev * gait_ns * 1e-9):7.2f} {rejected[(method, rtol)]:9.1%} "
              f"{e_err:11.2e} {e_t:11.2e}")
    print("  cost split over the tolerances (us/gait = fixed + marginal x RHS/gait):")
    for method in KERNEL_CONFIGS:
        keys = [key for key in rows if key[0] == method]
        if len(keys) < 2:
            continue
        fixed, marginal = cost_split([nfev_of[key] for key in keys], [rows[key][0] for key in keys])
        print(f"    {method:9} marginal {marginal * 1e9:5.1f} ns per RHS "
              f"({marginal * 1e9 / chain_ns:.2f}x chain, {marginal * 1e9 / gait_ns:.2f}x gait "
              f"states), fixed {fixed * 1e6:4.1f} us per gait")


def print_scipy_comparison(robot: Robot, pts: np.ndarray, ref: np.ndarray, quick: bool) -> None:
    """scipy ``solve_ivp`` on the same gaits against the kernel's DOP853 at rtol 1e-10."""
    par, floor = robot.params(), robot.swap_energy_floor()
    print("\nscipy solve_ivp, same gait (events, terminal), per gait (best of 3):")
    nsub = min(len(pts), 4 if quick else 8)
    for rhs_kind in ("scalar", "numpy"):
        sg = ScipyGait(robot, SEED2009_TORQUE, rhs_kind)
        for method, rtol in (("DOP853", 1e-10), ("RK45", 1e-10), ("LSODA", 1e-10)):
            if rhs_kind == "numpy" and method != "DOP853":
                continue
            # best of three, as the kernel's times: one disturbed pass of scipy would flatter
            # the ratio (single passes read 8.9 and 12.0 ms/gait in two runs of one day); the
            # untimed first pass gives the results and warms scipy up
            res = [sg.gait(a, b, rtol, rtol * 1e-2, method=method) for a, b in pts[:nsub]]
            dt = best_of(lambda: [sg.gait(a, b, rtol, rtol * 1e-2, method=method)
                                  for a, b in pts[:nsub]], 2 if quick else 3) / nsub
            res = np.array([r[:4] for r in res])
            e_err = np.nanmax(np.abs(res[:, 0] - ref[:nsub, 0]))
            e_t = np.nanmax(np.abs(res[:, 1:4] - ref[:nsub, 1:4]))
            # the kernel on the very same points, for an honest comparison of errors
            integ = Integrator(method="dop853", rtol=1e-10, atol=1e-12)
            prog, _ = HorizontalSearch(SEED2009_TORQUE).program()
            st = settings_vector(integ)
            kt = best_of(lambda: kernel_gaits(par, prog, st, pts[:nsub], floor), 5) / nsub
            ko = kernel_gaits(par, prog, st, pts[:nsub], floor)
            mine = (kt, np.nanmax(np.abs(ko[:, R_ERROR] - ref[:nsub, 0])),
                    np.nanmax(np.abs(ko[:, [R_T_SWITCH, R_T_MOTOR, R_T_END]] - ref[:nsub, 1:4])))
            print(f"  {method:6} {rhs_kind:6} rtol {rtol:.0e}: {dt * 1e3:8.2f} ms/gait, "
                  f"err(error) {e_err:.2e}, err(times) {e_t:.2e}  ->  kernel DOP853 rtol 1e-10 "
                  f"on the same points is {dt / mine[0]:.0f}x faster (its errors "
                  f"{mine[1]:.1e}, {mine[2]:.1e})")


def print_skipping() -> None:
    sk = skipping()
    print(f"\nskipping: {sk['unreachable_fraction']:.1%} of the study's error map provably "
          f"cannot reach the swap; marking one costs {sk['t_skip'] * 1e9:.0f} ns, integrating "
          f"it to the horizon {sk['t_unreachable_integrated'] * 1e6:.0f} us "
          f"({sk['t_unreachable_integrated'] / sk['t_skip']:.0f}x). A search evaluation "
          f"{sk['t_eval'] * 1e6:.1f} us/gait; the same gait with a 1 ms trajectory and event log "
          f"through the Python API {sk['t_with_outputs'] * 1e6:.0f} us "
          f"({sk['t_with_outputs'] / sk['t_eval']:.1f}x)")


def print_grid_run(n: int, served: int) -> None:
    g = grid_run(n, served=served)
    print(f"\nend-to-end error map, {g['points']} points, {g['workers']} workers, "
          f"DOP853 rtol 1e-8: {g['wall']:.2f} s wall; kernel alone "
          f"{g['per_gait'] * 1e6:.1f} us/gait -> predicted {g['predicted']:.2f} s; ratio "
          f"{g['ratio']:.2f}; peak RSS {g['peak_rss_mb']:.0f} MB; ok {g['ok_fraction']:.3f}, "
          f"skipped (unreachable) {g['skipped_fraction']:.3f}")
    if served:
        print(f"  handed to a resident 'monkeystudy serve' (started in "
              f"{g['serve_start']:.1f} s, once): "
              + ", ".join(f"{w:.2f} s" for w in g["served"]) + " wall; ratio "
              + ", ".join(f"{r:.2f}" for r in g["served_ratios"])
              + " (same datasets as the direct run)")


def main(argv=None) -> int:
    args = parse_args(argv)
    robot = Robot.preset("seed2009")
    par = robot.params()
    npts = 8 if args.quick else 24
    pts = gait_points(npts)
    print(f"monkeystudy bench: seed2009 horizontal gait, {npts} points, "
          f"{os.cpu_count()} cores; all ratios use baselines timed in this run")

    # the baselines are timed before and after the kernel runs and the smaller of the two is
    # used: a shared machine disturbs one short window now and then, and a disturbed baseline
    # would flatter every ratio below
    swing_states = gait_swing_states(pts)
    chain_ns, indep_ns = rhs_cost_ns(par)
    gait_ns = rhs_cost_gait_ns(par, swing_states)
    # reference: scipy DOP853 at rtol 1e-13 (a different implementation)
    ref = np.array([ScipyGait(robot, SEED2009_TORQUE).gait(a, b, 1e-13, 1e-13)[:4]
                    for a, b in pts])
    kernel = kernel_runs(robot, pts, ref, args.quick)
    chain_before = chain_ns
    chain_after, indep_after = rhs_cost_ns(par)
    chain_ns, indep_ns = min(chain_ns, chain_after), min(indep_ns, indep_after)
    gait_ns = min(gait_ns, rhs_cost_gait_ns(par, swing_states))
    print(f"\nRHS (swing, compiled; best of a timing before and one after the kernel runs): "
          f"{chain_ns:.1f} ns per evaluation as a dependent chain ({chain_before:.1f} / "
          f"{chain_after:.1f}), {indep_ns:.1f} ns independent (both at small angles); "
          f"{gait_ns:.1f} ns as a chain over the gaits' own states")
    trig_kernel, trig_libm = sincos_cost_ns()
    print(f"sine and cosine of two angles as a dependent chain: {trig_kernel:.1f} ns with the "
          f"kernel's own (kernel/trig.py), {trig_libm:.1f} ns with the C library's "
          f"({trig_libm / trig_kernel:.2f}x)")
    print_kernel_table(kernel, chain_ns, indep_ns, gait_ns)
    print_scipy_comparison(robot, pts, ref, args.quick)
    if args.workers:
        n = 2500 if args.quick else 20000
        w1 = workers_throughput(n, 1, 1e-8)
        wn = workers_throughput(n, os.cpu_count() or 1, 1e-8)
        print(f"\nprocess pool, {n}-point grid (seed2009 map, rtol 1e-8): "
              f"1 worker {w1:.0f} gaits/s, {os.cpu_count()} workers {wn:.0f} gaits/s, "
              f"speed-up {wn / w1:.2f}x")
    print_skipping()
    print_design_cost(args.quick)
    print_survival_rate(args.quick)
    for n in args.grid or []:
        print_grid_run(n, args.served)
    if args.startup:
        print_startup()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
