"""AcroMonk's measured swings replayed against the model (docs/acromonk.md, "Replayed
against the model"): the friction identified on the training logs, and per held-out log and
joint the replay's angle error at 0.1, 0.2 and 0.5 s after starts every 0.1 s through each
swing, and over whole swings, for the identified model, the published MuJoCo damping and no
friction, with the sensor floor beside them.

Usage::

    python tools/acromonk_replay.py [--extra torque_scale] [--extra shoulder_offset]
                                    [--extra rotor_inertia] [--window 0.3]
    python tools/acromonk_replay.py --holds     # the two torque holds compared, no fit
    python tools/acromonk_replay.py --checks    # the frame and signal checks, no fit

Takes a few minutes (the fit replays 170 windows per evaluation).
"""
from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace

import numpy as np

from monkeystudy.analysis.measured_replay import (
    CATCH_REST, FRICTION, HORIZONS, PUBLISHED_JOINT, PUBLISHED_PIVOT, ModelValues,
    acromonk_robot, chain_closure, energy_balance, errors_of, identify, inverse_dynamics,
    model_swings, rate_square_integrals, viscous_from_energy,
    rate_agreement, rate_noise, rest_shoulder, simulated_swing, torque_sign_errors,
    whole_swing_error,
)
from monkeystudy.measured import SHIPPED_LOGS, read_log, sensor_floor, swings

TRAIN = ("BF_tvlqr_5x", "BF_pd_5x")
HELD_OUT = ("BF_rl_5x", "BF_tvlqr_1x", "FB_pd_1x_", "ZB_pd_1x", "ZB_tvlqr_1x", "ZF_pd_1x",
            "ZF_tvlqr_1x")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--extra", action="append", default=[],
                        help="fit this parameter too (torque_scale, shoulder_offset, rotor_inertia)")
    parser.add_argument("--holds", action="store_true",
                        help="only compare the centred and the plain torque hold (BF_pd_5x, "
                             "published damping)")
    parser.add_argument("--window", type=float, default=0.3,
                        help="length of a shooting window [s] (default 0.3)")
    parser.add_argument("--checks", action="store_true",
                        help="only the checks of the frame and the signals (no fit)")
    args = parser.parse_args()
    if args.holds:
        return compare_holds()
    if args.checks:
        return checks()
    base = acromonk_robot()
    logs = {n: read_log(SHIPPED_LOGS / f"{n}.csv.gz") for n in TRAIN + HELD_OUT}
    train = [ms for n in TRAIN for ms in model_swings(logs[n])]
    t0 = time.time()
    fit = identify(base, train, names=FRICTION + tuple(args.extra), window=args.window)
    print(f"identified on {', '.join(TRAIN)}: {fit.swings} swings, {fit.windows} windows of "
          f"{args.window:g} s every 0.1 s, {fit.residuals} residuals, rms {fit.rms:.4f} rad, "
          f"{fit.nfev} evaluations, {time.time() - t0:.0f} s")
    print(fit.table())
    floors = [sensor_floor(logs[n]) for n in TRAIN]
    sh_std = max(f.shoulder_std for f in floors)
    el_std = max(f.elbow_std for f in floors)
    drift = max(abs(f.offset_drift) for f in floors)
    models = {"identified": fit.model,
              "published": ModelValues(PUBLISHED_PIVOT, PUBLISHED_JOINT),
              "frictionless": ModelValues()}
    print()
    print("held-out replay error [rad]: RMS (median |error|) over starts every 0.1 s; floor: "
          "the sensor's std (+ the shoulder's drift times the horizon)")
    print(f"{'log':<12} {'joint':<8} {'h [s]':>5} {'starts':>6}  "
          + "  ".join(f"{m:>19}" for m in models) + f"  {'floor':>8}")
    wins = {m: 0 for m in models}
    total = 0
    log_ratio = {"shoulder": [], "elbow": []}    # log(identified / published) per row
    for name in HELD_OUT:
        sws = model_swings(logs[name])
        errs = {m: errors_of(v, base, sws) for m, v in models.items()}
        for j, joint in enumerate(("shoulder", "elbow")):
            for h in HORIZONS:
                rms = {m: e.rms(h)[j] for m, e in errs.items()}
                med = {m: e.median_abs(h)[j] for m, e in errs.items()}
                floor = sh_std + drift * h if j == 0 else el_std
                total += 1
                wins["identified"] += rms["identified"] < rms["published"]
                log_ratio[joint].append(np.log(rms["identified"] / rms["published"]))
                print(f"{name:<12} {joint:<8} {h:5.1f} {errs['identified'].count(h):6d}  "
                      + "  ".join(f"{rms[m]:8.4f} ({med[m]:7.4f})" for m in models)
                      + f"  {floor:8.1e}")
        whole = {m: np.sqrt(np.mean([whole_swing_error(v.robot(base), ms,
                                                        torque_scale=v.torque_scale) ** 2
                                     for ms in v.swings(sws)], axis=0))
                 for m, v in models.items()}
        for j, joint in enumerate(("shoulder", "elbow")):
            print(f"{name:<12} {joint:<8} {'swing':>5} {len(sws):6d}  "
                  + "  ".join(f"{whole[m][j]:8.4f}          " for m in models))
    print(f"\nidentified below published on {wins['identified']} of {total} "
          "(log, joint, horizon) rows")
    both = log_ratio["shoulder"] + log_ratio["elbow"]
    print("identified / published RMS, geometric mean over the rows: "
          f"{np.exp(np.mean(both)):.3f} (shoulder {np.exp(np.mean(log_ratio['shoulder'])):.3f}, "
          f"elbow {np.exp(np.mean(log_ratio['elbow'])):.3f})")
    return 0


