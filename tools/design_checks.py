"""The numbers docs/findings.md section 6 states about the designed gaits, from a run of
``studies/open_loop_design.yaml``.

Usage::

    monkeystudy run studies/open_loop_design.yaml
    python tools/design_checks.py outputs/open_loop_design

Prints, for every design step's best design: its torque profile in the motor frame (the
physical torque, its sign fixed to the links: the kernel applies a pulse on theta2 of the
frame of the end attached at the time, and theta2 changes sign at the swap, so a pulse that
runs across the swap is the opposite physical torque after it); for ``as_built``: the
multipliers and period as the dataset holds them, a start 0.05 rad/s off in dtheta1 (the next
cycle's dtheta1 and the height of the new hold, by the return map with the height in it), the
free end's rise above the wall line and its velocity at the catch, the impact loss of the
gait and of the two starts, and the design with its pulse's part after the swap held as the
same physical torque or cut (re-solved); for ``as_built_clock``: the
same schedule under the restarting clock. Times are from the vertical crossing [s], torques in
N m. For a design of a sequence gait's segments with a screen (``studies/robust_design.yaml``:
``python tools/design_checks.py outputs/robust_design``, run from the project's folder): the
least-rho refined design re-solved, its full map's multipliers both ways, and how far the
chosen design's two Jacobians differ.
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import xarray as xr

from monkeystudy.analysis import cycle_full_map
from monkeystudy.analysis.sections import TIGHT, cycle_section_state
from monkeystudy.analysis.variational import sequence_variational_jacobian
from monkeystudy.analysis.design import (
    DesignSpace, design_cycle_run, evaluate_design, motor_frame_pulses, with_variational,
)
from monkeystudy.robot import P_L1, P_L2, Robot
from monkeystudy.simulation import StateIndex as S, physical_points, simulate

SCHEDULE = ("t_switch", "motor_start", "t_motor", "torque", "pulse2_start",
            "pulse2_duration", "pulse2_torque")


def best_values(attrs) -> dict[str, float]:
    """The best design's schedule and robot values (dataset attributes ``best_*``)."""
    return {k[5:]: float(v) for k, v in attrs.items()
            if k.startswith("best_") and k[5:] in SCHEDULE + ("com", "inertia", "mass_ratio",
                                                              "length_ratio")}


def profile_text(v: dict[str, float]) -> str:
    parts = [f"{tau:+.4f} N m from {a:.4f} s for {b - a:.4g} s"
             for a, b, tau in motor_frame_pulses(v)]
    return "; ".join(parts) + f" (the swap at {v['t_switch']:.4f} s)"


def space_of(ds, values) -> DesignSpace:
    a = ds.attrs
    clock = str(a.get("clock", "reset_at_vertical"))
    return DesignSpace(Robot.preset("seed2009"), base=values,
                       balance=str(a.get("balance", "t_switch")), clock=clock)


def impact_loss(gait, z) -> float:
    """Energy [J] the impacts of one cycle of ``gait`` from the section state ``z = (theta2,
    dtheta1, dtheta2)`` take (the motor's switchings change no energy: every other event
    leaves it as it was)."""
    run = simulate(gait.controller(), state=cycle_section_state(gait, z), cycles=1,
                   integrator=TIGHT, sample_dt=1.0)
    return float((run["event_energy_before"] - run["event_energy_after"]).sum())


def motor_frame_variants(v: dict[str, float], z) -> None:
    """The best design with its pulse's part after the swap changed, each re-solved as the
    design step solves a design (the swap time balanced, pulse times from the swap): the same
    physical torque held across the swap (in the kernel's frame a second pulse of the opposite
    sign), and the pulse cut at the swap."""
    ms, tm, tq = v["motor_start"], v["t_motor"], v["torque"]
    if not ms < 0 < ms + tm:
        return
    variants = {
        "the same physical torque held across the swap":
            dict(v, t_motor=-ms, pulse2_start=0.0, pulse2_duration=ms + tm, pulse2_torque=-tq),
        "the pulse cut at the swap": dict(v, t_motor=-ms),
    }
    for what, values in variants.items():
        space = DesignSpace(Robot.preset("seed2009"), base=values, balance="t_switch")
        found = [r for z0 in (z, z + np.array([0, 0.05, 0]), z - np.array([0, 0.05, 0]))
                 if (r := evaluate_design(space, {}, z0, variational=True)).ok]
        if not found:
            print(f"  {what}: no gait")
            continue
        r = min(found, key=lambda r: r.spectral_radius_fd)
        print(f"  {what}: rho {r.spectral_radius:.6f} (finite differences "
              f"{r.spectral_radius_fd:.6f}), swap at {r.values['t_switch']:.4f} s")


