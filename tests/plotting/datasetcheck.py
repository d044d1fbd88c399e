"""What must hold of the datasets a study run writes: :func:`check_datasets`, called by
reportcheck.run_and_report for every study the property test draws and every kept case.

* **No unexplained NaN.** Each kind's rule below (:data:`NAN_RULES`, from docs/datasets.md)
  says where a float variable may be NaN; a NaN anywhere else is a problem, and a variable no
  rule names may hold none. Where NaN is legitimate, per kind:

  - grid, refine: the results of a point (a start) whose status is not ok; a refine's
    iterates after its ``n_iterations``, and the error of its best vertex until the search
    reaches a gait;
  - stability: every per-cycle value of the cycles after the run stopped (after
    ``cycles_completed``); the error, kinetic energy and crossing time of a cycle the step's
    line in the run's log names as reaching no vertical crossing; a sequence gait's swap
    time when its gait has no magnet action;
  - shoot: the error and times of a solution whose status is not ok, the Newton history
    after its last iteration;
  - floquet: everything a controller whose return map was not analysed (``failure``) did not
    measure; the schedule (``t_switch``, ``t_motor``, ``motor_torque``) of a sequence gait's
    own cycle, named per segment instead;
  - tick_sweep: the cycles after a tick's run stopped (after its ``cycles_completed``); the
    growth per cycle of a tick with fewer than 3 cycles in its fitting window;
  - stress: the drift after a run that did not reach its end time stopped, its growth
    exponent with fewer than 3 values above the round-off floor in the last decade, the
    final drift per period of such a run; the schedule of a state-based long run, and of an
    open-loop long run that did not start (its gait not evaluated at the start); the energy
    change of every case but the free run;
  - survival: the MFPT of a level where no run failed late enough to fit a tail
    (``lower_bound``); a hazard with no cycle at risk; the advance per cycle of a level whose
    runs completed no cycle, and the distances made of a NaN; the final error and height
    drift of a run that completed no cycle; the height fraction of a level where no run
    completed its cycles;
  - design: a design's results where its status is not ok (its energy per metre also where
    it does not advance); a replay's cycles after it stopped; the decay run's cycles after it
    stopped;
  - work_precision: the errors where no point had a gait in both the run and its
    reference (with ``first_swing_only`` every point has one in the reference: where the run
    missed it at every point; without, anywhere);
  - basin, continuation: nowhere.

* **A replay of a converged fixed point stays near it** (:func:`replay_problems`). A run from
  a floquet step's fixed point ``z`` on exact timing leaves it only as the map's defect
  grows: after ``k`` cycles its distance from ``z`` is at most about ``|P(z) - z|`` times
  ``1 + rho + ... + rho^(k-1)`` (``rho`` the largest multiplier modulus, at least 1), plus
  the map's own error level per cycle. Every cycle whose bound, times a margin of
  :data:`MARGIN` for the multipliers' eigenvectors, is below :data:`NEAR` must be reached
  within it: in a stability or tick_sweep run (its exact-timing tick), at a basin's zero
  offset and in the runs of a survival level without noise. A replay of another map than
  the one analysed (an open-loop replay of a state-based fixed point, a running clock) is
  held to its first cycle only. A stability run of a refine step's start on the refine's own
  tick repeats the refine's cycle: its first error is the refine's.

* **A floquet step's handed-on point is converged, or the next step's refusal says it is
  not** (:func:`floquet_problems`): a Newton polish that did not converge is named in the
  floquet step's line of the run's log, and one said to have converged left a point the map
  moves less than :data:`MARGIN_DEFECT` times its error level; a step run from a floquet
  point ran one whose polish converged (survival and design: or one the map moves less than
  1e-8, as docs/datasets.md says); a step refused because of its floquet step's point says
  so, and the point is not a fixed point to the map's error level (not converged, and the
  map moves it more than its error level).
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import xarray as xr

#: a replay's distance from its fixed point stays within the linear bound times this
MARGIN = 1e3

#: cycles are checked while the bound stays below this distance [1]: far below where a run
#: could fail, and in the linear regime
NEAR = 1e-4

#: a converged point's map defect is at most its map error level times this
MARGIN_DEFECT = 10.0


def flag(da: xr.DataArray, meaning: str) -> int | None:
    """The value of a CF flag variable that means ``meaning`` (None: it has no such flag)."""
    meanings = str(da.attrs.get("flag_meanings", "")).split()
    if meaning not in meanings:
        return None
    return int(np.asarray(da.attrs["flag_values"])[meanings.index(meaning)])


def _mask(condition, like: xr.DataArray) -> np.ndarray:
    """``condition`` (a bool DataArray, or a bool) broadcast to ``like``'s shape."""
    if isinstance(condition, (bool, np.bool_)):
        return np.full(like.shape, bool(condition))
    cond = condition.variable.set_dims(dict(like.sizes))
    return np.asarray(cond.transpose(*like.dims).values, bool)


