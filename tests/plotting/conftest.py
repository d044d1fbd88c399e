"""Fixtures of the plotting tests: study folders built once per session, copied per test."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import xarray as xr

from plotdata import FAST, build_study, run_runner_study


@pytest.fixture(scope="session")
def runner_built(tmp_path_factory) -> Path:
    return run_runner_study(tmp_path_factory.mktemp("runner") / "plot_runner")


@pytest.fixture
def runner_study_dir(runner_built, tmp_path) -> Path:
    dst = tmp_path / runner_built.name
    shutil.copytree(runner_built, dst, ignore=shutil.ignore_patterns("figures", ".*"))
    return dst


@pytest.fixture(scope="session")
def built_study(tmp_path_factory) -> Path:
    return build_study(tmp_path_factory.mktemp("studies") / "plot_test")


@pytest.fixture
def study_dir(built_study, tmp_path) -> Path:
    """A private copy of the built study folder (datasets only, no figures)."""
    dst = tmp_path / built_study.name
    shutil.copytree(built_study, dst, ignore=shutil.ignore_patterns("figures"))
    return dst


@pytest.fixture(scope="session")
def reported_study(tmp_path_factory, built_study) -> Path:
    """The built study with its full report drawn once per session (do not modify)."""
    from monkeystudy.plotting.report import report_study
    dst = tmp_path_factory.mktemp("reported") / built_study.name
    shutil.copytree(built_study, dst, ignore=shutil.ignore_patterns("figures"))
    report_study(dst, **FAST)
    return dst


@pytest.fixture
def reported_copy(reported_study, tmp_path) -> Path:
    """A private copy of the reported study (datasets, figures and manifest, mtimes kept)."""
    dst = tmp_path / reported_study.name
    shutil.copytree(reported_study, dst)
    return dst


@pytest.fixture
def datasets(built_study):
    """The built study's datasets opened with xarray, by step name."""
    out = {}
    for p in sorted(built_study.glob("*.nc")):
        with xr.open_dataset(p) as ds:
            out[p.stem] = ds.load()
    return out
