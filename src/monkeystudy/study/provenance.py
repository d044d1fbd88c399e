"""Provenance of datasets: package version, git revision, code hash, library versions, history.

``code_sha256(module)`` hashes, with the package version, the source files that decide what
one step kind computes: the kind's module (its model, tasks and dataset writer) and every
module of the package it imports, followed through the import graph (imports inside functions
too) - the analysis, the simulation API, the kernels. A package's ``__init__`` counts when a
name is imported from it, not when the import only passes through it (the step registry and
the lazy re-exports decide nothing), so editing one kind, or adding one, leaves the other
kinds' datasets current. The figures, the command line, the service and the benchmark are
never among the sources: editing them reruns nothing. With the study text's hash it keys
shards and datasets. It does not depend on git, so an uncommitted edit counts too.
"""
from __future__ import annotations

import functools
import hashlib
import json
import re
import subprocess
import sys
from datetime import datetime, timezone
from importlib import metadata
from pathlib import Path

from .. import __version__

_PKG = Path(__file__).resolve().parents[1]

#: The package (relative to ``monkeystudy``) whose modules, and all they import, decide the
#: numbers and the layout of datasets.
RESULT_ROOT = "study/steps"

LIBRARIES = ("numpy", "scipy", "numba", "xarray", "netCDF4")


@functools.lru_cache(maxsize=None)
def _package_modules() -> dict[tuple[str, ...], Path]:
    """Every source of the package by module name (``("study", "steps")`` is the package
    ``monkeystudy.study.steps``, its ``__init__.py``)."""
    out = {}
    for p in _PKG.rglob("*.py"):
        parts = p.relative_to(_PKG).with_suffix("").parts
        out[parts[:-1] if parts[-1] == "__init__" else parts] = p
    return out


#: an import statement's head: ``from <module> import <names...`` or ``import <names...``
_IMPORT = re.compile(r"^(\s*)(?:from\s+(\.*)([\w.]*)\s+import\s+(.*)|import\s+(.*))$")


def import_statements(text: str) -> list[tuple[int, str, list[str]]]:
    """The import statements of a module's source as ``(level, module, names)`` (``import a.b``
    as ``(0, "", ["a.b"])``), wherever they are, but those under ``if TYPE_CHECKING:`` (not
    run). A line scan, not a parse: parsing the package's sources costs ~0.3 s, which every
    run would pay; a test holds the scan to :mod:`ast`'s answer."""
    out: list[tuple[int, str, list[str]]] = []
    lines = text.splitlines()
    skip_indent: int | None = None
    k = 0
    while k < len(lines):
        line = lines[k]
        k += 1
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        indent = len(line) - len(line.lstrip())
        if skip_indent is not None:
            if indent > skip_indent:
                continue
            skip_indent = None
        if stripped.startswith("if TYPE_CHECKING"):
            skip_indent = indent
            continue
        m = _IMPORT.match(line)
        if m is None:
            continue
        rest = (m.group(4) if m.group(4) is not None else m.group(5)).split("#")[0]
        if "(" in rest:                          # names continue up to the closing bracket
            while ")" not in rest and k < len(lines):
                rest += " " + lines[k].split("#")[0]
                k += 1
        while rest.rstrip().endswith("\\") and k < len(lines):     # a continued line
            rest = rest.rstrip()[:-1] + " " + lines[k].split("#")[0]
            k += 1
        rest = rest.replace("(", " ").replace(")", " ")
        names = [n.split(" as ")[0].strip() for n in rest.split(",")]
        names = [n for n in names if n]
        if m.group(5) is not None:
            out.append((0, "", names))
        else:
            out.append((len(m.group(2)), m.group(3), names))
    return out


def _imported_files(path: Path) -> set[Path]:
    """Sources of the package modules ``path`` imports (anywhere in the file): for
    ``from X import n`` the module ``X.n`` if there is one, else ``X`` itself; for
    ``import X.Y``, ``X.Y``. The packages an import only passes through are left out."""
    here = list(path.relative_to(_PKG).with_suffix("").parts)[:-1]   # its package
    modules = _package_modules()
    found: set[Path] = set()
    for level, module, names in import_statements(path.read_text()):
        if level:
            base = here[:len(here) - (level - 1)]
            mod = base + (module.split(".") if module else [])
        elif module:
            if module.split(".")[0] != "monkeystudy":
                continue
            mod = module.split(".")[1:]
        else:
            found.update(modules[tuple(t)] for n in names if n.split(".")[0] == "monkeystudy"
                         and tuple(t := n.split(".")[1:]) in modules)
            continue
        for n in names:
            sub = tuple(mod + [n])
            target = sub if sub in modules else tuple(mod)
            if target in modules:
                found.add(modules[target])
    return found


def module_path(module: str) -> Path:
    """The source of a module of the package, by its dotted name
    (``monkeystudy.study.steps.grid``)."""
    return _package_modules()[tuple(module.split(".")[1:])]


@functools.lru_cache(maxsize=None)
def result_sources(module: str | None = None) -> tuple[Path, ...]:
    """Every source that decides what ``module`` (a step kind's, by its dotted name)
    computes: its own and the package modules it imports, transitively (sorted). Without
    ``module``, those of every module of :data:`RESULT_ROOT` but its registry (every
    kind)."""
    todo = ([module_path(module)] if module is not None
            else sorted(p for p in (_PKG / RESULT_ROOT).rglob("*.py")
                        if p.name != "__init__.py"))
    seen: set[Path] = set(todo)
    while todo:
        for p in _imported_files(todo.pop()):
            if p not in seen:
                seen.add(p)
                todo.append(p)
    return tuple(sorted(seen))


@functools.lru_cache(maxsize=None)
def code_sha256(module: str | None = None) -> str:
    """Hash of the package version and every source of :func:`result_sources` of
    ``module`` (a step kind's module: what its datasets are keyed by), or of every kind."""
    h = hashlib.sha256(f"monkeystudy {__version__}\n".encode())
    for p in result_sources(module):
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


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of a file's bytes (hex)."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def run_key(study_sha256: str) -> str:
    """Key of one study text run by this code: names shard folders, checked in datasets."""
    return hashlib.sha256(f"{study_sha256}:{code_sha256()}".encode()).hexdigest()
