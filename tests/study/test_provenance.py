"""What keys a dataset: the code hash covers exactly the modules the step kinds import."""
from __future__ import annotations

import ast
from pathlib import Path

from monkeystudy.study import provenance as P

PKG = Path(P.__file__).resolve().parents[1]


def _ast_imports(text: str) -> list[tuple[int, str, list[str]]]:
    """The import statements of a module by parsing it (those under ``if TYPE_CHECKING:``
    left out), in the form of :func:`~monkeystudy.study.provenance.import_statements`."""
    out = []

    def visit(node):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                continue
            if isinstance(child, ast.Import):
                out.append((0, "", [a.name for a in child.names]))
            elif isinstance(child, ast.ImportFrom):
                out.append((child.level, child.module or "", [a.name for a in child.names]))
            else:
                visit(child)
    visit(ast.parse(text))
    return out


def test_the_line_scan_finds_the_imports_the_parser_finds():
    for path in sorted(PKG.rglob("*.py")):
        text = path.read_text()
        assert sorted(P.import_statements(text)) == sorted(_ast_imports(text)), path


def test_the_code_hash_covers_the_computation_and_not_the_presentation():
    names = {p.relative_to(PKG).as_posix() for p in P.result_sources()}
    for must in ("kernel/hybrid.py", "kernel/rk_explicit.py", "simulation.py", "robot.py",
                 "controllers.py", "analysis/continuation.py", "analysis/variational.py",
                 "reference/scipy_gait.py", "study/steps/grid.py", "study/datasets.py",
                 "study/models.py"):
        assert must in names, must
    for never in ("bench.py", "cli.py", "__main__.py", "plotting/report.py",
                  "service/server.py", "service/client.py", "study/runner.py",
                  "study/progress.py", "study/inspect.py"):
        assert never not in names, never
