"""The README is for users: short, and every command and option exactly as --help prints it;
the docs it links exist; the project speaks of itself, not of how it was built."""
from __future__ import annotations

import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from monkeystudy.cli import app

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _flat(text: str) -> str:
    return " ".join(text.split())


def _options(command: str) -> list[str]:
    """The option entries of ``monkeystudy COMMAND --help`` (name, metavar and help, with
    the help's line breaks joined), --help itself left out."""
    out = CliRunner().invoke(app, [command, "--help"], terminal_width=80).output
    body = out.split("Options:", 1)[1]
    entries, cur = [], ""
    for line in body.splitlines():
        if re.match(r"^  -", line):
            if cur:
                entries.append(cur)
            cur = line
        elif line.startswith("    ") and cur:
            cur += " " + line.strip()
    entries.append(cur)
    return [_flat(e) for e in entries if e and "--help" not in _flat(e)]


@pytest.mark.parametrize("command", ["run", "report", "serve", "bench"])
def test_readme_shows_every_option_as_help_prints_it(command):
    flat = _flat(README)
    for entry in _options(command):
        assert entry in flat, f"README: {command} {entry!r}"


@pytest.mark.parametrize("command", ["run", "report", "serve", "bench", "validate", "inspect",
                                     "schema"])
def test_readme_names_every_command(command):
    assert f"monkeystudy {command}" in README


def test_readme_is_short_and_its_links_exist():
    assert len(README.splitlines()) <= 250
    for link in re.findall(r"\]\(([^)#]+)\)", README):
        assert (ROOT / link).exists(), link


def test_the_project_speaks_of_itself_not_of_its_history():
    """No development diary in the README, docs, code, tests or studies."""
    diary = re.compile(r"\b(sessions? \d+|last session|this session|previous session)\b"
                       .replace("session", "sess" + "ion"), re.IGNORECASE)
    bad = []
    for folder in ("docs", "src", "tests", "studies", "pipeline"):
        for p in (ROOT / folder).rglob("*"):
            if p.suffix in (".py", ".md", ".yaml") and p.name != "test_readme.py" and \
                    diary.search(p.read_text()):
                bad.append(str(p.relative_to(ROOT)))
    if diary.search(README):
        bad.append("README.md")
    assert not bad, bad


def test_the_install_goes_into_a_virtual_environment():
    """The install line comes after a virtual environment is made and activated."""
    venv = README.index("python3 -m venv .venv && . .venv/bin/activate")
    assert venv < README.index("python3 -m pip install -e .")