def as_built_checks(ds) -> None:
    a = ds.attrs
    v = best_values(a)
    lam = ds["best_multipliers_real"].values + 1j * ds["best_multipliers_imag"].values
    print(f"  multipliers {np.array2string(lam, precision=7)}; period {a['best_period']:.6f} s")
    space = DesignSpace(Robot.preset("seed2009"), base=v, balance="t_switch")
    gait = space.gait(space.values())
    w = np.array([0.0, a["best_theta2"], a["best_dtheta1"], a["best_dtheta2"]])
    jac = sequence_variational_jacobian(gait, w, height=True)
    for d in (0.05, -0.05):
        p, _ = cycle_full_map(w + [0.0, 0.0, d, 0.0], gait)
        print(f"  start dtheta1 {d:+.2f} rad/s: next dtheta1 {p[2] - w[2]:+.6f} rad/s from the "
              f"gait's (linear {jac[2, 2] * d:+.6f}), the new hold {1e3 * p[0]:+.3f} mm, "
              f"impact loss {impact_loss(gait, w[1:] + [0.0, d, 0.0]):.4f} J")
    print(f"  impact loss on the gait {impact_loss(gait, w[1:]):.4f} J")
    motor_frame_variants(v, w[1:])
    run_on = DesignSpace(Robot.preset("seed2009"), base=v, balance="t_switch", clock="run_on")
    clocked = with_variational(run_on, evaluate_design(run_on, {}, w[1:]))
    print(f"  with the clock running on: rho {clocked.spectral_radius:.6f} (finite differences "
          f"{clocked.spectral_radius_fd:.6f})")
    res = evaluate_design(space, {}, [a["best_theta2"], a["best_dtheta1"], a["best_dtheta2"]])
    run = design_cycle_run(space, res, sample_dt=1e-5)
    pts = physical_points(run.params, run.sample_state, run.sample_flipped)
    b = pts["B"]
    held = np.flatnonzero(run.sample_flipped > 0)
    i = int(held[0]) - 1                            # the last sample before the catch
    rise = float(b[: i + 1, 1].max())
    # B's velocity from the state (frame of A, still attached): d/dt of its position
    th1, th2, w1, w2 = (run.sample_state[i, k] for k in (S.THETA1, S.THETA2, S.THETA1_DOT,
                                                          S.THETA2_DOT))
    l1, l2 = run.params[0][P_L1], run.params[0][P_L2]
    v_catch = (l1 * math.cos(th1) * w1 + l2 * math.cos(th1 + th2) * (w1 + w2),
               l1 * math.sin(th1) * w1 + l2 * math.sin(th1 + th2) * (w1 + w2))
    print(f"  free end B: highest {1e3 * rise:.3f} mm above the wall line (t = "
          f"{run.sample_t[int(np.argmax(b[: i + 1, 1]))]:.4f} s); at the catch (t = "
          f"{run.sample_t[i]:.4f} s) moving at v_x {v_catch[0]:+.3f}, v_y {v_catch[1]:+.4f} m/s")


def before_the_swap(ds) -> None:
    """The least rho on the grid among the designs whose pulse ends by the swap (no reversal
    in the motor frame)."""
    r = ds["spectral_radius"]
    ends = ds["motor_start"] + ds["t_motor"]            # relative to the swap [s]
    r = r.where((ends <= 0) & np.isfinite(r))
    if not np.isfinite(r).any():
        print("  no grid design whose pulse ends by the swap has a gait")
        return
    i = np.unravel_index(int(np.nanargmin(r.values)), r.shape)
    at = {d: float(ds[d].values[k]) for d, k in zip(r.dims, i)}
    print(f"  least rho of a grid design whose pulse ends by the swap: {float(r.values[i]):.4f} "
          f"(" + ", ".join(f"{k} {v:+.4g}" for k, v in at.items()) + ")")


def restarting_clock_check(ds) -> None:
    a = ds.attrs
    v = best_values(a)
    space = DesignSpace(Robot.preset("seed2009"), base=v, balance="t_switch",
                        clock="reset_at_vertical")
    z = [a["best_theta2"], a["best_dtheta1"], a["best_dtheta2"]]
    res = with_variational(space, evaluate_design(space, {}, z))
    print(f"  under the restarting clock: rho {res.spectral_radius:.6f} (finite differences "
          f"{res.spectral_radius_fd:.6f}), multipliers "
          f"{np.array2string(res.multipliers, precision=4)}")


