"""AcroMonk's measured swings replayed against the model (docs/acromonk.md, "Replayed
against the model"): the friction identified on the training logs, and per held-out log and
joint the replay's angle error at 0.1, 0.2 and 0.5 s after starts every 0.1 s through each
swing, and over whole swings, for the identified model, the published MuJoCo damping and no
friction, with the sensor floor beside them.

Usage::

    python tools/acromonk_replay.py [--extra torque_scale] [--extra shoulder_offset]
    python tools/acromonk_replay.py --holds     # the two torque holds compared, no fit

Takes a few minutes (the fit replays 170 windows per evaluation).
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from monkeystudy.analysis.measured_replay import (
    FRICTION, HORIZONS, PUBLISHED_JOINT, PUBLISHED_PIVOT, ModelValues, acromonk_robot,
    errors_of, identify, model_swings, whole_swing_error,
)
from monkeystudy.measured import SHIPPED_LOGS, read_log, sensor_floor

TRAIN = ("BF_tvlqr_5x", "BF_pd_5x")
HELD_OUT = ("BF_rl_5x", "BF_tvlqr_1x", "FB_pd_1x_", "ZB_pd_1x", "ZB_tvlqr_1x", "ZF_pd_1x",
            "ZF_tvlqr_1x")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--extra", action="append", default=[],
                        help="fit this parameter too (torque_scale, shoulder_offset)")
    parser.add_argument("--holds", action="store_true",
                        help="only compare the centred and the plain torque hold (BF_pd_5x, "
                             "published damping)")
    args = parser.parse_args()
    if args.holds:
        return compare_holds()
    base = acromonk_robot()
    logs = {n: read_log(SHIPPED_LOGS / f"{n}.csv.gz") for n in TRAIN + HELD_OUT}
    train = [ms for n in TRAIN for ms in model_swings(logs[n])]
    t0 = time.time()
    fit = identify(base, train, names=FRICTION + tuple(args.extra))
    print(f"identified on {', '.join(TRAIN)}: {fit.swings} swings, {fit.windows} windows of "
          f"0.3 s every 0.1 s, {fit.residuals} residuals, rms {fit.rms:.4f} rad, "
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


if __name__ == "__main__":
    sys.exit(main())