def _suffix_nan(da: xr.DataArray, dim: str) -> xr.DataArray:
    """True from the first NaN along ``dim`` on (NaN allowed only after a run stopped)."""
    nan = np.isnan(da.values)
    axis = da.dims.index(dim)
    return xr.DataArray(np.maximum.accumulate(nan, axis=axis), dims=da.dims)


def _not_ok(ds: xr.Dataset, var: str = "status") -> xr.DataArray:
    return ds[var] != flag(ds[var], "ok")


# --- where each kind may hold NaN ----------------------------------------------------------------
def grid_nan(ds: xr.Dataset, ctx: dict) -> dict:
    bad = _not_ok(ds)
    return {v: bad for v in ("error", "t_switch", "t_motor", "t_end", "t_segment",
                             "x_advance", "y_advance")}


def refine_nan(ds: xr.Dataset, ctx: dict) -> dict:
    bad = _not_ok(ds)
    out = {v: bad for v in ("error", "t_switch", "t_motor", "t_end", "t_segment",
                            "x_advance", "y_advance")}
    after = ds["iteration"] >= ds["n_iterations"]
    out.update({v: after for v in ("iterate_dtheta1", "iterate_dtheta2", "iterate_error")})
    # the best vertex has no gait until the search finds one (its objective the penalty)
    no_gait_yet = ~np.isfinite(ds["iterate_error"]).cumsum("iteration").astype(bool)
    out["iterate_error"] = after | no_gait_yet
    return out


#: the cycles a stability step's line names as reaching no vertical crossing
UNCROSSED = re.compile(r"\(([\d, ]+)\) reached no vertical crossing")


def stability_nan(ds: xr.Dataset, ctx: dict) -> dict:
    after = ds["cycle"] > int(ds.attrs.get("cycles_completed", 0))
    named = set()
    for m in UNCROSSED.finditer(ctx["note"]):
        named |= {int(c) for c in m.group(1).split(",")}
    crossing = after | ds["cycle"].isin(sorted(named))
    out = {"error": crossing, "kinetic_energy": crossing, "t_cross": crossing,
           "pivot_height": after, "x_advance": after, "t_swap": after}
    gait = ctx["study"]["gait"]
    if gait["kind"] == "sequence" and all(seg.get("magnets", "keep") == "keep"
                                          for seg in gait["segments"]):
        out["t_swap"] = True
    return out


def shoot_nan(ds: xr.Dataset, ctx: dict) -> dict:
    bad = _not_ok(ds)
    out = {v: bad for v in ("error", "t_end", "t_switch", "t_motor", "residual_norm")}
    out["history"] = _suffix_nan(ds["history"], "iteration")
    return out


def floquet_nan(ds: xr.Dataset, ctx: dict) -> dict:
    failed = ds["failure"].astype(str) != ""
    out = {v: failed for v in ds.data_vars if "controller" in ds[v].dims}
    own = ds["controller"].astype(str) == "sequence"
    for v in ("t_switch", "t_motor", "motor_torque"):
        out[v] = failed | own
    return out


def tick_sweep_nan(ds: xr.Dataset, ctx: dict) -> dict:
    after = ds["cycle"] > ds["cycles_completed"]
    root = np.sqrt(ds["error"].values)
    with np.errstate(invalid="ignore"):
        window = (np.isfinite(root) & (root > 1e-10) & (root < 1e-4)).sum(axis=1)
    return {"error": after, "pivot_height": after,
            "growth_per_cycle": xr.DataArray(window < 3, dims=("tick",))}


