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


@pytest.fixture(scope="session")
def analysis_smoke(tmp_path_factory):
    """The analysis smoke study through ``monkeystudy run`` on 2 workers: (output folder, the
    CLI's result)."""
    from click.testing import CliRunner

    from monkeystudy.cli import app
    from studyhelpers import ANALYSIS_SMOKE

    out = tmp_path_factory.mktemp("analysis_smoke") / "out"
    result = CliRunner().invoke(app, ["run", str(ANALYSIS_SMOKE), "--out", str(out),
                                      "--workers", "2"])
    assert result.exit_code == 0, result.output
    return out, result


@pytest.fixture(scope="session")
def route_study(tmp_path_factory):
    """The small atlas and route study (tests/study/steps/routestudy.py) run once on 2 local
    workers: (study path, output folder)."""
    from monkeystudy.study import load_study, run_study
    from steps.routestudy import ROUTE_STUDY

    root = tmp_path_factory.mktemp("route_study")
    study = write_study(root, ROUTE_STUDY, "route_small.yaml")
    out = root / "out"
    summary = run_study(load_study(study), out, workers=2)
    assert sorted(p.name for p in summary.written) == ["atlas.nc", "route.nc"]
    return study, out