def least_rho_checks(ds, study: Path) -> None:
    """A sequence gait's design with a screen: the refined design of least spectral radius
    (finite differences), re-solved, with the multipliers of its full map both ways."""
    from monkeystudy.analysis.design import SegmentDesignSpace
    from monkeystudy.study import load_study
    from monkeystudy.study.spec import gait_spec

    spec = gait_spec(load_study(study).study)
    names = [str(n) for n in json.loads(ds.attrs["parameters"])]
    i = int(np.nanargmin(ds["refined_spectral_radius_fd"].values))
    free = {n: float(ds[f"refined_{n}"].values[i]) for n in names}
    space = SegmentDesignSpace(spec.sequence, spec.robot,
                               motor_frame=spec.torque_frame == "motor",
                               integrator=spec.integrator)
    # Newton from the fixed point of the grid design nearest to it (in axis steps)
    grid = ds["status"]
    dist = sum(((ds[n] - free[n]) / float(ds[n][1] - ds[n][0])) ** 2 for n in names)
    dist = dist.where(grid == 0).transpose(*grid.dims).values
    k = np.unravel_index(int(np.nanargmin(dist)), dist.shape)
    z = [float(ds[c].transpose(*grid.dims).values[k]) for c in ("theta2", "dtheta1",
                                                                 "dtheta2")]
    res = with_variational(space, evaluate_design(space, free, z))
    print("  least-rho refined design: " + ", ".join(f"{n} {v:.4f}" for n, v in free.items())
          + f"; rho {res.spectral_radius:.7f} (finite differences "
          f"{res.spectral_radius_fd:.7f}), |multipliers| "
          f"{np.array2string(np.abs(res.multipliers), precision=4)}; Jacobians differ by "
          f"{float(np.max(np.abs(res.jacobian - res.jacobian_fd))):.2g}")
    chosen = float(np.max(np.abs(ds["best_jacobian"].values - ds["best_jacobian_fd"].values)))
    print(f"  chosen design: rho {ds.attrs['best_spectral_radius']:.8f} (finite differences "
          f"{ds.attrs['best_spectral_radius_fd']:.8f}); Jacobians differ by {chosen:.2g}")


def catch_speed(gait, z, robot, integrator) -> tuple[float, float]:
    """The time [s] of a cycle's catch (the first sample hanging from B, the sample before
    it) and the free end B's vertical speed there [m s-1] (> 0: rising), from one cycle
    sampled every 10 us."""
    run = simulate(gait.controller(), robot=robot, state=cycle_section_state(gait, z),
                   cycles=1, integrator=integrator, sample_dt=1e-5)
    end = run["attached_end"].values
    i = int(np.flatnonzero(end > 0)[0]) - 1
    th1, th2 = run["theta1"].values[i], run["theta2"].values[i]
    w1, w2 = run["theta1_dot"].values[i], run["theta2_dot"].values[i]
    p = robot.params()[0]
    v_y = p[P_L1] * math.sin(th1) * w1 + p[P_L2] * math.sin(th1 + th2) * (w1 + w2)
    return float(run["time"].values[i]), float(v_y)


def robust_checks(folder: Path, study: Path) -> None:
    """The catch of design B (the floquet step's fixed point) and of the chosen design, and
    how high the attached end went in the noiseless tick run (``cycles``)."""
    from monkeystudy.analysis.design import SegmentDesignSpace
    from monkeystudy.study import load_study
    from monkeystudy.study.spec import gait_spec

    spec = gait_spec(load_study(study).study)
    with xr.open_dataset(folder / "floquet.nc") as fq:
        z = fq["fixed_point"].values[0]
    t, v = catch_speed(spec.sequence, z, spec.robot, spec.integrator)
    print(f"design B: the catch {t:.4f} s after the vertical, B rising at {v:.3f} m/s")
    with xr.open_dataset(folder / "cycles.nc") as cy:
        h = cy["pivot_height"].values
    print(f"  on the 1 ms tick ({h.size} steps): the attached end {1e3 * np.nanmin(h):.3f} to "
          f"{1e3 * np.nanmax(h):.3f} mm above its start")
    with xr.open_dataset(folder / "design.nc") as ds:
        a = dict(ds.attrs)
        names = [str(n) for n in json.loads(a["parameters"])]
    space = SegmentDesignSpace(spec.sequence, spec.robot,
                               motor_frame=spec.torque_frame == "motor")
    gait = space.gait_for({**space.values(), **{n: float(a[f"best_{n}"]) for n in names}})
    t, v = catch_speed(gait, [a["best_theta2"], a["best_dtheta1"], a["best_dtheta2"]],
                       spec.robot, spec.integrator)
    print(f"the chosen design: the catch {t:.4f} s after the vertical, B rising at {v:.3f} m/s")


def main(folder: str) -> int:
    folder = Path(folder)
    for path in sorted(folder.glob("*.nc")):
        with xr.open_dataset(path) as ds:
            if ds.attrs.get("step_kind") != "design":
                continue
            ds.load()
        if "best_t_switch" not in ds.attrs:
            if "screen_survived" in ds:
                study = Path("studies") / f"{ds.attrs['study_name']}.yaml"
                print(f"{path.stem}: a design of the segments of {ds.attrs['study_name']}")
                least_rho_checks(ds, study)
                if (folder / "floquet.nc").exists() and (folder / "cycles.nc").exists():
                    robust_checks(folder, study)
            continue
        v = best_values(ds.attrs)
        print(f"{path.stem}: rho {ds.attrs['best_spectral_radius']:.6f}; motor frame: "
              f"{profile_text(v)}")
        if path.stem == "as_built":
            as_built_checks(ds)
            before_the_swap(ds)
        if path.stem == "as_built_clock":
            restarting_clock_check(ds)
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    raise SystemExit(main(sys.argv[1]))
