"""The dataset layer: each step kind's declared variables (``StepKind.variables``) and
docs/datasets.md, which documents them. The datasets the kinds write are held against the
declarations in each kind's tests (``studyhelpers.assert_written_as_declared``)."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from monkeystudy.study import datasets as D
from monkeystudy.study.steps import REGISTRY

DOC = Path(__file__).resolve().parents[2] / "docs" / "datasets.md"

DECLARING = list(REGISTRY)


def doc_sections(text: str) -> list[tuple[str, str]]:
    """docs/datasets.md as (heading, body) pairs, one per ``##`` or ``###`` heading."""
    parts = re.split(r"^(#{2,3} .*)$", text, flags=re.M)
    return list(zip(parts[1::2], parts[2::2]))


def kind_doc(kind: str) -> str:
    """What docs/datasets.md says of a kind's dataset: its section, its bullets under "Also
    stored by the analysis steps" and, for a kind that runs sequence gaits, the section on
    them."""
    text = DOC.read_text()
    parts = []
    for heading, body in doc_sections(text):
        if re.match(rf"#{{2,3}} `{kind}`", heading):
            parts.append(body)
        elif heading.startswith("### Also stored"):
            parts += [b for b in re.split(r"^- ", body, flags=re.M)
                      if b.startswith(f"`{kind}`")]
        elif heading.startswith("## Sequence gaits") and \
                "sequence" in REGISTRY[kind].gait_kinds:
            parts.append(body)
    assert parts, f"docs/datasets.md has no section on {kind}"
    return "\n".join(parts)


def mentions(doc: str, name: str) -> list[re.Match]:
    """Where ``doc`` names variable ``name`` (```name```, ```name(dims)```; a complex
    variable's parts also as ```<base>_real/imag```)."""
    names = [re.escape(name)]
    if name.endswith("_imag") or name.endswith("_real"):
        names.append(re.escape(name[:-5]) + r"_real/imag")
    return list(re.finditer(rf"`(?:{'|'.join(names)})(?:\([^)`]*\))?`", doc))


def stated_units(doc: str, match: re.Match) -> str | None:
    """The units the doc states for the name at ``match``: the ``[...]`` right after it or
    after the list of names it heads (```a`, `b` [s]``); None when it states none there."""
    rest = doc[match.end():]
    m = re.match(r"(?:,\s*(?:and\s+)?`[^`]+`)*\s*\[([^\]]+)\]", rest)
    return m.group(1).replace("`", "").split(",")[0].strip() if m else None


def test_every_kind_declares_its_variables():
    for name in DECLARING:
        variables = REGISTRY[name].variables
        assert variables, f"{name} declares no variables"
        for var_name, var in variables.items():
            assert isinstance(var, D.Variable), (name, var_name)


@pytest.mark.parametrize("kind", DECLARING)
def test_declared_variables_are_documented_with_their_units(kind):
    doc = kind_doc(kind)
    problems = []
    for name, var in REGISTRY[kind].variables.items():
        found = mentions(doc, name)
        if not found:
            problems.append(f"{name}: not in docs/datasets.md")
            continue
        if "{" in var.units:          # units of the run (a continuation's parameter)
            continue
        for match in found:
            units = stated_units(doc, match)
            if units is not None and units != var.units:
                problems.append(f"{name}: the doc says [{units}], declared {var.units!r}")
    assert not problems, f"{kind}:\n  " + "\n  ".join(problems)


def test_declared_long_names_take_their_fields():
    """Every field of a declared long_name or units is a word of the run, not a stray brace:
    a long_name formats with any text for its fields."""
    from string import Formatter

    for kind in DECLARING:
        for name, var in REGISTRY[kind].variables.items():
            for text in (var.long_name, var.units):
                fields = {f for _, f, _, _ in Formatter().parse(text) if f}
                assert all(re.fullmatch(r"[a-z_]+", f) for f in fields), (kind, name, text)
                text.format(**{f: "x" for f in fields})
