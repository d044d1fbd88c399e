"""The package's structure: layers that point down (import-linter contracts in pyproject.toml,
imports inside functions included), no private name used across modules, imports inside
functions only with a stated reason, and a step-kind registry in which every kind is
documented and has its figures."""
from __future__ import annotations

import ast
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from monkeystudy.plotting.report import DRAWINGS
from monkeystudy.study.schema import Study
from monkeystudy.study.steps import REGISTRY

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "src" / "monkeystudy"
#: import-linter's command (a test dependency), beside this interpreter or on the PATH
LINT = str(Path(sys.executable).with_name("lint-imports")) \
    if Path(sys.executable).with_name("lint-imports").exists() else shutil.which("lint-imports")

#: modules that are entry points: their imports inside functions keep --help fast
ENTRY_POINTS = {"__main__.py", "cli.py"}


def _lint(root: Path) -> subprocess.CompletedProcess:
    assert LINT, "import-linter is not installed (pip install -e '.[test]')"
    env = dict(os.environ, PYTHONPATH=str(root / "src"))
    return subprocess.run([LINT, "--no-cache", str(root / "pyproject.toml")], cwd=root, env=env,
                          capture_output=True, text=True)


def test_import_contracts_are_kept():
    res = _lint(ROOT)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "broken" not in res.stdout.split("Contracts:")[-1].replace("0 broken", "")


