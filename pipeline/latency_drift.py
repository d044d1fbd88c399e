"""Why the state-based two-step gait fails under actuation latency (docs/findings.md,
section 5): run it from its fixed point with a constant delay on every magnet and motor action
and print, per cycle, the pivot height, the kinetic energy at the section and the section
state - with the controller's latched energy reference and with an absolute one.

    python pipeline/latency_drift.py [--delay SECONDS] [--cycles N]

Needs outputs/survival/floquet.nc (monkeystudy run studies/survival.yaml).
"""
from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np
import xarray as xr

from monkeystudy.analysis.replay import sequence_cycles
from monkeystudy.analysis.sections import cycle_section_state
from monkeystudy.kernel.dynamics import total_energy8
from monkeystudy.study import load_study
from monkeystudy.study.spec import gait_spec

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--delay", type=float, default=1e-5, help="delay of every action [s]")
    ap.add_argument("--cycles", type=int, default=200, help="cycles to run")
    ap.add_argument("--outputs", type=Path, default=ROOT / "outputs" / "survival",
                    help="the survival study's output folder")
    args = ap.parse_args()
    spec = gait_spec(load_study(ROOT / "studies" / "survival.yaml").study)
    with xr.open_dataset(args.outputs / "floquet.nc") as ds:
        z = ds["fixed_point"].values[0]
    gait = spec.sequence
    energy = total_energy8(spec.robot.params()[0], cycle_section_state(gait, z)[:8])
    absolute = dataclasses.replace(gait, segments=tuple(
        dataclasses.replace(s, until="energy", value=float(energy), latch_energy=False)
        if s.until == "energy_restored" else dataclasses.replace(s, latch_energy=False)
        for s in gait.segments))
    for name, g in (("latched energy reference", gait),
                    (f"absolute energy target {energy:.4f} J", absolute)):
        # every row whose exit switches a magnet or the motor acts `delay` late
        rows = tuple(dataclasses.replace(s, delay=args.delay) if s.until != "coord" else s
                     for s in g.segments)
        r = sequence_cycles(dataclasses.replace(g, segments=rows), z, cycles=args.cycles,
                            robot=spec.robot, integrator=spec.integrator, replay="gait",
                            tick=0.0)
        print(f"{name}, delay {args.delay:g} s: {len(r.error)} cycles, status "
              f"{r.status.name.lower()}")
        print("  cycle   error      advance [m]  pivot height [m]  KE [J]   theta2, dtheta1, "
              "dtheta2")
        n = len(r.error)
        for c in sorted({0, 10, 50, 100, 150, *range(150, n, 10), n - 1}):
            if c < n:
                s = r.section_state[c]
                print(f"  {c:5d}  {r.error[c]:9.3g}  {r.x_advance[c]:10.3f}  "
                      f"{r.pivot_height[c]:14.4f}  {r.kinetic_energy[c]:7.4f}   "
                      f"{np.round(s[[3, 6, 7]], 4)}")


if __name__ == "__main__":
    main()