def stress_nan(ds: xr.Dataset, ctx: dict) -> dict:
    out = {}
    if "energy_drift" in ds:
        stopped = ds["drift_status"] != flag(ds["drift_status"], "end_time")
        out["energy_drift"] = stopped & _suffix_nan(ds["energy_drift"], "checkpoint")
        drift = ds["energy_drift"].transpose("drift_phase", "drift_rtol", "checkpoint").values
        time = ds["time"].transpose("drift_phase", "checkpoint").values
        floor = float(ds.attrs.get("drift_floor", 0.0))
        few = np.zeros(drift.shape[:2], bool)
        for p in range(drift.shape[0]):
            last = time[p] >= np.nanmax(time[p]) / 10
            with np.errstate(invalid="ignore"):
                few[p] = (np.isfinite(drift[p][:, last]) & (drift[p][:, last] > floor)
                          ).sum(axis=1) < 3
        out["growth_exponent"] = xr.DataArray(few, dims=("drift_phase", "drift_rtol"))
        out["drift_per_period"] = np.isnan(ds["energy_drift"].isel(checkpoint=-1))
    if "run" in ds.dims:
        # a state-based run replays no schedule; an open-loop run whose gait cannot be
        # evaluated at the start does not start (0 cycles, no time): its schedule is the
        # failed evaluation's
        state_based = ds["run"].astype(str).str.startswith("search")
        not_started = (ds["cycles_completed"] == 0) & (ds["t_final"] == 0)
        out.update(t_switch=state_based | not_started, t_motor=state_based | not_started)
    if "case" in ds.dims:
        out["energy_change"] = ds["case"].astype(str) != "coulomb_sticking"
    return out


def survival_nan(ds: xr.Dataset, ctx: dict) -> dict:
    cycles = ds["cycles_completed"]
    failed = ds["failure"] != flag(ds["failure"], "survived")
    m = int(ds.attrs["max_cycles"])
    half = m // 2
    attempted = xr.where(failed, cycles + 1, cycles)
    early = attempted.clip(0, half).sum("run") == 0
    late = (attempted.clip(half, m) - half).sum("run") == 0
    no_cycle = cycles.sum("run") == 0
    out = {"mfpt": ds["mfpt_method"] == flag(ds["mfpt_method"], "lower_bound"),
           "hazard_early": early, "hazard_late": late, "advance_per_cycle": no_cycle,
           "final_error": cycles == 0, "height_drift": cycles == 0,
           "height_within_tolerance": (~failed).sum("run") == 0}
    out["mfpt_distance"] = np.isnan(ds["mfpt"]) | no_cycle
    out["mfpt_distance_low"] = np.isnan(ds["mfpt_low"]) | no_cycle
    out["mfpt_distance_high"] = np.isnan(ds["mfpt_high"]) | no_cycle
    return out


def design_nan(ds: xr.Dataset, ctx: dict) -> dict:
    grid = set(ds["status"].dims)
    bad = _not_ok(ds)
    out = {}
    for v in ds.data_vars:
        if grid and grid <= set(ds[v].dims) and set(ds[v].dims) - grid <= {"k"}:
            out[v] = bad
    if "energy_per_metre" in ds:
        out["energy_per_metre"] = bad | (ds["advance"] <= 0)
    stopped = _not_ok(ds, "replay_status") if "replay_status" in ds else False
    for v in ("replay_error", "replay_kinetic_energy", "replay_pivot_height"):
        if v in ds:
            out[v] = stopped & _suffix_nan(ds[v], "cycle")
    if "perturbation_distance" in ds:
        out["perturbation_distance"] = _suffix_nan(ds["perturbation_distance"], "decay_cycle")
    return out


def work_precision_nan(ds: xr.Dataset, ctx: dict) -> dict:
    """Errors are NaN where no point had a gait in both the run and the reference: with
    ``first_swing_only`` every point kept has one in the reference, so where the run missed
    it at every point; without, the points (and scipy's first ones) may hold none."""
    if not int(ds.attrs.get("first_swing_only", 1)):
        return {v: True for v in ("error_value", "error_times", "scipy_error_value",
                                  "scipy_error_times")}
    missed = ds["status_mismatch"] == int(ds.attrs["n_points"])
    return {"error_value": missed, "error_times": missed}


def nowhere(ds: xr.Dataset, ctx: dict) -> dict:
    return {}


#: each kind's rule: where its variables may be NaN (a bool DataArray, or True: anywhere)
NAN_RULES = {
    "grid": grid_nan, "refine": refine_nan, "stability": stability_nan, "shoot": shoot_nan,
    "floquet": floquet_nan, "tick_sweep": tick_sweep_nan, "basin": nowhere,
    "continuation": nowhere, "work_precision": work_precision_nan, "stress": stress_nan,
    "survival": survival_nan, "design": design_nan,
}


