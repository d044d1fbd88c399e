"""The runner's side of the analysis steps: what each kind depends on, which tasks it queues,
and how its results become a dataset (docs/datasets.md "Analysis steps").

Tasks (:mod:`monkeystudy.study.analysis_tasks`): a shoot step runs one task per start (like a
refine step); a floquet step one per controller; a basin step one task, or blocks of rows
saved as shards (resumable, like grid blocks) when it has more than
:data:`~monkeystudy.study.schema.BASIN_TASK_POINTS` points; tick_sweep, continuation and
work_precision one task each; a stress step one task per energy-drift run and per long run,
and one for the extreme cases. The work_precision task runs alone on the pool (it measures wall
time; other tasks on the same cores would inflate it).

A step that uses a shoot step (``from:``) reads its dataset when it starts and takes the
lowest-error usable solution (status ok, finite error and times; for a continuation a
converged grazing one), or ``solution: i``; when there is none the run fails with a message
naming both steps.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import analysis_tasks as AT
from . import datasets as D
from .schema import (
    BasinStep, ContinuationStep, FloquetStep, ShootStep, StressStep, TickSweepStep,
    WorkPrecisionStep,
)


def step_deps(step) -> tuple[str, ...]:
    """Names of the steps an analysis step needs first."""
    deps: list[str] = []
    if getattr(step, "from_", None) is not None:
        deps.append(step.from_)
    if isinstance(step, TickSweepStep) and step.floquet is not None:
        deps.append(step.floquet)
    return tuple(deps)


def n_tasks(step, gait_kind: str = "horizontal") -> int:
    if isinstance(step, ShootStep):
        return len(step.starts) if step.starts is not None else 1
    if isinstance(step, FloquetStep):
        return len(step.controllers_for(gait_kind))
    if isinstance(step, StressStep):
        return len(stress_tasks(step))
    return 1


def stress_tasks(step: StressStep) -> list[tuple]:
    """The tasks of a stress step, in tag order: ``("drift", phase, rtol)`` per phase and
    tolerance, ``("long", run name, controller kind, ticked)`` per long run, then one
    ``("extreme",)`` task for all the extreme cases."""
    from ..stress import LONG_RUNS

    d = step.energy_drift
    return ([("drift", ph, r) for ph in d.phases for r in d.rtols]
            + [("long",) + run for run in LONG_RUNS] + [("extreme",)])


def basin_blocks(step: BasinStep) -> list:
    """Blocks of whole rows of a basin (flat C-order point indices ``lo..hi``)."""
    from .runner import Block

    n1, n2 = step.offsets.d_dtheta1.num, step.offsets.d_dtheta2.num
    rows = step.rows_per_block
    return [Block(i, r0 * n2, min(r0 + rows, n1) * n2)
            for i, r0 in enumerate(range(0, n1, rows))]


# --- reading dependencies ----------------------------------------------------------------------
def _usable(g: dict, grazing: bool) -> bool:
    keys = ("dtheta1", "dtheta2", "t_switch", "t_motor", "error")
    ok = g["status"] == 0 and all(math.isfinite(g[k]) for k in keys)
    if grazing:
        ok = ok and g["method"] == AT.METHOD_GRAZING and g["converged"] == 1
    return ok


def shoot_gait(run, s, source: str, solution: int | None, grazing: bool = False) -> dict:
    """The gait a step uses from shoot step ``source`` (its dataset must exist)."""
    from .runner import RunFailed

    sols = D.read_shoot(run.by_name[source].path)
    what = "converged grazing gait" if grazing else "usable gait"
    if solution is not None:
        if solution >= len(sols):
            raise RunFailed(f"{s.name}: solution {solution} requested, shoot step {source!r} "
                            f"found {len(sols)}")
        g = sols[solution]
        if not _usable(g, grazing):
            raise RunFailed(f"{s.name}: solution {solution} of shoot step {source!r} is not a "
                            f"{what} (status {g['status']}, error {g['error']:.3g}, method "
                            f"{AT.METHOD_NAMES[g['method']]}, converged {g['converged']})")
        return g
    good = [g for g in sols if _usable(g, grazing)]
    if not good:
        found = "; ".join(f"{AT.METHOD_NAMES[g['method']]} error {g['error']:.3g} status "
                          f"{g['status']}" for g in sols) or "nothing"
        raise RunFailed(f"{s.name}: shoot step {source!r} produced no {what} (found: {found})")
    return min(good, key=lambda g: (g["error"], g["index"]))


def _gait_attrs(source: str, g: dict | None) -> dict:
    if g is None:
        return {"shoot_step": source or "", "solution": -1}
    return {"shoot_step": source, "solution": int(g["index"]), "dtheta1": g["dtheta1"],
            "dtheta2": g["dtheta2"], "t_switch": g["t_switch"], "t_motor": g["t_motor"],
            "gait_error": g["error"], "gait_method": AT.METHOD_NAMES[g["method"]]}


def sequence_start(run, s) -> dict:
    """Where a sequence gait's multi-cycle step starts: ``{z: (theta2, dtheta1, dtheta2),
    source, source_kind, ...}`` from its ``from:`` floquet step (the fixed point) or refine
    step (the refined rates at the section's theta2)."""
    from .runner import RunFailed
    from .schema import RefineStep

    st = s.step
    src = run.by_name[st.from_]
    section_theta1 = run.plan.loaded.study.gait.section.theta1
    if isinstance(src.step, RefineStep):
        g, idx = D.read_refined(src.path, getattr(st, "start_index", None))
        if g["status"] != 0 or not math.isfinite(g["error"]):
            raise RunFailed(f"{s.name}: refine step {st.from_!r} found no cycle to run "
                            f"(status {g['status']})")
        theta2 = run.plan.loaded.study.gait.section.theta2
        return {"z": np.array([theta2, g["dtheta1"], g["dtheta2"]]), "source": st.from_,
                "source_kind": "refine", "index": idx, "gait_error": g["error"],
                "section_theta1": section_theta1}
    fp = D.read_floquet_point(src.path, "sequence")
    if fp["newton_converged"] == 0 or not np.all(np.isfinite(fp["fixed_point"])):
        raise RunFailed(f"{s.name}: floquet step {st.from_!r} did not converge to a fixed "
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


# --- starting ----------------------------------------------------------------------------------
def _queue(run, s, tag, fn, args, kwargs, exclusive: bool = False) -> None:
    from .runner import _Task

    run.queue.append(_Task(s, tag, fn, args, kwargs, exclusive))


def start(run, s) -> None:
    """Queue the tasks of an analysis step (its dependencies are done)."""
    from .runner import RunFailed

    st = s.step
    spec = run.spec
    ctx: dict[str, Any] = {"tasks": {}}
    run.results[s.name] = ctx
    if isinstance(st, ShootStep):
        if st.from_ is not None:
            g, idx = D.read_refined(run.by_name[st.from_].path)
            if not (math.isfinite(g["dtheta1"]) and math.isfinite(g["dtheta2"])):
                raise RunFailed(f"{s.name}: refine step {st.from_!r} produced no usable start")
            starts = [(g["dtheta1"], g["dtheta2"])]
        else:
            starts = [(float(p[0]), float(p[1])) for p in st.starts]
        ctx["starts"] = starts
        kw = {"method": st.method, "tol": st.tol, "max_iter": st.max_iter}
        run.rep.start(s.name, len(starts), 0, "starts")
        run.remaining[s.name] = len(starts)
        for i, x0 in enumerate(starts):
            _queue(run, s, i, AT.shoot_task, (spec, x0), kw)
    elif isinstance(st, FloquetStep):
        controllers = st.controllers_for(run.plan.loaded.study.gait.kind)
        if controllers == ["sequence"]:
            g, idx = D.read_refined(run.by_name[st.from_].path)
            if g["status"] != 0 or not math.isfinite(g["error"]):
                raise RunFailed(f"{s.name}: refine step {st.from_!r} found no cycle to "
                                f"analyse (status {g['status']})")
            g["index"] = idx
        else:
            g = shoot_gait(run, s, st.from_, st.solution) if "open_loop" in controllers \
                else None
        ctx["gait"] = g
        run.rep.start(s.name, len(controllers), 0, "controllers")
        run.remaining[s.name] = len(controllers)
        for i, c in enumerate(controllers):
            _queue(run, s, i, AT.floquet_task, (spec, c),
                   {"gait": g, "search_start": list(st.search_start), "fd_step": st.fd_step})
    elif isinstance(st, (TickSweepStep, BasinStep)) and \
            run.plan.loaded.study.gait.kind == "sequence":
        _start_sequence_replay(run, s, ctx)
    elif isinstance(st, TickSweepStep):
        g = shoot_gait(run, s, st.from_, st.solution)
        ctx["gait"] = g
        if st.floquet is not None:
            lam = D.read_floquet_multipliers(run.by_name[st.floquet].path, "open_loop")
            ctx["leading"] = float(np.abs(lam[0]))
        max_drop = st.max_drop if st.max_drop is not None else run.robot.link1.length
        ctx["max_drop"] = max_drop
        run.rep.start(s.name, 1, 0, "runs")
        run.remaining[s.name] = 1
        _queue(run, s, 0, AT.tick_sweep_task, (spec, g),
               {"ticks": list(st.ticks), "cycles": st.cycles, "error_bound": st.error_bound,
                "max_drop": max_drop, "leading_multiplier": st.floquet is None})
    elif isinstance(st, BasinStep):
        g = shoot_gait(run, s, st.from_, st.solution)
        ctx["gait"] = g
        _queue_basin(run, s, ctx, AT.basin_block, g, {})
    elif isinstance(st, ContinuationStep):
        bounds = tuple(st.bounds) if st.bounds is not None else (-math.inf, math.inf)
        run.rep.start(s.name, 1, 0, "branches")
        run.remaining[s.name] = 1
        if run.plan.loaded.study.gait.kind == "sequence":
            fp = D.read_floquet_point(run.by_name[st.from_].path, "sequence")
            if fp["newton_converged"] == 0 or not np.all(np.isfinite(fp["fixed_point"])):
                raise RunFailed(f"{s.name}: floquet step {st.from_!r} did not converge to a "
                                f"fixed point (map defect {fp['map_defect']:.3g}): nothing "
                                f"to continue")
            ctx["gait"] = fp
            _queue(run, s, 0, AT.sequence_continuation_task, (spec, fp["fixed_point"]),
                   {"parameter": st.parameter, "ds": st.ds, "steps": st.steps,
                    "ds_max": st.ds_max, "bounds": bounds})
            return
        g = shoot_gait(run, s, st.from_, None, grazing=True)
        ctx["gait"] = g
        _queue(run, s, 0, AT.continuation_task, (spec, g),
               {"parameter": st.parameter, "ds": st.ds, "steps": st.steps, "bounds": bounds})
    elif isinstance(st, StressStep):
        tasks = stress_tasks(st)
        d, lr, ex = st.energy_drift, st.long_runs, st.extreme
        max_drop = lr.max_drop if lr.max_drop is not None else run.robot.link1.length
        ctx["tasks_spec"] = tasks
        ctx["max_drop"] = max_drop
        run.rep.start(s.name, len(tasks), 0, "runs")
        run.remaining[s.name] = len(tasks)
        for i, t in enumerate(tasks):
            if t[0] == "drift":
                _queue(run, s, i, AT.stress_drift_task, (spec, t[1], t[2]),
                       {"periods": d.periods, "checkpoints": d.checkpoints,
                        "atol_ratio": d.atol_ratio})
            elif t[0] == "long":
                _queue(run, s, i, AT.stress_long_run_task, (spec, t[2]),
                       {"start": list(lr.start), "cycles": lr.cycles,
                        "tick": lr.tick if t[3] else 0.0, "max_drop": max_drop,
                        "max_steps": lr.max_steps})
            else:
                _queue(run, s, i, AT.stress_extreme_task, (spec, list(ex.cases)),
                       {"points": [list(p) for p in ex.points], "max_steps": ex.max_steps})
    elif isinstance(st, WorkPrecisionStep):
        run.rep.start(s.name, 1, 0, "measurements")
        run.remaining[s.name] = 1
        _queue(run, s, 0, AT.work_precision_task, (spec, st.point_array()),
               {"methods": tuple(st.methods), "rtols": tuple(st.rtols),
                "atol_ratio": st.atol_ratio, "repeat": st.repeat,
                "scipy_methods": tuple(st.scipy_methods),
                "scipy_rtols": tuple(st.scipy_rtols), "scipy_points": st.scipy_points,
                "first_swing_only": st.first_swing_only}, exclusive=True)
    else:  # pragma: no cover - the schema admits no other kind
        raise TypeError(f"not an analysis step: {st.kind}")


def _start_sequence_replay(run, s, ctx: dict) -> None:
    """Queue a sequence gait's tick_sweep (one task) or basin (blocks of rows)."""
    st = s.step
    g = sequence_start(run, s)
    ctx["gait"] = g
    replay = st.replay or "gait"
    ctx["replay"] = replay
    if isinstance(st, TickSweepStep):
        max_drop = st.max_drop if st.max_drop is not None else run.robot.link1.length
        ctx["max_drop"] = max_drop
        run.rep.start(s.name, 1, 0, "runs")
        run.remaining[s.name] = 1
        _queue(run, s, 0, AT.sequence_tick_sweep_task, (run.spec, g["z"]),
               {"ticks": list(st.ticks), "cycles": st.cycles, "error_bound": st.error_bound,
                "max_drop": max_drop, "replay": replay,
                "leading_multiplier": replay == "open_loop"})
        if replay == "gait":
            lam = D.read_floquet_multipliers(run.by_name[st.from_].path, "sequence")
            ctx["leading"] = float(np.abs(lam[0]))
        return
    _queue_basin(run, s, ctx, AT.sequence_basin_block, g["z"], {"replay": replay})


def _queue_basin(run, s, ctx: dict, fn, gait, extra: dict) -> None:
    """Queue a basin step's missing blocks of rows: ``fn(spec, gait, offsets1, offsets2,
    max_cycles=, error_bound=, tick=, **extra)``; saved blocks (shards) are reused."""
    from .runner import clean_parts, saved_blocks, shard_dir

    st = s.step
    tick = st.tick if st.tick is not None else run.plan.loaded.study.gait.tick
    ctx["tick"] = tick
    clean_parts(run.plan.out, s.name, s.key)
    s.saved = saved_blocks(shard_dir(run.plan.out, s.name, s.key), s.blocks)
    todo = s.todo_blocks()
    run.reused += len(s.saved)
    run.rep.start(s.name, len(s.blocks), len(s.saved), "blocks")
    run.remaining[s.name] = len(todo)
    o1, o2 = st.offsets.d_dtheta1.values(), st.offsets.d_dtheta2.values()
    n2 = o2.size
    kw = {"max_cycles": st.max_cycles, "error_bound": st.error_bound, "tick": tick, **extra}
    for b in todo:
        _queue(run, s, b, fn, (run.spec, gait, o1[b.lo // n2:b.hi // n2], o2), kw)
    if not todo:
        run._finish(s)


def handle(run, t, value) -> None:
    """Keep a finished (non-block) task's result until the step is complete."""
    run.results[t.step.name]["tasks"][t.tag] = value


# --- finishing ---------------------------------------------------------------------------------
def _read_basin_shards(run, s) -> np.ndarray:
    from .runner import RunFailed, shard_dir, shard_path

    folder = shard_dir(run.plan.out, s.name, s.key)
    out = np.empty(s.step.n_points, np.int32)
    for b in s.blocks:
        with np.load(shard_path(folder, b)) as z:
            if int(z["lo"]) != b.lo or int(z["hi"]) != b.hi or z["cycles"].size != b.hi - b.lo:
                raise RunFailed(f"shard {shard_path(folder, b)} does not hold block "
                                f"{b.lo}..{b.hi}")
            out[b.lo:b.hi] = z["cycles"]
    return out


def finish(run, s, attrs: dict) -> str:
    """Write the step's dataset; return the one-line summary shown when it is done."""
    from .runner import RunFailed, clean_parts

    st = s.step
    ctx = run.results.pop(s.name)
    tasks = ctx["tasks"]
    results = [tasks[i] for i in sorted(tasks)] if not isinstance(st, BasinStep) else []
    if isinstance(st, ShootStep):
        sols, failures = AT.dedup_solutions(results, st.dedup_tol)
        if not sols:
            raise RunFailed(f"{s.name}: no start produced a solution: " + "; ".join(failures))
        errs = [x["error"] if math.isfinite(x["error"]) else math.inf for x in sols]
        best = int(np.argmin(errs))
        attrs.update(method=st.method, dedup_tol=st.dedup_tol, tol=st.tol,
                     max_iter=st.max_iter, starts=[list(x) for x in ctx["starts"]],
                     refine_step=st.from_ or "", failures=failures, best_solution=best)
        D.write_shoot(s.path, attrs, sols)
        b = sols[best]
        return (f"{len(sols)} solution(s); best: error {b['error']:.3g} at "
                f"({b['dtheta1']:.10g}, {b['dtheta2']:.10g}) rad s-1, "
                f"{AT.METHOD_NAMES[b['method']]}, t_switch {b['t_switch']:.6g} s")
    if isinstance(st, FloquetStep):
        controllers = st.controllers_for(run.plan.loaded.study.gait.kind)
        if controllers == ["sequence"]:
            g = ctx["gait"]
            attrs.update(refine_step=st.from_, refine_start=int(g["index"]),
                         dtheta1=g["dtheta1"], dtheta2=g["dtheta2"], gait_error=g["error"])
        else:
            attrs.update(_gait_attrs(st.from_, ctx["gait"]))
            attrs["search_start"] = list(st.search_start)
        attrs.update(fd_step=st.fd_step, neutral_tol=AT.NEUTRAL_TOL,
                     controllers=controllers)
        D.write_floquet(s.path, attrs, results)
        parts = []
        for r in results:
            lam = np.abs(r["multipliers"])
            parts.append(f"{r['controller']}: |lambda| {', '.join(f'{x:.4g}' for x in lam)} "
                         f"({'stable' if r['stable'] else 'unstable'}, agreement "
                         f"{r['agreement']:.2g})")
        return "; ".join(parts)
    if isinstance(st, TickSweepStep):
        r = results[0]
        g = ctx["gait"]
        sequence = "replay" in ctx
        if sequence and "leading" in ctx:
            lead, source = ctx["leading"], (f"floquet step {st.from_} (variational equations "
                                            "of the gait's own controller)")
        elif "leading" in ctx:
            lead, source = ctx["leading"], f"floquet step {st.floquet} (variational equations)"
        else:
            lead, source = r["leading_multiplier"], "finite differences of the exact-timing " \
                                                    "open-loop map"
        if sequence:
            attrs.update(sequence_attrs(g, ctx["replay"]), t_segment=list(r["t_segment"]))
            if ctx["replay"] == "open_loop":
                lam = np.asarray(r["multipliers"], complex)
                attrs.update(open_loop_multipliers_real=lam.real.tolist(),
                             open_loop_multipliers_imag=lam.imag.tolist())
        else:
            attrs.update(_gait_attrs(st.from_, g), replay="open_loop")
        attrs.update(leading_multiplier=lead, leading_multiplier_source=source,
                     error_bound=st.error_bound, cycles=st.cycles, motor_torque=r["torque"],
                     max_drop=ctx["max_drop"])
        D.write_tick_sweep(s.path, attrs, st.ticks, r)
        rows = ", ".join(f"{t:g} s: {int(c)}" for t, c in zip(st.ticks, r["cycles_to_bound"]))
        return f"cycles to bound {rows}; leading multiplier {lead:.4g}"
    if isinstance(st, BasinStep):
        cycles = _read_basin_shards(run, s).reshape(st.offsets.d_dtheta1.num,
                                                    st.offsets.d_dtheta2.num)
        g = ctx["gait"]
        if "replay" in ctx:
            from .drivers import spec_sequence
            attrs.update(sequence_attrs(g, ctx["replay"]),
                         motor_torque=AT.sequence_torque(spec_sequence(run.spec)))
        else:
            attrs.update(_gait_attrs(st.from_, g), replay="open_loop",
                         motor_torque=AT.replay_torque(run.spec, g))
        attrs.update(max_cycles=st.max_cycles, error_bound=st.error_bound, tick=ctx["tick"],
                     n_blocks=len(s.blocks))
        D.write_basin(s.path, attrs, st.offsets.d_dtheta1.values(),
                      st.offsets.d_dtheta2.values(), cycles)
        clean_parts(run.plan.out, s.name, None)
        i0 = int(np.argmin(np.abs(st.offsets.d_dtheta1.values())))
        j0 = int(np.argmin(np.abs(st.offsets.d_dtheta2.values())))
        return (f"{cycles.size} starts: cycles at the least offset {int(cycles[i0, j0])}, "
                f"median {float(np.median(cycles)):g}, max {int(cycles.max())} of "
                f"{st.max_cycles}")
    if isinstance(st, ContinuationStep):
        r = results[0]
        sequence = "t_segment" in r
        if sequence:
            fp = ctx["gait"]
            attrs.update(floquet_step=st.from_, fixed_point=list(fp["fixed_point"]),
                         map_defect=fp["map_defect"],
                         ds_max=st.ds_max if st.ds_max is not None else abs(st.ds))
        else:
            attrs.update(_gait_attrs(st.from_, ctx["gait"]))
        attrs.update(ds=st.ds, steps=st.steps,
                     bounds=list(st.bounds) if st.bounds is not None else [])
        D.write_continuation(s.path, attrs, r)
        v = r["value"]
        msg = (f"{len(v)} points, {st.parameter} {v[0]:.6g} -> {v[-1]:.6g} "
               f"{D.PARAMETER_UNITS[st.parameter]}, folds {r['folds']}, period doublings "
               f"{r['period_doublings']}, max residual {float(np.max(r['residual'])):.2g}")
        if sequence:
            msg += (f", through +1 {r['through_plus_one']}, Neimark-Sacker "
                    f"{r['neimark_sacker']}, stopped: {r['stop_reason']}")
        return msg
    if isinstance(st, StressStep):
        return _finish_stress(s, st, ctx, results, attrs)
    if isinstance(st, WorkPrecisionStep):
        r = results[0]
        attrs.update(repeat=st.repeat, atol_ratio=st.atol_ratio,
                     first_swing_only=int(st.first_swing_only),
                     n_points_requested=st.n_points, scipy_points=st.scipy_points)
        D.write_work_precision(s.path, attrs, r)
        return (f"{len(r['methods'])} methods x {len(r['rtols'])} rtols on {r['n_points']} "
                f"points (timings are machine-dependent)")
    raise TypeError(f"not an analysis step: {st.kind}")  # pragma: no cover


def _finish_stress(s, st: StressStep, ctx: dict, results: list, attrs: dict) -> str:
    from ..kernel.layout import STATUS_NAMES
    from .. import stress as S

    spec = ctx["tasks_spec"]
    drift = [r for t, r in zip(spec, results) if t[0] == "drift"]
    runs = [dict(r, run=t[1], controller=t[2], tick=st.long_runs.tick if t[3] else 0.0)
            for t, r in zip(spec, results) if t[0] == "long"]
    cases = results[-1]
    d, lr = st.energy_drift, st.long_runs
    attrs.update(
        swing_start=S.SWING_START, flight_start=S.FLIGHT_START, drift_floor=S.DRIFT_FLOOR,
        period_window=S.PERIOD_WINDOW, period_rtol=S.PERIOD_RTOL, periods=d.periods,
        atol_ratio=d.atol_ratio, cycles=lr.cycles, long_run_start=list(lr.start),
        long_run_tick=lr.tick, max_drop=ctx["max_drop"], long_run_max_steps=lr.max_steps,
        extreme_points=[list(p) for p in st.extreme.points],
        extreme_max_steps=st.extreme.max_steps,
        huge_velocities=[list(p) for p in S.HUGE_VELOCITIES],
        coulomb_start=list(S.COULOMB_START), coulomb_t_end=S.COULOMB_T_END,
        bit_reproducible=1)
    D.write_stress(s.path, attrs, list(d.phases), list(d.rtols), drift, runs, cases)
    exps = ", ".join(f"{r['phase']} {r['rtol']:.0e}: {r['growth_exponent']:.3g}"
                     for r in drift)
    outs = ", ".join(f"{r['run']} {STATUS_NAMES[r['status']]} {r['cycles_completed']}"
                     for r in runs)
    bad = [c["case"] for c in cases if not c["finite_ok"]]
    return (f"growth exponents {exps}; long runs {outs}; extreme cases "
            + ("all finite where ok" if not bad else "NON-FINITE: " + ", ".join(bad)))


__all__ = ["basin_blocks", "finish", "handle", "n_tasks", "shoot_gait", "start", "step_deps",
           "stress_tasks"]
