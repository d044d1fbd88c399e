"""Every fenced code block of the README and the docs works as written.

Each fence names its language, and the language says what is checked:

- ``yaml``: a study file; validated as ``monkeystudy validate`` does (``study.loader``), and
  run as written (the README's study: a 24 321-point map, three refinements and a 30-cycle
  replay, seconds once compiled).
- ``python``: executed top to bottom, from a folder holding what it reads (the README's first
  block reads ``outputs/horizontal/``: ``studies/horizontal.yaml`` is run there first, a
  few seconds once compiled). A statement that is an expression with a comment holding
  numbers (``float(gait.error)   # 1.24e-4``) prints what the comment says: each
  comma-separated item of the comment is one value of the expression, a number equal to the
  value at the digits printed (a unit after it is ignored), a word equal to its name.
- ``bash``: each command line parses: ``monkeystudy ...`` against the command line's own
  parser (command, options, their values and the arguments); ``python <script> ...`` names a
  script of this repository and, when the script has an ``argparse`` parser, options its
  ``--help`` lists; ``python -c "..."`` compiles. ``pip`` and ``pytest`` lines (installing,
  the test suite itself) are not run. The findings' ``python -c`` block reads
  ``outputs/robust_design`` (minutes to produce): it is compiled here, and
  ``tools/check_findings.py`` computes the draws it prints and checks the numbers the text
  cites from them.
- ``text``: an output listing or a diagram, not runnable: skipped.

Inline code spans that start with ``monkeystudy `` are command lines too and parse the same way.
"""
from __future__ import annotations

import ast
import io
import re
import shlex
import subprocess
import sys
from contextlib import redirect_stdout
from dataclasses import dataclass
from pathlib import Path

import click
import pytest

from monkeystudy.cli import app

from toolmodules import load_tool

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")),
        ROOT / "pipeline" / "README.md", ROOT / "outputs" / "README.md"]
LANGUAGES = {"yaml", "python", "bash", "text"}


check_findings = load_tool("check_findings")


@dataclass(frozen=True)
class Block:
    """One fenced code block: its file, the line of its opening fence, language, text."""

    path: Path
    line: int
    language: str
    text: str

    def __str__(self) -> str:
        return f"{self.path.relative_to(ROOT)}:{self.line}"


def fenced_blocks(path: Path) -> list[Block]:
    """The fenced code blocks of a markdown file (an unclosed fence is an error)."""
    blocks, lines = [], path.read_text().splitlines()
    i = 0
    while i < len(lines):
        m = re.match(r"^(\s*)(```+)\s*(\S*)", lines[i])
        if not m:
            i += 1
            continue
        indent, fence, language = m.groups()
        body, j = [], i + 1
        while j < len(lines) and not lines[j].strip().startswith(fence):
            body.append(lines[j][len(indent):] if lines[j].startswith(indent) else lines[j])
            j += 1
        assert j < len(lines), f"{path.relative_to(ROOT)}:{i + 1}: unclosed fence"
        blocks.append(Block(path, i + 1, language, "\n".join(body) + "\n"))
        i = j + 1
    return blocks


BLOCKS = [b for p in DOCS for b in fenced_blocks(p)]


def _of(language: str) -> list:
    return [pytest.param(b, id=str(b)) for b in BLOCKS if b.language == language]


def test_every_fence_says_what_it_holds():
    """A fence without a language, or with one the test does not know, would go unchecked."""
    assert BLOCKS
    bad = [f"{b}: {b.language or '(none)'}" for b in BLOCKS if b.language not in LANGUAGES]
    assert not bad, f"fences must be one of {sorted(LANGUAGES)}: {bad}"


# --- yaml: study files ------------------------------------------------------------------------
@pytest.mark.parametrize("block", _of("yaml"))
def test_study_blocks_validate(block, tmp_path):
    from monkeystudy.study.loader import StudyError, load_study

    path = tmp_path / "study.yaml"
    path.write_text(block.text)
    try:
        load_study(path, shown=str(block))
    except StudyError as exc:
        pytest.fail(f"{block}: the study is refused:\n{exc}")


