"""AcroMonk's brachiations measured (docs/acromonk.md, "Brachiations measured"): per log and
controller the number of brachiations and the mean ± sd of each measure, per nominal
trajectory its measures and its open loop on the identified, published and frictionless
models, and side by side with the torque at the elbow: the logs, the plans open loop on the
identified model and the designed gait of a study (default studies/acromonk_gait.yaml) per
brachiation and their mean.

Usage::

    python tools/acromonk_brachiation.py                 # the shipped logs and trajectories
    python tools/acromonk_brachiation.py data/acromonk/logs/BF_pd_5x.csv.gz
    python tools/acromonk_brachiation.py --gait other_gait.yaml

Exit status 0, 1 for a log that cannot be read or a gait that cannot be run (the message
names its file and line), 2 for a study file that is not valid.
"""
from __future__ import annotations

import argparse
import sys
from functools import partial
from pathlib import Path

from monkeystudy.analysis.brachiation import DesignedGait, comparison
from monkeystudy.analysis.multipliers import solve_fixed_point
from monkeystudy.analysis.sections import cycle_map_error, cycle_return_map
from monkeystudy.analysis.variational import sequence_variational_jacobian
from monkeystudy.measured import SHIPPED_LOGS, LogError, log_paths, read_log
from monkeystudy.study.loader import StudyError, load_study
from monkeystudy.study.spec import gait_spec

#: the designed gait the table measures by default
GAIT_STUDY = Path(__file__).resolve().parents[1] / "studies" / "acromonk_gait.yaml"


def designed_gait(path: str | Path = GAIT_STUDY) -> DesignedGait:
    """The sequence gait of a study at its fixed point: Newton (variational Jacobian, to the
    map's error level, as the floquet step polishes) from the section's ``theta2`` and the
    rates of the study's first refine step. ``StudyError`` for an invalid study file,
    ``ValueError`` for one without such a gait or a polish that does not converge."""
    loaded = load_study(path)
    spec = gait_spec(loaded.study)
    gait = spec.sequence
    if getattr(loaded.study.gait, "kind", None) != "sequence":
        raise ValueError(f"{path}: gait: not a sequence gait")
    starts = [s.start for s in loaded.study.steps
              if s.kind == "refine" and isinstance(s.start, (list, tuple))]
    if not starts:
        raise ValueError(f"{path}: steps: no refine step with a start [dtheta1, dtheta2]")
    z0 = (gait.theta2, float(starts[0][0]), float(starts[0][1]))
    robot, integ = spec.robot, spec.integrator
    fp = solve_fixed_point(
        partial(cycle_return_map, gait=gait, robot=robot, integrator=integ), z0,
        jacobian=lambda q: sequence_variational_jacobian(gait, q, robot=robot, integrator=integ),
        map_error=cycle_map_error(z0, gait, robot=robot, integrator=integ))
    if not fp.converged:
        raise ValueError(f"{path}: the gait's fixed point: {fp.message}")
    return DesignedGait(name=loaded.study.name, robot=robot, gait=gait,
                        section_state=tuple(float(v) for v in fp.z), integrator=integ)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("logs", nargs="*", default=[str(SHIPPED_LOGS)],
                        help="a folder of logs, or log files (default: the shipped logs)")
    parser.add_argument("--gait", default=str(GAIT_STUDY),
                        help="a study of a sequence gait that catches bars (default: "
                             "studies/acromonk_gait.yaml)")
    args = parser.parse_args()
    paths = []
    try:
        for item in args.logs:
            paths += log_paths(item)
        logs = [read_log(p) for p in paths]
    except (LogError, OSError) as exc:
        print(exc, file=sys.stderr)
        return 1
    try:
        gait = designed_gait(args.gait)
    except StudyError as exc:
        print(exc, file=sys.stderr)
        return 2
    except ValueError as exc:
        print(exc, file=sys.stderr)
        return 1
    print(comparison(logs, gait=gait))
    return 0


if __name__ == "__main__":
    sys.exit(main())
