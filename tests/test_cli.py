"""The command line end to end: the smoke study through ``monkeystudy run``, exit codes,
validate, inspect, schema, report, dry run."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner

from monkeystudy.cli import app

ROOT = Path(__file__).resolve().parents[1]
SMOKE = ROOT / "studies" / "smoke.yaml"

GLOBAL_ATTRS = ("study_name", "step_name", "step_kind", "study_text", "study_sha256",
                "step_sha256", "robot",
                "gait", "integrator", "monkeystudy_version", "git_revision",
                "library_versions", "history", "Conventions")

VARIABLES = {
    "grid": ("dtheta1", "dtheta2", "error", "status", "t_switch", "t_motor", "t_end", "steps",
             "nfev", "rejected"),
    "refine": ("dtheta1", "dtheta2", "error", "status", "t_switch", "t_motor", "t_end",
               "iterate_dtheta1", "iterate_dtheta2", "iterate_error", "iterate_nfev"),
    "stability": ("error", "kinetic_energy", "pivot_height", "x_advance", "t_cross", "status",
                  "time", "A", "joint", "B", "phase", "motor_torque"),
}


@pytest.fixture
def runner():
    return CliRunner()


@pytest.fixture(scope="module")
def smoke_out(tmp_path_factory):
    out = tmp_path_factory.mktemp("smoke") / "out"
    result = CliRunner().invoke(app, ["run", str(SMOKE), "--out", str(out), "--workers", "2"])
    assert result.exit_code == 0, result.output
    return out, result


def test_smoke_study_end_to_end(smoke_out):
    out, result = smoke_out
    names = {p.stem for p in out.glob("*.nc")}
    assert names == {"coarse_map", "gait1", "minima", "gait1_cycles", "minima_cycles"}
    assert "wrote" in result.stdout
    assert not list(out.glob(".*"))                  # no shards or temp files left
    text = SMOKE.read_text()
    for path in out.glob("*.nc"):
        with xr.open_dataset(path) as ds:
            for a in GLOBAL_ATTRS:
                assert a in ds.attrs, (path.name, a)
            assert ds.attrs["study_text"] == text
            assert json.loads(ds.attrs["gait"])["motor_torque"] == 0.6354
            for v in VARIABLES[ds.attrs["step_kind"]]:
                assert v in ds.variables, (path.name, v)
            for v in ds.variables:
                assert {"units", "long_name"} <= set(ds[v].attrs), (path.name, v)
    with xr.open_dataset(out / "coarse_map.nc") as ds:
        assert ds["error"].shape == (9, 11)
        assert np.isfinite(ds["error"]).any()
    with xr.open_dataset(out / "gait1_cycles.nc") as ds:
        assert int(ds["status"]) == 0 and ds.sizes["cycle"] == 4


def test_rerun_is_up_to_date(smoke_out, runner):
    out, _ = smoke_out
    result = runner.invoke(app, ["run", str(SMOKE), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "up to date" in result.output and "wrote" not in result.stdout


def test_inspect(smoke_out, runner):
    out, _ = smoke_out
    for name, needle in (("coarse_map", "least error"), ("minima", "start 1:"),
                         ("gait1_cycles", "cycles completed")):
        result = runner.invoke(app, ["inspect", str(out / f"{name}.nc")])
        assert result.exit_code == 0, result.output
        assert needle in result.stdout and "summary:" in result.stdout


def test_validate_ok_and_invalid(runner, tmp_path):
    result = runner.invoke(app, ["validate", str(SMOKE)])
    assert result.exit_code == 0 and "ok" in result.stdout
    bad = tmp_path / "bad.yaml"
    bad.write_text(SMOKE.read_text().replace("num: 9", "num: 0"))
    result = runner.invoke(app, ["validate", str(bad)])
    assert result.exit_code == 2
    assert f"{bad}:13: steps[0].dtheta1.num: must be >= 1, got 0" in result.output
    result = runner.invoke(app, ["run", str(bad), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and not (tmp_path / "o").exists()


def test_every_shipped_study_is_valid(runner):
    for study in sorted((ROOT / "studies").glob("*.yaml")):
        result = runner.invoke(app, ["validate", str(study)])
        assert result.exit_code == 0, result.output


def test_invalid_input_exit_codes(runner, tmp_path):
    assert runner.invoke(app, ["run", str(tmp_path / "missing.yaml")]).exit_code == 2
    assert runner.invoke(app, ["run", str(SMOKE), "--workers", "0"]).exit_code == 2
    assert runner.invoke(app, ["inspect", str(tmp_path / "missing.nc")]).exit_code == 2
    (tmp_path / "junk.nc").write_text("not netcdf")
    assert runner.invoke(app, ["inspect", str(tmp_path / "junk.nc")]).exit_code == 2


def test_dry_run_lists_blocks_and_does_nothing(runner, tmp_path):
    out = tmp_path / "never"
    result = runner.invoke(app, ["run", str(SMOKE), "--out", str(out), "--dry-run"])
    assert result.exit_code == 0, result.output
    assert "coarse_map [grid] -> coarse_map.nc: 9 of 9 blocks to do" in result.stdout
    assert "b000000..b000008" in result.stdout
    assert "minima [refine] -> minima.nc: 2 tasks after coarse_map" in result.stdout
    assert "nothing was run" in result.stdout
    assert not out.exists()


def test_schema_command_prints_the_shipped_schema(runner):
    result = runner.invoke(app, ["schema"])
    assert result.exit_code == 0
    shipped = ROOT / "src" / "monkeystudy" / "schema" / "study.schema.json"
    assert json.loads(result.stdout) == json.loads(shipped.read_text())


def test_report_refuses_what_it_cannot_draw(runner, tmp_path):
    """A missing folder, a folder without datasets, an unknown format: exit 2, a clear line,
    nothing written."""
    res = runner.invoke(app, ["report", str(tmp_path / "missing")])
    assert res.exit_code == 2 and "no such folder" in res.output
    res = runner.invoke(app, ["report", str(tmp_path)])
    assert res.exit_code == 2 and "holds no study datasets" in res.output
    res = runner.invoke(app, ["report", str(tmp_path), "--formats", "png,bmp"])
    assert res.exit_code == 2 and "bmp not among png, pdf, svg" in res.output
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["run", "validate"])
def test_a_missing_study_file_names_the_closest_study_files(runner, command, monkeypatch):
    monkeypatch.chdir(ROOT)
    res = runner.invoke(app, [command, "studies/horizontl.yaml"])
    assert res.exit_code == 2
    assert res.output.strip() == ("studies/horizontl.yaml: no such file; did you mean "
                                  "studies/horizontal.yaml?")
    res = runner.invoke(app, [command, "studies/zzz_nothing_like_it.yaml"])
    assert res.exit_code == 2
    assert res.output.strip() == "studies/zzz_nothing_like_it.yaml: no such file"


def test_inspect_on_a_study_file_points_to_validate_and_its_outputs(runner, monkeypatch):
    monkeypatch.chdir(ROOT)
    res = runner.invoke(app, ["inspect", "studies/horizontal.yaml"])
    assert res.exit_code == 2
    assert "NetCDF" not in res.output
    assert res.output.strip() == (
        "studies/horizontal.yaml: a study file, not a dataset: 'monkeystudy validate "
        "studies/horizontal.yaml' checks it; 'monkeystudy inspect outputs/horizontal' "
        "summarises the datasets its run writes there")


def test_run_says_what_it_does_before_the_simulator_loads(runner, tmp_path):
    # the simulator's code takes seconds to load: the first words come before it, and a bad
    # study's located error after them
    bad = tmp_path / "bad.yaml"
    bad.write_text(SMOKE.read_text().replace("schema_version: 1", "schema_version: 1\nbogus: 1"))
    result = runner.invoke(app, ["run", str(bad), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    lines = result.output.splitlines()
    assert lines[0] == f"{bad}: loading the simulator to check the study"
    assert any("bogus" in line for line in lines[1:])