def compare_holds() -> int:
    """The elbow's RMS replay error at each horizon on BF_pd_5x with the published damping,
    the measured torque held centred and plain."""
    base = acromonk_robot()
    swings = model_swings(read_log(SHIPPED_LOGS / "BF_pd_5x.csv.gz"))
    published = ModelValues(PUBLISHED_PIVOT, PUBLISHED_JOINT)
    print("BF_pd_5x, published damping: elbow RMS replay error [rad] at "
          + "/".join(f"{h:g}" for h in HORIZONS) + " s")
    for hold in ("centred", "plain"):
        e = errors_of(published, base, swings, hold=hold)
        print(f"{hold:>8}: " + "/".join(f"{e.rms(h)[1]:.4f}" for h in HORIZONS))
    return 0


def _span(values) -> str:
    return f"{min(values):.2f}-{max(values):.2f}"


#: the smoothing differentiator's half-widths [s] the checks compare (windows of 30-100 ms)
HALF_WIDTHS = (0.015, 0.025, 0.05)


def checks() -> int:
    """The checks of the frame and the signals (docs/acromonk.md, "Replayed against the
    model"): the closed chain at the first catch, the torque's sign, the rates against the
    angles, the rest angle and the inverse dynamics of the training swings."""
    base = acromonk_robot()
    published = base.with_friction(PUBLISHED_PIVOT, PUBLISHED_JOINT)
    logs = {n: read_log(SHIPPED_LOGS / f"{n}.csv.gz") for n in TRAIN}
    print(f"closed chain: the model's free end from the holding hook [m] over the last "
          f"{CATCH_REST} s of the first catch")
    for name in ("BF_pd_5x", "BF_tvlqr_5x"):
        c = chain_closure(base, logs[name])
        print(f"  {name:<12} logged shoulder: x {c.free_end[0]:.4f} y {c.free_end[1]:+.4f}   "
              f"with the URDF offset ({c.urdf_offset:+.4f} rad): x {c.free_end_urdf[0]:.4f} "
              f"y {c.free_end_urdf[1]:+.4f}")
    pd1 = model_swings(logs["BF_pd_5x"])[0]
    right, wrong = torque_sign_errors(published, pd1)
    print(f"torque sign: {pd1.name}, published damping, elbow RMS replay error at 0.1 s over "
          f"starts every 0.1 s: logged sign {right:.4f} rad, reversed {wrong:.4f} rad "
          f"({wrong / right:.1f} times)")
    ra = rate_agreement(pd1)
    print(f"rates: {pd1.name}: integrated rate less angle, largest: shoulder "
          f"{ra.integrated[0]:.4f} rad, elbow {ra.integrated[1]:.4f} rad; difference quotient "
          f"of the angle less the rate, RMS: shoulder {ra.quotient[0]:.3f} rad/s, elbow "
          f"{ra.quotient[1]:.3f} rad/s")
    train = [ms for n in TRAIN for ms in model_swings(logs[n])]
    spans = [rate_agreement(ms) for ms in train]
    print(f"  training swings: integrated less angle, largest: shoulder "
          f"{_span([r.integrated[0] for r in spans])} rad, elbow {_span([r.integrated[1] for r in spans])} rad; quotient RMS: shoulder "
          f"{_span([r.quotient[0] for r in spans])} rad/s, elbow "
          f"{_span([r.quotient[1] for r in spans])} rad/s")
    rest = []
    for name in ("ZB_pd_1x", "ZF_pd_1x", "ZB_tvlqr_1x", "ZF_tvlqr_1x"):
        log = read_log(SHIPPED_LOGS / f"{name}.csv.gz")
        rest.append(f"{name} {log.shoulder_angle[swings(log)[0].start]:.4f}")
    print(f"rest: logged shoulder at the first swing row (elbow at 0): {', '.join(rest)} rad; "
          f"the model's theta1 at rest with theta2 = 0: {rest_shoulder(base, 0):.4f} rad")

    print("\nenergy budget of each training swing in the model [J]: the measured torque's work, "
          "the mechanical energy's change, their difference (dissipated), and the largest "
          "gain beyond the work; in the swing's own parameter row, then in the other")
    for ms in train:
        own, other = energy_balance(base, ms), energy_balance(base, ms, 1 - ms.flipped)
        print(f"  {ms.name:<14} {'motor' if ms.flipped == 0 else 'IMU':>5} arm holds: work "
              f"{own.motor_work:5.2f}, change {own.energy_change:+5.2f}, dissipated "
              f"{own.dissipated:5.2f}, largest gain {own.largest_gain:4.2f}; other row: "
              f"change {other.energy_change:+5.2f}, dissipated {other.dissipated:5.2f}, "
              f"largest gain {other.largest_gain:4.2f}")
    published_loss = [PUBLISHED_PIVOT.viscous * i[0] + PUBLISHED_JOINT.viscous * i[1]
                      for i in map(rate_square_integrals, train)]
    b = viscous_from_energy(base, train)
    print(f"  the published damping dissipates {_span(published_loss)} J along these motions; "
          f"the viscous friction whose dissipation fits the budgets best (nnls): pivot "
          f"{b[0]:.3f}, joint {b[1]:.3f} N m s")

    noise = np.array([rate_noise(ms) for ms in train])
    print(f"\ninverse dynamics of the training swings ({', '.join(TRAIN)}; {len(train)} swings),"
          f" scored on the samples >= {HALF_WIDTHS[1]} s from each swing's ends; ranges over "
          "swings")
    print(f"  rate noise (std about a +-{HALF_WIDTHS[1]} s quadratic): shoulder "
          f"{_span(noise[:, 0])} rad/s, elbow {_span(noise[:, 1])} rad/s")
    print("  M q'' + C q' + G + the published friction: pivot: RMS of the pivot row [N m]; "
          "elbow: RMS of the elbow row less the measured torque [N m]; k: elbow row = "
          "k torque; gravity: RMS of gravity's torque in the pivot row [N m]")
    print(f"  {'differentiator':<24} {'hook holding':<22} {'roles':<8} {'pivot':>9} "
          f"{'elbow':>9} {'k':>9} {'gravity':>9}")
    methods = [("difference", HALF_WIDTHS[1], "difference quotient")] + \
        [("local_quadratic", h, f"local quadratic +-{1e3 * h:.0f} ms") for h in HALF_WIDTHS]
    for diff, hw, label in methods:
        for hook, hook_name in ((0, "motor arm (row 0)"), (1, "IMU arm (row 1)")):
            for roles in ("logged", "swapped"):
                ids = [inverse_dynamics(published, ms, differentiator=diff, half_width=hw,
                                        flipped=hook if roles == "logged" else 1 - hook)
                       for ms in train if ms.flipped == hook]
                print(f"  {label:<24} {hook_name:<22} {roles:<8} "
                      f"{_span([i.pivot_rms for i in ids]):>9} "
                      f"{_span([i.elbow_rms for i in ids]):>9} "
                      f"{_span([i.torque_factor for i in ids]):>9} "
                      f"{_span([i.gravity_rms for i in ids]):>9}")
    cells = []
    for hook, hook_name in ((0, "motor arm"), (1, "IMU arm")):
        negated = [replace(ms, theta1=-ms.theta1, theta1_rate=-ms.theta1_rate)
                   for ms in train if ms.flipped == hook]
        cells.append(f"{hook_name} " + _span([
            inverse_dynamics(published, ms, differentiator="local_quadratic",
                             half_width=HALF_WIDTHS[1]).pivot_rms for ms in negated]))
    print(f"  the sign of theta1 reversed (local quadratic +-{1e3 * HALF_WIDTHS[1]:.0f} ms), "
          f"pivot RMS [N m]: " + ", ".join(cells))
    print("  the model's own swing (published damping, the measured torque and start), "
          "BF_pd_5x motor-arm swings, as above (what the differentiator and the rates' noise "
          "make of a swing the model fits exactly)")
    # the flipped row's replays of a whole swing run away (the elbow spins), so the motor
    # arm's swings, whose replays stay near the logged ones, calibrate the differentiators
    sources = [ms for ms in model_swings(logs["BF_pd_5x"]) if ms.flipped == 0]
    for noisy in (False, True):
        own = [simulated_swing(published, ms,
                               rate_noise_std=rate_noise(ms) if noisy else (0.0, 0.0))
               for ms in sources]
        for diff, hw, label in methods:
            for roles in ("logged", "swapped"):
                ids = [inverse_dynamics(published, sw, differentiator=diff, half_width=hw,
                                        flipped=0 if roles == "logged" else 1) for sw in own]
                print(f"  {label:<24} {'noisy rates' if noisy else 'noiseless':<22} "
                      f"{roles:<8} {_span([i.pivot_rms for i in ids]):>9} "
                      f"{_span([i.elbow_rms for i in ids]):>9} "
                      f"{_span([i.torque_factor for i in ids]):>9} "
                      f"{_span([i.gravity_rms for i in ids]):>9}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
