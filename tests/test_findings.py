"""docs/findings.md and the README's findings print what the code gives (tools/check_findings.py).

Every number of the two documents has a source in ``tools/findings_numbers.yaml``: the
coverage is checked here whole. The numbers of the studies that run in seconds are checked
against a run of those studies; the rest (``open_loop_design``, ``robust_design``,
``survival``, ``two_step``, ...: up to minutes each) by ``python tools/check_findings.py --run``
(pipeline/README.md), whenever a study, a kernel or the findings change.
"""
from __future__ import annotations

from pathlib import Path

import pytest

from toolmodules import load_tool

ROOT = Path(__file__).resolve().parents[1]


cf = load_tool("check_findings")

#: the cited studies that run in seconds once compiled (the rest take minutes)
CHEAP = ("horizontal", "smoke", "exact_gait", "two_swing", "flight_gait", "climbing_gait",
         "asymmetric_gait", "wide_high_dtheta2", "wide_low_dtheta2")


def test_numbers_are_compared_at_their_printed_digits():
    assert cf.matches("0.899", 0.8994) and cf.matches("0.899", 0.89851)
    assert not cf.matches("0.899", 0.8996)
    assert cf.matches("1.24e-4", 1.2449e-4) and not cf.matches("1.24e-4", 1.2349e-4)
    assert cf.matches("−1.375", -1.3752) and cf.matches("+5.8", 5.84)
    assert cf.matches("204", 203.6) and not cf.matches("204", 203.4)
    assert cf.matches("24 321", 24321.0)
    assert not cf.matches("0", float("nan"))


def test_every_number_of_the_documents_has_a_source():
    docs = {name: cf.Document.read(name, path) for name, path in cf.DOCUMENTS.items()}
    problems = cf.coverage(docs, cf.load_entries())
    assert not problems, "\n".join(f"{p.where}: {p.message}" for p in problems)


def test_a_number_without_a_source_is_found(tmp_path):
    path = tmp_path / "doc.md"
    path.write_text("The gait lasts 51 cycles (the 2009 study: 12).\n\n```text\n7\n```\n")
    doc = cf.Document.read("findings", path)
    assert [n for _, n in doc.numbers()] == ["51", "2009", "12"]
    entry = cf.Entry("findings", "the 2009 study: 12", ["# year", "# cited"])
    problems = cf.coverage({"findings": doc}, [entry])
    assert [p.message.split()[0] for p in problems] == ["51"]


@pytest.fixture(scope="module")
def cheap_outputs(tmp_path_factory):
    from monkeystudy.study import load_study, run_study

    out = tmp_path_factory.mktemp("findings")
    for name in CHEAP:
        run_study(load_study(ROOT / "studies" / f"{name}.yaml"), out / name, workers=1)
    return out


def test_the_cheap_studies_numbers_hold(cheap_outputs):
    entries = cf.load_entries()
    assert set(CHEAP) <= set(cf.cited_studies(entries))
    problems, counts = cf.check(entries, cheap_outputs, set(CHEAP))
    assert counts["checked"] > 0
    assert not problems, "\n".join(f"{p.where}: {p.message}" for p in problems)
