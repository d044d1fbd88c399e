"""Provenance of datasets: package version, git revision, code hash, library versions, history.

``code_sha256`` hashes the source files that decide what a study computes (kernels, robot,
controllers, simulation API, study schema, drivers, dataset layout, and the analysis
computations and tasks) together with the package version. With the study text's hash it keys
shards and datasets: change either and nothing old is reused. It does not depend on git, so
an uncommitted edit counts too.
"""
from __future__ import annotations

import functools
import hashlib
import json
import subprocess
import sys
from datetime import datetime, timezone
from importlib import metadata
from pathlib import Path

from .. import __version__

_PKG = Path(__file__).resolve().parents[1]

#: Sources (relative to the package) that decide the numbers and the layout of datasets.
CODE_FILES = ("kernel/*.py", "robot.py", "controllers.py", "simulate.py", "study/schema.py",
              "study/drivers.py", "study/datasets.py",
              # the analysis steps: their computations, tasks and runner glue
              "analysis.py", "precision.py", "bench.py", "study/analysis_tasks.py",
              "study/analysis_steps.py", "saltation.py", "continuation.py", "replay.py",
              # the stress scenarios
              "stress.py")

LIBRARIES = ("numpy", "scipy", "numba", "xarray", "netCDF4")


@functools.lru_cache(maxsize=None)
def code_sha256() -> str:
    h = hashlib.sha256(f"monkeystudy {__version__}\n".encode())
    for pattern in CODE_FILES:
        for p in sorted(_PKG.glob(pattern)):
            h.update(p.relative_to(_PKG).as_posix().encode() + b"\0")
            h.update(p.read_bytes())
            h.update(b"\0")
    return h.hexdigest()


def source_sha256() -> str:
    """Hash of every Python source of the package, read now (not cached): a resident server
    compares it with its own at start to notice an edited package (any file, not only those
    that decide the numbers: it runs the old code of all of them)."""
    h = hashlib.sha256()
    for p in sorted(_PKG.rglob("*.py")):
        h.update(p.relative_to(_PKG).as_posix().encode() + b"\0" + p.read_bytes() + b"\0")
    return h.hexdigest()


@functools.lru_cache(maxsize=None)
def git_revision() -> str:
    """``HEAD`` of the repository holding the package, ``+dirty`` if sources changed;
    ``unknown`` outside a git checkout."""
    try:
        rev = subprocess.run(["git", "-C", str(_PKG), "rev-parse", "HEAD"], check=True,
                             capture_output=True, text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(_PKG), "status", "--porcelain",
                                "--untracked-files=no", "--", "."], check=True,
                               capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return rev + ("+dirty" if dirty else "")


@functools.lru_cache(maxsize=None)
def library_versions() -> str:
    """JSON ``{numpy, scipy, numba, xarray, netCDF4}`` (installed distributions)."""
    out = {}
    for name in LIBRARIES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    out["python"] = sys.version.split()[0]
    return json.dumps(out, sort_keys=True)


def history_line(command: str | None = None) -> str:
    """One line: ISO time (UTC) and the command."""
    when = datetime.now(timezone.utc).replace(microsecond=0).isoformat()
    cmd = command if command is not None else " ".join(["monkeystudy"] + sys.argv[1:])
    return f"{when}: {cmd}"


def run_command(study, out=None, workers: int | None = None, scheduler: str | None = None,
                server: str | None = None) -> str:
    """``monkeystudy run ...`` with the options given, as the datasets' ``history`` records
    it."""
    return " ".join(["monkeystudy", "run", str(study)]
                    + ([f"--out {out}"] if out is not None else [])
                    + ([f"--workers {workers}"] if workers is not None else [])
                    + ([f"--scheduler {scheduler}"] if scheduler else [])
                    + ([f"--server --socket {server}"] if server else []))


def run_key(study_sha256: str) -> str:
    """Key of one study text run by this code: names shard folders, checked in datasets."""
    return hashlib.sha256(f"{study_sha256}:{code_sha256()}".encode()).hexdigest()