@pytest.mark.parametrize("block", _of("yaml"))
def test_study_blocks_run_as_written(block, tmp_path):
    from monkeystudy.study import load_study, run_study

    path = tmp_path / "study.yaml"
    path.write_text(block.text)
    loaded = load_study(path)
    out = tmp_path / "out"
    summary = run_study(loaded, out, workers=1)
    steps = {s.name for s in loaded.study.steps}
    assert {p.stem for p in summary.written} == steps, f"{block}: {summary.written}"


# --- python -----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def outputs_folder(tmp_path_factory):
    """A folder with ``outputs/horizontal/`` (``studies/horizontal.yaml`` run as written)."""
    from monkeystudy.study import load_study, run_study

    folder = tmp_path_factory.mktemp("docs")
    run_study(load_study(ROOT / "studies" / "horizontal.yaml"),
              folder / "outputs" / "horizontal", workers=1)
    return folder


def _comment_of(source_lines: list[str], node: ast.stmt) -> str | None:
    """The ``#`` comment at the end of a statement's last line, if any."""
    line = source_lines[node.end_lineno - 1]
    tail = line[node.end_col_offset:]
    m = re.match(r"\s*#\s?(.*)$", tail)
    return m.group(1).strip() if m else None


def comment_mismatches(value, comment: str) -> list[str]:
    """How ``value`` differs from what its comment says it prints (nothing: it agrees).

    The comment's comma-separated items are the value's items (a tuple) or the value; an item
    is a number, compared at its printed digits (:func:`check_findings.matches`), with an
    optional unit after it, or a word, compared with the value's name or text."""
    values = list(value) if isinstance(value, tuple) else [value]
    items = [s.strip() for s in comment.split(",")]
    if len(items) != len(values):
        return [f"{len(items)} items in the comment, {len(values)} values: {values!r}"]
    out = []
    for item, v in zip(items, values):
        m = re.match(r"^([-+]?\d[\d.]*(?:e[-+]?\d+)?)(\s+\S+)?$", item)
        if m:
            if not check_findings.matches(m.group(1), float(v)):
                out.append(f"{item!r}: the code gives {float(v)!r}")
        elif item != getattr(v, "name", str(v)):
            out.append(f"{item!r}: the code gives {v!r}")
    return out


@pytest.mark.parametrize("block", _of("python"))
def test_python_blocks_run_and_print_their_comments(block, outputs_folder, monkeypatch):
    monkeypatch.chdir(outputs_folder)
    tree = ast.parse(block.text, filename=str(block))
    lines = block.text.splitlines()
    scope: dict = {"__name__": "__docs__"}
    wrong = []
    for node in tree.body:
        code = compile(ast.Module([node], []), str(block), "exec")
        comment = _comment_of(lines, node)
        if isinstance(node, ast.Expr) and comment and re.search(r"\d", comment):
            value = eval(compile(ast.Expression(node.value), str(block), "eval"), scope)
            for problem in comment_mismatches(value, comment):
                wrong.append(f"{block.path.name}:{block.line + node.lineno}: "
                             f"{lines[node.lineno - 1].split('#')[0].strip()}  # {problem}")
        else:
            with redirect_stdout(io.StringIO()):
                exec(code, scope)
    assert not wrong, "\n".join(wrong)


def test_comment_check_can_fail():
    assert comment_mismatches((0.899381, 10.933721), "0.899381, 10.933721") == []
    assert comment_mismatches((0.8993814, 1.2449e-4), "0.899381, 1.24e-4") == []
    assert comment_mismatches((0.899391, 1.2349e-4), "0.899381, 1.24e-4") != []
    assert len(comment_mismatches((0.43, 0.0245), "0.43 s, 0.024 s")) == 1
    assert comment_mismatches((1.0,), "1, 2") != []


# --- bash: command lines ------------------------------------------------------------------------
def _command_lines(text: str) -> list[str]:
    """The commands of a shell block: continuation lines joined, comments dropped, ``&&``
    split, a leading ``time`` dropped."""
    joined = re.sub(r"\\\n\s*", " ", text)
    out, buffer = [], ""
    for line in joined.splitlines():
        buffer = f"{buffer}\n{line}" if buffer else line
        try:
            words = shlex.split(buffer, comments=True)
        except ValueError:            # an open quote: the command goes on
            continue
        buffer = ""
        command: list[str] = []
        for w in words + ["&&"]:
            if w == "&&":
                if command:
                    out.append(command[1:] if command[0] == "time" else command)
                command = []
            else:
                command.append(w)
    assert not buffer, f"unclosed quote in {text!r}"
    return out


