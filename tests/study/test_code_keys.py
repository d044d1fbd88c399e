"""A dataset is keyed by the code its own step kind runs: editing one kind (in a copy of the
package) leaves the datasets of the other kinds current, and makes its own and those built on
them stale."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from monkeystudy.study import provenance as P
from monkeystudy.study.steps import REGISTRY

ROOT = Path(__file__).resolve().parents[2]
PKG = Path(P.__file__).resolve().parents[1]
SMOKE = ROOT / "studies" / "smoke.yaml"


def _monkeystudy(copy: Path, *args) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(copy)}
    return subprocess.run([sys.executable, "-m", "monkeystudy", *map(str, args)], env=env,
                          capture_output=True, text=True, timeout=900, cwd=copy)


def _plan(copy: Path, out: Path) -> dict[str, str]:
    """``{step: "up to date" or "to do"}`` from ``run --dry-run`` with the copied package."""
    res = _monkeystudy(copy, "run", SMOKE, "--out", out, "--dry-run")
    assert res.returncode == 0, res.stderr
    plan = {}
    for line in res.stdout.splitlines():
        if " -> " in line and "[" in line and line.startswith("  "):
            name = line.split()[0]
            plan[name] = "up to date" if line.rstrip().endswith("up to date") else "to do"
    return plan


def _edit(copy: Path, module: str) -> None:
    with open(copy / "monkeystudy" / module, "a") as fh:
        fh.write("\n# an edit of this kind's code\n_EDITED = True\n")


EVERYTHING = {"coarse_map", "gait1", "minima", "gait1_cycles", "minima_cycles"}


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory) -> tuple[Path, Path]:
    """A copy of the package and the datasets of studies/smoke.yaml it made."""
    base = tmp_path_factory.mktemp("smoke")
    copy, out = base / "pkg", base / "out"
    shutil.copytree(PKG, copy / "monkeystudy", ignore=shutil.ignore_patterns("__pycache__"))
    res = _monkeystudy(copy, "run", SMOKE, "--out", out, "--workers", "1")
    assert res.returncode == 0, res.stderr
    return copy, out


@pytest.fixture
def smoke_copy(smoke_run, tmp_path) -> tuple[Path, Path]:
    """A copy of :func:`smoke_run`'s package and datasets of this test's own to edit."""
    copy, out = tmp_path / "pkg", tmp_path / "out"
    shutil.copytree(smoke_run[0], copy, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(smoke_run[1], out)
    return copy, out


def test_editing_one_kind_leaves_the_other_kinds_datasets_current(smoke_copy):
    copy, out = smoke_copy
    everything = EVERYTHING
    assert _plan(copy, out) == dict.fromkeys(everything, "up to date")

    _edit(copy, "study/steps/design.py")          # a kind smoke.yaml does not use
    assert _plan(copy, out) == dict.fromkeys(everything, "up to date")

    _edit(copy, "study/steps/refine.py")          # refine, and the replays of its gaits
    assert _plan(copy, out) == {"coarse_map": "up to date", "gait1": "to do",
                                "minima": "to do", "gait1_cycles": "to do",
                                "minima_cycles": "to do"}


def test_editing_a_figure_caption_leaves_the_datasets_current(smoke_copy):
    """A figure's title and caption are text of its drawing: editing the captions of the
    smoke study's kinds (wherever the package holds them) recomputes nothing."""
    from monkeystudy.plotting.report import DRAWINGS

    copy, out = smoke_copy
    edited = []
    for (kind, _), how in DRAWINGS.items():
        if kind not in ("grid", "refine", "stability"):
            continue
        start = how.caption[:30]           # on one line of the source
        for p in (copy / "monkeystudy").rglob("*.py"):
            text = p.read_text()
            if start in text:
                p.write_text(text.replace(start, start + " (an edited caption)"))
                edited.append(p)
    assert edited
    assert _plan(copy, out) == dict.fromkeys(EVERYTHING, "up to date")


def test_no_figure_caption_is_among_the_sources_of_a_kind():
    """No caption of a figure is a string of a source that keys a dataset."""
    import ast

    from monkeystudy.plotting.report import DRAWINGS

    strings = set()
    for p in P.result_sources():
        strings |= {n.value for n in ast.walk(ast.parse(p.read_text()))
                    if isinstance(n, ast.Constant) and isinstance(n.value, str)}
    assert {how.caption for how in DRAWINGS.values()} & strings == set()


def test_a_kind_is_keyed_by_its_own_import_closure():
    sources = {name: {p.relative_to(PKG).as_posix()
                      for p in P.result_sources(type(kind).__module__)}
               for name, kind in REGISTRY.items()}
    for name, files in sources.items():
        assert "study/steps/__init__.py" not in files, name     # the registry decides nothing
        assert "plotting/report.py" not in files and "cli.py" not in files, name
    assert "study/steps/design.py" not in sources["grid"] | sources["refine"] | \
        sources["stability"]
    assert {"kernel/hybrid.py", "simulation.py", "study/steps/grid.py"} <= sources["grid"]
    # every kind's sources are among those of all kinds together
    assert set().union(*sources.values()) == {p.relative_to(PKG).as_posix()
                                              for p in P.result_sources()}


@pytest.mark.parametrize("kind", sorted(REGISTRY))
def test_each_kind_has_a_code_hash_of_its_own_sources(kind):
    k = REGISTRY[kind]
    assert k.code_sha256 == P.code_sha256(type(k).__module__)
    assert len(k.code_sha256) == 64
