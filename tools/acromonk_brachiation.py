"""AcroMonk's brachiations measured (docs/acromonk.md, "Brachiations measured"): per log and
controller the number of brachiations and the mean ± sd of each measure, per nominal
trajectory its measures and its open loop on the identified, published and frictionless
models.

Usage::

    python tools/acromonk_brachiation.py                 # the shipped logs and trajectories
    python tools/acromonk_brachiation.py data/acromonk/logs/BF_pd_5x.csv.gz

Exit status 0, 1 for a log that cannot be read (the message names its file and line).
"""
from __future__ import annotations

import argparse
import sys

from monkeystudy.analysis.brachiation import comparison
from monkeystudy.measured import SHIPPED_LOGS, LogError, log_paths, read_log


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("logs", nargs="*", default=[str(SHIPPED_LOGS)],
                        help="a folder of logs, or log files (default: the shipped logs)")
    args = parser.parse_args()
    paths = []
    try:
        for item in args.logs:
            paths += log_paths(item)
        logs = [read_log(p) for p in paths]
    except (LogError, OSError) as exc:
        print(exc, file=sys.stderr)
        return 1
    print(comparison(logs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
