"""Every number docs/findings.md and the README's findings cite, against what the code gives.

Usage::

    python tools/check_findings.py --run              # run the cited studies (-j 1), then check
    python tools/check_findings.py                    # check against outputs/ as it is
    python tools/check_findings.py --studies horizontal,smoke
    python tools/check_findings.py --list             # every number and where it comes from

Each number of the two documents' prose (fenced code blocks aside: tests/test_docs.py runs
those) is tied to its source in ``tools/findings_numbers.yaml``: an entry quotes a passage of
the document and gives, for each number in the passage, in order, either an expression that
computes it from a study's datasets (or from the output of a command the passage cites), or
a reason it is not a result (``"# ..."``: a setting of the study, a value of the 2009 study's
report, a section number). A number of the documents that no entry covers is an error, so no
number is skipped silently, and so is a passage that is no longer in the document.

A number is compared at the digits it is printed with: ``0.899`` holds for 0.8994, not for
0.8996; ``1.24e-4`` for 1.2449e-4. An expression prefixed ``<=`` (or ``>=``) says the printed
number is a bound the value must keep (``below 1e-15``).

Exit status 0: every number holds; 1: some differ, are not covered, or their datasets are
missing (each is listed); 2: bad arguments. Run it whenever a study, a kernel or the findings
change; the cheap studies' part runs in the test suite (``tests/test_findings.py``).
"""
from __future__ import annotations

import argparse
import math
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NUMBERS = ROOT / "tools" / "findings_numbers.yaml"
DOCUMENTS = {"findings": ROOT / "docs" / "findings.md", "readme": ROOT / "README.md"}

#: a number as the documents write it: sign (also U+2212), digits, decimals, exponent
NUMBER = re.compile(r"(?<![\w.·/\u0300-\u036f−-])"     # not inside a name (θ̇1, s-1) or a path
                    r"([−+-]?\d+(?:\.\d+)?(?: \d{3}(?![\d.]))*(?:e[−+-]?\d+)?)"
                    r"(?![\w]|\.\d)")


# --- numbers at their printed digits ---------------------------------------------------------
def plain(printed: str) -> str:
    """A printed number as Python reads it: U+2212 as '-', thin groupings removed."""
    return printed.replace("−", "-").replace(" ", "").lstrip("+")


def matches(printed: str, value: float) -> bool:
    """Whether ``value`` printed with the digits of ``printed`` is ``printed``: ``0.899`` holds
    for 0.8994 and 0.8985, ``1.24e-4`` for 1.2449e-4, ``204`` for 203.6."""
    text = plain(printed)
    if not math.isfinite(value):
        return False
    m = re.fullmatch(r"-?\d+(?:\.(\d+))?(?:e([-+]?\d+))?", text)
    if m is None:
        raise ValueError(f"not a number: {printed!r}")
    decimals = len(m.group(1) or "")
    shown = f"{value:.{decimals}e}" if m.group(2) is not None else f"{value:.{decimals}f}"
    return float(shown) == float(text)


def shown_like(printed: str, value: float) -> str:
    """``value`` with the digits of ``printed`` (for the messages)."""
    text = plain(printed)
    m = re.fullmatch(r"-?\d+(?:\.(\d+))?(e[-+]?\d+)?", text)
    decimals = len(m.group(1) or "") if m else 3
    if not math.isfinite(value):
        return str(value)
    return f"{value:.{decimals}e}" if m and m.group(2) else f"{value:.{decimals}f}"


# --- the documents ------------------------------------------------------------------------------
@dataclass
class Document:
    """A document's prose, its whitespace collapsed, and where each character came from."""

    name: str
    path: Path
    text: str = ""
    lines: list[int] = field(default_factory=list)

    @classmethod
    def read(cls, name: str, path: Path) -> "Document":
        raw = path.read_text()
        raw = re.sub(r"```.*?```", lambda m: "\n" * m.group(0).count("\n"), raw, flags=re.S)
        text, lines, line, space = [], [], 1, False
        for ch in raw:
            if ch.isspace():
                if not space and text:
                    text.append(" ")
                    lines.append(line)
                space = True
                line += ch == "\n"
                continue
            space = False
            text.append(ch)
            lines.append(line)
        return cls(name, path, "".join(text), lines)

    def numbers(self) -> list[tuple[int, str]]:
        """(offset, number) of every number of the prose."""
        return [(m.start(1), m.group(1)) for m in NUMBER.finditer(self.text)]

    def where(self, offset: int) -> str:
        shown = self.path.relative_to(ROOT) if self.path.is_relative_to(ROOT) else self.path
        return f"{shown}:{self.lines[offset]}"