def nan_problems(ds: xr.Dataset, ctx: dict) -> list[str]:
    """Every float variable's NaN outside the places its kind's rule explains."""
    kind = ds.attrs["step_kind"]
    allowed = NAN_RULES[kind](ds, ctx)
    out = []
    for name in ds.variables:
        da = ds[name]
        if da.dtype.kind != "f":
            continue
        nan = np.isnan(da.values)
        if not nan.any():
            continue
        rule = allowed.get(name)
        where = nan & ~_mask(rule, da) if rule is not None else nan
        if where.any():
            at = np.argwhere(where)[0]
            index = ", ".join(f"{d}={i}" for d, i in zip(da.dims, at))
            out.append(f"{kind} variable {name}: {int(where.sum())} unexplained NaN "
                       f"(first at {index or 'the scalar'})")
    if kind == "grid":           # docs/datasets.md: error NaN wherever status != 0
        finite = np.isfinite(ds["error"].values) & _mask(_not_ok(ds), ds["error"])
        if finite.any():
            out.append("grid error finite where the status is not ok")
    return out


# --- replays of a fixed point --------------------------------------------------------------------
def _rtol(study: dict) -> float:
    return float((study.get("integrator") or {}).get("rtol", 1e-10))


def fixed_point_row(f: xr.Dataset, ds: xr.Dataset) -> int | None:
    """The floquet controller a dataset ran from: named (``floquet_controller``), else the
    one whose fixed point it started at."""
    labels = [str(c) for c in f["controller"].values]
    if "floquet_controller" in ds.attrs:
        c = str(ds.attrs["floquet_controller"])
        return labels.index(c) if c in labels else None
    if "dtheta1" not in ds.attrs:
        return None
    start = np.array([float(ds.attrs.get("start_theta2", np.nan)), float(ds.attrs["dtheta1"]),
                      float(ds.attrs["dtheta2"])])
    fp = f["fixed_point"].values
    gap = np.nanmax(np.abs(fp[:, 1:] - start[1:]), axis=1)
    i = int(np.argmin(gap))
    return i if gap[i] < 1e-9 * max(1.0, float(np.abs(start[1:]).max())) else None


def fixed_point_bounds(f: xr.Dataset, i: int, rtol: float) -> tuple[np.ndarray, float] | None:
    """Per cycle k (from 1), the bound on the distance of a run from floquet point ``i``
    after k cycles, while it stays below :data:`NEAR`; None when the point was not analysed
    or not polished."""
    if str(f["failure"].values[i]) or int(f["newton_converged"].values[i]) == 0:
        return None
    lam = np.abs(f["multipliers_real"].values[i] + 1j * f["multipliers_imag"].values[i])
    if not np.all(np.isfinite(lam)):
        return None
    defect = float(f["map_defect"].values[i]) + map_level(f, i, rtol)
    rho = max(1.0, float(lam.max()))
    bounds = MARGIN * defect * np.cumsum(rho ** np.arange(200))
    return bounds[bounds <= NEAR]


def _same_map(f: xr.Dataset, i: int, ds: xr.Dataset, clock: str) -> bool:
    """The run repeats the return map analysed at floquet point ``i``: its own controller's
    (a sequence gait's, or the search controller run as itself) or the open-loop replay of
    the open_loop map, the clock restarting at each cycle's end."""
    controller = str(f["controller"].values[i])
    replay = str(ds.attrs.get("replay", ""))
    same = ((controller == "open_loop" and replay == "open_loop")
            or (controller in ("sequence", "search") and replay == "gait"))
    return same and clock != "run_on"