@pytest.mark.parametrize("file, code, contract", [
    # the kernel imports the study layer at module level
    ("kernel/layout.py", "from ..study import models  # noqa\n", "The package's layers"),
    # the same inside a function: imports inside functions count
    ("kernel/gait.py", "\n\ndef _f():\n    from ..analysis import sections  # noqa\n",
     "The package's layers"),
    # a cycle between siblings, hidden in a function
    ("analysis/sections.py", "\n\ndef _f():\n    from . import replay  # noqa\n",
     "No cycle among the modules"),
    # the thin client loads numpy
    ("service/client.py", "import numpy  # noqa\n", "The thin client"),
    # the kernel loads scipy
    ("kernel/roots.py", "import scipy  # noqa\n", "The kernel imports nothing"),
    # a step kind reads a kernel constant instead of the simulation API's name for it
    ("study/steps/grid.py", "\n\ndef _f():\n    from ...kernel import layout  # noqa\n",
     "Study and plotting do not import the kernel"),
    # a figure calls a kernel function
    ("plotting/cycles.py", "from ..kernel.dynamics import kinetic_energy  # noqa\n",
     "Study and plotting do not import the kernel"),
])
def test_a_violation_breaks_a_contract(tmp_path, file, code, contract):
    """A copy of the package with one deliberate violation fails the check, naming it."""
    shutil.copytree(PKG, tmp_path / "src" / "monkeystudy",
                    ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    target = tmp_path / "src" / "monkeystudy" / file
    target.write_text(target.read_text() + code)
    res = _lint(tmp_path)
    assert res.returncode != 0
    broken = [line for line in res.stdout.splitlines() if line.endswith("BROKEN")]
    assert len(broken) >= 1 and any(line.startswith(contract) for line in broken), res.stdout


def _modules():
    for path in sorted(PKG.rglob("*.py")):
        yield path, ast.parse(path.read_text())


def test_no_private_name_is_used_across_modules():
    """``from monkeystudy.x import _name`` and ``module._name`` for a package module are
    refused (dunder names aside): a name used by another module is public."""
    bad = []
    for path, tree in _modules():
        modules = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                inside = node.level > 0 or (node.module or "").startswith("monkeystudy")
                for a in node.names:
                    if inside and a.name.startswith("_") and not a.name.startswith("__"):
                        bad.append(f"{path.relative_to(PKG)}:{node.lineno}: imports {a.name}")
                    if inside:
                        modules.add(a.asname or a.name)
            elif isinstance(node, ast.Import):
                modules |= {a.asname or a.name.split(".")[0] for a in node.names
                            if a.name.startswith("monkeystudy")}
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and \
                    node.value.id in modules and node.attr.startswith("_") and \
                    not node.attr.startswith("__"):
                bad.append(f"{path.relative_to(PKG)}:{node.lineno}: uses "
                           f"{node.value.id}.{node.attr}")
    assert not bad, "\n".join(bad)


def test_imports_inside_functions_say_why():
    """Outside the entry points, an import inside a function has a comment saying why (it
    keeps start-up fast): on its line, or above the block of imports it starts; never a
    silent cycle-dodge."""
    bad = []
    for path, tree in _modules():
        if path.name in ENTRY_POINTS:
            continue
        lines = path.read_text().splitlines()
        for fn in ast.walk(tree):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            explained_until = -1         # last line of a block of imports with a reason
            for node in sorted((n for n in ast.walk(fn)
                                if isinstance(n, (ast.Import, ast.ImportFrom))),
                               key=lambda n: n.lineno):
                here = lines[node.lineno - 1]
                above = lines[node.lineno - 2].strip()
                if "#" in here or above.startswith("#") or node.lineno == explained_until + 1:
                    explained_until = node.end_lineno
                else:
                    bad.append(f"{path.relative_to(PKG)}:{node.lineno}: {here.strip()}")
    assert not bad, "\n".join(bad)


# --- the step-kind registry ----------------------------------------------------------------------
def test_every_step_kind_is_registered_in_the_schema():
    names = [k.name for k in REGISTRY.values()]
    assert len(set(names)) == len(names)
    models = Study.model_fields["steps"].annotation.__args__[0].__origin__.__args__
    assert [m.model_fields["kind"].annotation.__args__[0] for m in models] == names
    for kind in REGISTRY.values():
        assert kind.summary, kind.name                   # its model says what it does
        assert kind.gait_kinds and set(kind.gait_kinds) <= {"horizontal", "sequence"}


def _steps_imports() -> dict[str, set[str]]:
    """The modules of ``study/steps`` each module there imports (inside functions too)."""
    folder = PKG / "study" / "steps"
    names = {p.stem for p in folder.glob("*.py")}
    out = {}
    for path in folder.glob("*.py"):
        got = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level == 1:
                got |= ({node.module.split(".")[0]} if node.module else
                        {a.name for a in node.names})
        out[path.stem] = got & names
    return out


def test_step_kinds_stand_side_by_side():
    """No kind imports another kind's module: what a step starts from comes through its
    source's kind (``StepKind.hand_on``) and the one readers module, so the modules of
    ``study/steps`` stand three levels deep (base and readers, the kinds, the registry)."""
    graph = _steps_imports()
    kinds = {type(k).__module__.rsplit(".", 1)[-1] for k in REGISTRY.values()}
    for module in kinds:
        assert graph[module] <= {"base", "gait_source"}, (module, graph[module])
    assert graph["base"] == set() and graph["gait_source"] == set()

    def depth(m):
        return 1 + max((depth(d) for d in graph[m]), default=0)
    assert max(depth(m) for m in graph) == 3


def test_no_step_kind_asks_another_steps_type():
    """Which steps a kind starts from is its declaration (``accepts``), never an
    ``isinstance`` of another kind's model."""
    bad = []
    for path in sorted((PKG / "study").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", "") == "isinstance":
                names = {n.id for n in ast.walk(node.args[1]) if isinstance(n, ast.Name)}
                bad += [f"{path.relative_to(PKG)}:{node.lineno}: {n}" for n in names
                        if n.endswith("Step")]
    assert not bad, bad


def test_what_a_kind_accepts_is_handed_on():
    """Every kind a ``from:`` accepts says what it hands on and reads it."""
    from monkeystudy.study.steps.base import StepKind

    for kind in REGISTRY.values():
        for source in kind.accepts:
            provider = REGISTRY[source]
            assert provider.provides, source
            assert type(provider).hand_on is not StepKind.hand_on, source


def test_every_step_kind_has_its_tests():
    """Tests mirror the package: each registered kind has tests/study/steps/test_<kind>.py."""
    folder = ROOT / "tests" / "study" / "steps"
    missing = [k for k in REGISTRY if not (folder / f"test_{k}.py").is_file()]
    assert not missing, missing


def test_architecture_lists_the_registered_kinds():
    """docs/architecture.md names the kinds the registry holds, no more and no fewer."""
    text = (ROOT / "docs" / "architecture.md").read_text()
    listed = re.search(r"one module each:\s*(.*?)\)", text, re.S).group(1)
    assert set(re.findall(r"`(\w+)`", listed)) == set(REGISTRY)


def test_every_step_kind_draws_its_figures_in_its_own_plotting_module():
    """plotting/kinds/<kind>.py of each registered kind draws exactly the figures it declares."""
    import importlib

    for name, kind in REGISTRY.items():
        module = importlib.import_module(f"monkeystudy.plotting.kinds.{name}")
        assert set(module.DRAWINGS) == {(name, f.suffix) for f in kind.figures}, name


def test_every_step_kind_is_documented():
    """Each kind has a section in docs/datasets.md and is named in the README or docs."""
    datasets = (ROOT / "docs" / "datasets.md").read_text()
    text = datasets + (ROOT / "README.md").read_text() + "".join(
        p.read_text() for p in (ROOT / "docs").glob("*.md"))
    for name in REGISTRY:
        assert re.search(rf"`{name}`", datasets), f"{name}: no section in docs/datasets.md"
        assert name in text


def test_every_step_kind_has_its_figures_or_says_why():
    declared = set()
    for kind in REGISTRY.values():
        assert kind.figures or kind.no_figures, f"{kind.name}: no figure and no reason"
        for fig in kind.figures:
            assert re.fullmatch(r"[a-z0-9_]+", fig.suffix), fig.suffix
            declared.add((kind.name, fig.suffix))
    assert declared == set(DRAWINGS), "declared figures and their drawings differ: " \
        f"{declared ^ set(DRAWINGS)}"
    for (kind, suffix), how in DRAWINGS.items():
        fig = next(f for f in REGISTRY[kind].figures if f.suffix == suffix)
        assert how.across == fig.across, (kind, suffix)
        assert how.title and how.caption, (kind, suffix)


def test_the_kernel_package_imports_only_numpy_numba_and_the_standard_library():
    """The same rule as the contract, checked without import-linter: every import of the
    kernel's modules names the standard library, numpy, numba, llvmlite or the kernel."""
    allowed = set(sys.stdlib_module_names) | {"numpy", "numba", "llvmlite"}
    bad = []
    for path in sorted((PKG / "kernel").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                names = [node.module]
            elif isinstance(node, ast.ImportFrom):
                if node.level > 1:
                    bad.append(f"{path.name}: from {'.' * node.level}{node.module or ''}")
                continue
            else:
                continue
            bad += [f"{path.name}: {n}" for n in names if n.split(".")[0] not in allowed]
    assert not bad, bad


#: the kernel module that is the robot's model (the room, docs/architecture.md): the only one
#: that reads the robot's parameters, but the Coulomb limits the hybrid loop's stick-slip
#: logic compares holding torques with
ROOM = "dynamics.py"
LOOP_READS = {"P_C_PIVOT", "P_C_JOINT"}


def robot_parameter_reads(folder: Path) -> list[str]:
    """``file:line: name`` of every robot parameter index (``layout.P_*``) that a kernel module
    of ``folder`` other than the room and the layout names, bar :data:`LOOP_READS`."""
    bad = []
    for path in sorted(folder.glob("*.py")):
        if path.name in (ROOM, "layout.py"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Name):
                names = [node.id]
            elif isinstance(node, ast.Attribute):
                names = [node.attr]
            elif isinstance(node, ast.ImportFrom):
                names = [a.asname or a.name for a in node.names]
            bad += [f"{path.name}:{node.lineno}: {n}" for n in names
                    if re.fullmatch(r"P_[A-Z0-9_]+", n) and n not in LOOP_READS]
    return bad


def test_only_the_room_reads_the_robots_geometry():
    """The two-link geometry (lengths, CG offsets, masses and inertias and what derives from
    them) is spelled in one kernel module: the guards, steps and loop reach it through the
    room's functions (e.g. ``dynamics.free_end_height_s``, ``dynamics.guard_params``)."""
    assert not robot_parameter_reads(PKG / "kernel")


@pytest.mark.parametrize("code", ["h = -p[P_L1] * c1\n", "from .layout import P_R2\n",
                                  "h = p[layout.P_K11]\n"])
def test_a_kernel_module_spelling_the_geometry_is_found(tmp_path, code):
    (tmp_path / "guards.py").write_text(code)
    (tmp_path / ROOM).write_text("h = -p[P_L1] * c1\n")
    assert len(robot_parameter_reads(tmp_path)) == 1