def collapse(text: str) -> str:
    return " ".join(text.split())


# --- the sources --------------------------------------------------------------------------------
@dataclass
class Entry:
    """One passage and the sources of its numbers (``tools/findings_numbers.yaml``)."""

    doc: str
    text: str
    numbers: list[str]
    data: str | None = None
    run: str | None = None
    let: str = ""
    index: int = 0

    @property
    def studies(self) -> set[str]:
        out = set()
        if self.data:
            out.add(self.data.split("/")[0])
        if self.run:
            out |= set(re.findall(r"\{outputs\}/(\w+)", self.run))
        # a dataset named to open() or to a helper of the entry's let: ("<study>/<step>")
        out |= set(re.findall(r"""\w\(["'](\w+)/""", self.let + " ".join(self.numbers)))
        return out

    @property
    def given(self) -> bool:
        return all(n.startswith("#") for n in self.numbers)


def load_entries(path: Path = NUMBERS) -> list[Entry]:
    from ruamel.yaml import YAML

    raw = YAML(typ="safe").load(path.read_text())
    entries = []
    for i, e in enumerate(raw):
        numbers = e["numbers"]
        if isinstance(numbers, str):
            numbers = [numbers]
        entries.append(Entry(e.get("doc", "findings"), collapse(e["text"]),
                             [str(n) for n in numbers], e.get("data"), e.get("run"),
                             e.get("let", ""), i))
    return entries


@dataclass
class Finding:
    where: str
    message: str


def coverage(docs: dict[str, Document], entries: list[Entry]) -> list[Finding]:
    """Every number of every document covered by an entry's passage; every passage found and
    with as many numbers as sources."""
    out = []
    covered = {name: set() for name in docs}
    for e in entries:
        doc = docs[e.doc]
        starts = [m.start() for m in re.finditer(re.escape(e.text), doc.text)]
        label = f"tools/findings_numbers.yaml entry {e.index + 1} ({e.text[:50]!r})"
        if not starts:
            out.append(Finding(label, f"passage not found in {doc.path.name}"))
            continue
        count = len(NUMBER.findall(e.text))
        if count != len(e.numbers):
            out.append(Finding(label, f"{count} numbers in the passage, {len(e.numbers)} "
                                      "sources"))
        for s in starts:
            covered[e.doc].update(range(s, s + len(e.text)))
    for name, doc in docs.items():
        for offset, number in doc.numbers():
            if offset not in covered[name]:
                context = doc.text[max(0, offset - 40):offset + len(number) + 20]
                out.append(Finding(doc.where(offset), f"{number} has no source: ...{context}..."))
    return out


# --- evaluating ---------------------------------------------------------------------------------
class Sources:
    """Opens the datasets and runs the commands the entries name, each once."""

    def __init__(self, outputs: Path):
        self.outputs = outputs
        self._data: dict[str, object] = {}
        self._runs: dict[str, str] = {}

    def open(self, name: str):
        """``<study>/<step>`` (``.nc`` implied) under the outputs folder, loaded."""
        import xarray as xr

        if name not in self._data:
            path = self.outputs / (name if name.endswith(".nc") else name + ".nc")
            with xr.open_dataset(path) as ds:
                self._data[name] = ds.load()
        return self._data[name]

    def run(self, command: str) -> str:
        command = command.replace("{outputs}", str(self.outputs))
        if command not in self._runs:
            words = shlex.split(command)
            if words[0] in ("python", "python3"):
                words[0] = sys.executable
            elif words[0] == "monkeystudy":
                words[:1] = [sys.executable, "-m", "monkeystudy"]
            r = subprocess.run(words, capture_output=True, text=True, cwd=ROOT)
            if r.returncode:
                raise RuntimeError(f"{command}: exit {r.returncode}: {r.stderr[-500:]}")
            self._runs[command] = r.stdout
        return self._runs[command]


def grab(text: str, pattern: str, group: int = 1, index: int = 0) -> float:
    """The number the regular expression ``pattern`` finds in ``text`` (its ``index``-th
    match, its group ``group``)."""
    found = list(re.finditer(pattern, text, flags=re.M))
    if len(found) <= index:
        raise LookupError(f"no match for {pattern!r}")
    return float(plain(found[index].group(group)))