def replay_problems(datasets: dict[str, xr.Dataset], study: dict) -> list[str]:
    """The runs from a floquet step's fixed point that leave it faster than its map allows,
    and the stability runs of a refine step's start whose first cycle is not the refine's."""
    out = []
    rtol = _rtol(study)
    gait_tick = float(study["gait"].get("tick", 0.0))
    for name, ds in datasets.items():
        kind = ds.attrs["step_kind"]
        if kind == "stability" and "refine_step" in ds.attrs:
            out += refine_replay_problems(name, ds, datasets, gait_tick)
        source = ds.attrs.get("floquet_step")
        if kind not in ("stability", "tick_sweep", "basin", "survival") or \
                source not in datasets:
            continue
        f = datasets[source]
        i = fixed_point_row(f, ds)
        if i is None:
            continue
        bounds = fixed_point_bounds(f, i, rtol)
        if bounds is None or not bounds.size:
            continue
        if kind == "stability":
            controller = json.loads(ds.attrs["controller"])
            tick = controller.get("tick")
            tick = gait_tick if tick is None else float(tick)
            if tick == 0:
                k = bounds.size if _same_map(f, i, ds, controller.get("clock")) else 1
                out += near_problems(f"{name} (stability)", ds["error"].values, bounds[:k])
        elif kind == "tick_sweep":
            k = bounds.size if _same_map(f, i, ds, "") else 1
            for row, tick in enumerate(ds["tick"].values):
                if float(tick) == 0:
                    out += near_problems(f"{name} (tick_sweep, exact timing)",
                                         ds["error"].values[row], bounds[:k])
        elif kind == "basin":
            at = (ds["d_dtheta1"] == 0) & (ds["d_dtheta2"] == 0)
            if float(ds.attrs.get("tick", 0.0)) == 0 and bool(at.any()):
                k = bounds.size if _same_map(f, i, ds, "") else 1
                need = min(k, int(ds.attrs["max_cycles"]))
                got = int(ds["cycles"].values[np.asarray(at.values)].min())
                if got < need:
                    out.append(f"{name} (basin): the fixed point's own start failed after "
                               f"{got} cycles, within {need} cycles of its map's bound")
        elif kind == "survival":
            out += survival_near_problems(name, ds, f, i, bounds)
    return out


def near_problems(what: str, error: np.ndarray, bounds: np.ndarray) -> list[str]:
    """The cycles of a run (``error`` per cycle, the squared distance) beyond their bound."""
    for k, bound in enumerate(bounds[:error.size], start=1):
        e = float(error[k - 1])
        if not (math.isfinite(e) and math.sqrt(e) <= bound):
            return [f"{what}: from a converged fixed point, cycle {k} ends {math.sqrt(e):.3g} "
                    f"from it (error {e:.3g}); its map allows {bound:.3g}"]
    return []


def survival_near_problems(name: str, ds: xr.Dataset, f: xr.Dataset, i: int,
                           bounds: np.ndarray) -> list[str]:
    """A survival level without noise runs the fixed point as a stability run would: no run
    fails within the cycles its map's bound holds (on exact timing)."""
    if float(ds.attrs.get("tick", 0.0)) != 0:
        return []
    bound = float(ds.attrs.get("error_bound", math.inf))
    k = bounds.size if _same_map(f, i, ds, str(ds.attrs.get("clock", ""))) else 1
    k = int(np.sum(bounds[:k] ** 2 < bound))
    need = min(k, int(ds.attrs["max_cycles"]))
    noise = [v for v in ds.data_vars if v.startswith("noise_")]
    out = []
    for level in range(ds.sizes["level"]):
        if any(float(ds[v].values[level]) != 0 for v in noise):
            continue
        got = int(ds["cycles_completed"].values[level].min())
        if got < need:
            out.append(f"{name} (survival): at the level without noise a run from the "
                       f"converged fixed point failed after {got} cycles, within {need} "
                       "cycles of its map's bound")
    return out


def refine_replay_problems(name: str, ds: xr.Dataset, datasets: dict,
                           gait_tick: float) -> list[str]:
    """A stability run of a refine step's start, on the refine's tick, repeats its cycle."""
    refine = datasets.get(ds.attrs["refine_step"])
    controller = json.loads(ds.attrs["controller"])
    tick = controller.get("tick")
    if refine is None or (tick is not None and float(tick) != gait_tick):
        return []
    start = int(ds.attrs.get("refine_start", 0))
    e_refine = float(np.ravel(refine["error"].values)[start])
    if not (math.isfinite(e_refine) and int(ds.attrs.get("cycles_completed", 0)) >= 1):
        return []
    e1 = float(ds["error"].values[0])
    if not abs(e1 - e_refine) <= 1e-6 * max(e_refine, 1e-6):
        return [f"{name} (stability): its first cycle's error {e1:.10g} is not its refine "
                f"step's {e_refine:.10g} at the start it replays"]
    return []


# --- floquet points handed on --------------------------------------------------------------------
#: survival and design run a floquet point the map moves less than this [1], its Newton
#: polish converged or not (docs/datasets.md)
LOOSE_DEFECT = 1e-8


