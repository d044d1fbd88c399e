"""Summary tables of AcroMonk's hardware logs (docs/acromonk.md): per log its rows, duration
and sampling; per swing its rows, holding hook and end states; the desired-trajectory rule
against the flag; the values at every hand-over; the sensor floor.

Usage::

    python tools/acromonk_logs.py data/acromonk/logs
    python tools/acromonk_logs.py data/acromonk/logs/BF_pd_5x.csv.gz

Exit status 0, 1 for a log that cannot be read (the message names its file and line).
"""
from __future__ import annotations

import argparse
import sys

from monkeystudy import measured


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("logs", nargs="+", help="a folder of logs, or log files (.csv, .csv.gz)")
    return measured.main(parser.parse_args().logs)


if __name__ == "__main__":
    sys.exit(main())