def evaluate(entry: Entry, sources: Sources) -> list[tuple[str, str, object]]:
    """(printed, source, value or the exception) for each number of the entry."""
    import numpy as np

    scope = {"np": np, "open": sources.open, "grab": grab, "math": math, "re": re, "root": ROOT}
    printed = NUMBER.findall(entry.text)
    out = []
    try:
        if entry.data:
            scope["ds"] = sources.open(entry.data)
        if entry.run:
            scope["out"] = sources.run(entry.run)
        if entry.let:
            exec(entry.let, scope)
    except Exception as exc:   # the whole entry cannot be checked: say so for each number
        return [(p, s, exc) for p, s in zip(printed, entry.numbers)]
    for p, source in zip(printed, entry.numbers):
        if source.startswith("#"):
            out.append((p, source, None))
            continue
        expr = source[2:] if source[:2] in ("<=", ">=") else source
        try:
            out.append((p, source, float(eval(expr, scope))))
        except Exception as exc:
            out.append((p, source, exc))
    return out


def holds(printed: str, source: str, value: float) -> bool:
    if source.startswith("<="):
        return value <= float(plain(printed))
    if source.startswith(">="):
        return value >= float(plain(printed))
    return matches(printed, value)


def check(entries: list[Entry], outputs: Path, studies: set[str] | None,
          verbose: bool = False) -> tuple[list[Finding], dict[str, int]]:
    sources = Sources(outputs)
    docs = {name: Document.read(name, path) for name, path in DOCUMENTS.items()}
    findings = coverage(docs, entries)
    counts = {"checked": 0, "given": 0, "not selected": 0}
    for e in entries:
        doc = docs[e.doc]
        start = doc.text.find(e.text)
        where = doc.where(start) if start >= 0 else f"{e.doc}: entry {e.index + 1}"
        if e.given:
            counts["given"] += len(e.numbers)
            continue
        if studies is not None and not e.studies <= studies:
            counts["not selected"] += len(e.numbers)
            continue
        for p, source, value in evaluate(e, sources):
            if value is None:
                counts["given"] += 1
            elif isinstance(value, Exception):
                findings.append(Finding(where, f"{p}: {source}: {type(value).__name__}: "
                                               f"{value}"))
            else:
                counts["checked"] += 1
                if not holds(p, source, value):
                    findings.append(Finding(where, f"{p} in {e.text[:60]!r}...: the code gives "
                                                   f"{shown_like(p, value)} ({value:.6g}; "
                                                   f"{source})"))
                elif verbose:
                    print(f"{where}: {p} = {value:.6g}  ({source})")
    return findings, counts


def cited_studies(entries: list[Entry]) -> list[str]:
    return sorted(set().union(*(e.studies for e in entries)))


def run_studies(names: list[str], outputs: Path) -> None:
    for name in names:
        print(f"run {name}", flush=True)
        r = subprocess.run([sys.executable, "-m", "monkeystudy", "run",
                            str(ROOT / "studies" / f"{name}.yaml"), "-o", str(outputs / name),
                            "-j", "1"], cwd=ROOT)
        if r.returncode:
            raise SystemExit(f"check_findings: {name}: monkeystudy run exit {r.returncode}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--outputs", type=Path, default=ROOT / "outputs",
                    help="the folder holding each study's outputs (default: outputs)")
    ap.add_argument("--studies", help="check only the numbers of these studies "
                                      "(comma-separated names; coverage is always checked)")
    ap.add_argument("--run", action="store_true",
                    help="first run each study checked (monkeystudy run -j 1; a current "
                         "study is not rerun)")
    ap.add_argument("--list", action="store_true", help="print every number checked")
    args = ap.parse_args(argv)
    entries = load_entries()
    every = cited_studies(entries)
    studies = None
    if args.studies:
        studies = set(args.studies.split(","))
        unknown = studies - set(every)
        if unknown:
            ap.error(f"no number cites {sorted(unknown)}; cited: {', '.join(every)}")
    if args.run:
        run_studies(sorted(studies) if studies else every, args.outputs)
    findings, counts = check(entries, args.outputs, studies, verbose=args.list)
    for f in findings:
        print(f"{f.where}: {f.message}")
    print(f"{counts['checked']} numbers hold their source, {len(findings)} problems; "
          f"{counts['given']} are settings or cited values, {counts['not selected']} of "
          f"studies not selected")
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