def map_level(f: xr.Dataset, i: int, rtol: float) -> float:
    """The return map's error level at floquet point ``i`` [1]: as the step measured it
    (``map_error``), else ten times the tolerance at the point's scale."""
    if "map_error" in f:
        return float(f["map_error"].values[i])
    return 10 * rtol * max(1.0, float(np.abs(f["fixed_point"].values[i]).max()))


def floquet_problems(datasets: dict[str, xr.Dataset], study: dict, notes: dict[str, str],
                     failed: dict[str, str]) -> list[str]:
    """A floquet step's unconverged polish is named in its log line, and its converged one
    is a fixed point to the map's error level; a step run from a floquet point ran one
    whose polish converged (survival and design: or one the map moves less than
    :data:`LOOSE_DEFECT`); a step refused because of a floquet point says so, and the point
    is not a fixed point to the map's error level."""
    out = []
    rtol = _rtol(study)
    steps = {s["name"]: s for s in study["steps"]}
    for name, f in datasets.items():
        if f.attrs["step_kind"] != "floquet":
            continue
        for i, c in enumerate(f["controller"].values):
            if str(f["failure"].values[i]):
                continue
            defect, level = float(f["map_defect"].values[i]), map_level(f, i, rtol)
            if int(f["newton_converged"].values[i]) == 0:
                if "not converged" not in notes.get(name, "").lower():
                    out.append(f"{name} (floquet): {c}'s Newton polish did not converge, and "
                               f"the step's line does not say so: {notes.get(name, '')!r}")
            elif str(c) != "open_loop" and not defect <= MARGIN_DEFECT * level:
                out.append(f"{name} (floquet): {c}'s Newton polish is said to have converged "
                           f"at a point the map moves {defect:.3g} (its error level "
                           f"{level:.3g})")
    for name, ds in datasets.items():
        source = ds.attrs.get("floquet_step")
        kind = ds.attrs["step_kind"]
        if source not in datasets or kind == "floquet":
            continue
        f = datasets[source]
        i = fixed_point_row(f, ds)
        if i is None:
            continue
        newton = int(f["newton_converged"].values[i]) == 1
        loose = kind in ("survival", "design") and \
            float(f["map_defect"].values[i]) <= LOOSE_DEFECT
        if str(f["failure"].values[i]) or not (newton or loose):
            out.append(f"{name}: ran floquet step {source!r}'s {f['controller'].values[i]} "
                       f"point, which is not polished ({point_text(f, i, rtol)})")
    for name, why in failed.items():
        source = steps.get(name, {}).get("from")
        if source not in datasets or datasets[source].attrs["step_kind"] != "floquet":
            continue
        f = datasets[source]
        m = re.search(r"has no (\w+) fixed point", why)
        labels = [str(c) for c in f["controller"].values]
        if m is None or m.group(1) not in labels:
            continue
        i = labels.index(m.group(1))
        newton = int(f["newton_converged"].values[i]) == 1
        at_level = float(f["map_defect"].values[i]) <= map_level(f, i, rtol)
        if not str(f["failure"].values[i]) and (newton or at_level):
            out.append(f"{name}: refused floquet step {source!r}'s {labels[i]} point, a fixed "
                       f"point to its map's error level ({point_text(f, i, rtol)}): {why}")
    return out


def point_text(f: xr.Dataset, i: int, rtol: float) -> str:
    return (f"map defect {float(f['map_defect'].values[i]):.3g}, map error level "
            f"{map_level(f, i, rtol):.3g}, Newton converged "
            f"{int(f['newton_converged'].values[i])}")


# --- everything --------------------------------------------------------------------------------
def dataset_problems(folder: Path, study: dict, notes: dict[str, str],
                     failed: dict[str, str]) -> list[str]:
    """Every property above, of the datasets in ``folder`` written by a run of ``study``
    (plain data) whose log gave ``notes`` (each written step's line) and whose ``failed``
    steps gave their reasons: what does not hold, one line each."""
    datasets = {}
    for path in sorted(folder.glob("*.nc")):
        with xr.open_dataset(path) as ds:
            datasets[path.stem] = ds.load()
    problems = []
    for name, ds in datasets.items():
        ctx = {"study": study, "note": notes.get(name, "")}
        problems += [f"{name}: {p}" for p in nan_problems(ds, ctx)]
    problems += replay_problems(datasets, study)
    problems += floquet_problems(datasets, study, notes, failed)
    return problems