def cli_problem(args: list[str]) -> str | None:
    """Why ``monkeystudy ARGS`` would not parse (None: it parses): the command exists, and
    its options, their values and its arguments are what its parser takes."""
    try:
        if not args or args[0].startswith("-"):      # the group's own options: --version
            app.make_context("monkeystudy", list(args))
            return None
        command = app.get_command(click.Context(app), args[0])
        if command is None:
            return f"no command {args[0]!r}"
        command.make_context(args[0], list(args[1:]), parent=click.Context(app))
    except click.exceptions.Exit:          # --version, --help
        return None
    except click.ClickException as exc:
        return exc.format_message()
    return None


def script_problem(words: list[str]) -> str | None:
    """Why ``python [-c CODE | SCRIPT ARGS]`` would not run as written (None: it would)."""
    if words[1] == "-c":
        try:
            compile(words[2], "<python -c>", "exec")
        except SyntaxError as exc:
            return f"python -c: {exc}"
        return None
    if words[1] == "-m":
        return None if words[2] in ("pip", "pytest", "monkeystudy", "venv") \
            else f"module {words[2]}"
    script = ROOT / words[1]
    if not script.is_file():
        return f"no script {words[1]}"
    if "argparse" not in script.read_text():
        return None
    help_text = subprocess.run([sys.executable, str(script), "--help"], capture_output=True,
                               text=True, cwd=ROOT, timeout=120).stdout
    missing = [w for w in words[2:] if w.startswith("-") and w.split("=")[0] not in help_text]
    return f"{words[1]}: no option {missing}" if missing else None


def command_problem(words: list[str]) -> str | None:
    if words[0] == "monkeystudy":
        return cli_problem(words[1:])
    if words[0] in (".", "source"):      # activating the virtual environment
        return None if words[1:] == [".venv/bin/activate"] else f"sources {words[1:]}"
    if words[0] in ("python", "python3"):
        if words[1:3] == ["-m", "monkeystudy"]:
            return cli_problem(words[3:])
        return script_problem(words)
    return f"not a command of this project: {words[0]}"


@pytest.mark.parametrize("block", _of("bash"))
def test_command_lines_parse(block):
    lines = _command_lines(block.text)
    assert lines, f"{block}: no command"
    wrong = [f"{' '.join(w)[:80]}: {p}" for w in lines if (p := command_problem(w))]
    assert not wrong, f"{block}:\n" + "\n".join(wrong)


def _inline_commands() -> list:
    out = []
    for path in DOCS:
        text = path.read_text()
        for block in fenced_blocks(path):    # inline spans outside fences only
            text = text.replace(block.text, "")
        for span in re.findall(r"`(monkeystudy [^`]+)`", text):
            out.append(pytest.param(span, id=f"{path.relative_to(ROOT)}:{span[:40]}"))
    return out


@pytest.mark.parametrize("span", _inline_commands())
def test_inline_command_lines_parse(span):
    """An inline command line parses; a placeholder (``<study name>``) is one argument, and
    a span naming a command alone (``monkeystudy report``) names one that exists."""
    words = shlex.split(re.sub(r"<[^>]*>", "X", span))
    if words[-1] in ("...", "…"):          # `monkeystudy run ...`: a command named, not given
        words = words[:-1]
    if len(words) == 2 and not words[1].startswith("-"):
        assert app.get_command(click.Context(app), words[1]) is not None, span
        return
    assert command_problem(words) is None, f"{span}: {command_problem(words)}"


def test_command_check_can_fail():
    assert cli_problem(["run", "studies/smoke.yaml", "-j", "1"]) is None
    assert cli_problem(["run", "studies/smoke.yaml", "--no-such-option"])
    assert cli_problem(["run"])                            # STUDY missing
    assert cli_problem(["run", "-j", "0", "x.yaml"])       # x >= 1
    assert cli_problem(["inspect", "a", "b"])              # one PATH
    assert cli_problem(["nosuchcommand"])
    assert script_problem(["python", "pipeline/build.py", "--no-such-option"])
    assert script_problem(["python", "-c", "print("])
    assert _command_lines("monkeystudy run a.yaml && \\\n  monkeystudy report b  # x\n") == \
        [["monkeystudy", "run", "a.yaml"], ["monkeystudy", "report", "b"]]
