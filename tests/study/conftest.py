"""Fixtures of the study tests."""
from __future__ import annotations

import pytest

from studyhelpers import TINY_FILES, write_study


@pytest.fixture(scope="session")
def tiny_reference(tmp_path_factory):
    """The tiny study run once on 2 local workers: (study path, output folder)."""
    from monkeystudy.study import load_study, run_study

    root = tmp_path_factory.mktemp("tiny_ref")
    study = write_study(root)
    out = root / "out"
    summary = run_study(load_study(study), out, workers=2)
    assert sorted(p.name for p in summary.written) == sorted(TINY_FILES)
    return study, out
