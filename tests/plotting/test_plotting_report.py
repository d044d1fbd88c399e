"""report_study: every figure the datasets support, valid files with provenance, incremental."""
from __future__ import annotations

import json
import re

import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from PIL import Image

from monkeystudy.plotting.page import PAGE
from monkeystudy.plotting.report import (
    MANIFEST, NoStudyDatasets, ReportError, StudyIncomplete, report_study,
)

from plotdata import FAST, write_nc

REPO = Path(__file__).resolve().parents[2]

STILLS = ["error_map_surface", "error_map_map", "error_map_swap_time", "refine_1_convergence",
          "refine_2_convergence", "stability_error_comparison"] + [
    f"stability_{i}_{what}" for i in (1, 2)
    for what in ("error", "kinetic_energy", "height", "filmstrip")]
ANIMATIONS = ["stability_1_animation", "stability_2_animation"]


def mtimes(folder: Path) -> dict[str, int]:
    return {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}


def assert_png(path: Path, sha: str):
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with Image.open(path) as im:
        im.verify()
    with Image.open(path) as im:
        assert im.size[0] > 300 and im.size[1] > 200
        assert im.text.get("study_sha256") == sha
        assert im.text.get("monkeystudy_version")
        assert "git_revision" in im.text


def assert_pdf(path: Path, sha: str):
    data = path.read_bytes()
    assert data[:5] == b"%PDF-" and b"%%EOF" in data[-64:]
    assert f"study_sha256={sha}".encode() in data        # Keywords / Subject of the info dict


def test_the_report_table_lists_every_declared_figure():
    """The figure table of plotting/report.py's docstring names each figure every step kind
    declares (``<kind>_<suffix>``, or ``kind_suffix`` for a figure across steps), no more."""
    from monkeystudy.plotting import report as R
    from monkeystudy.study.steps import REGISTRY

    table = re.search(r"^=+  =+  =+$(.*)^=+  =+  =+$", R.__doc__, re.M | re.S).group(1)
    listed = set()
    for name in re.findall(r"^``([^`]+)``", table, re.M):
        step = re.fullmatch(r"<(\w+)>_(\w+)", name)
        if step:
            listed.add((*step.groups(), False))
        else:
            kind = next(k for k in REGISTRY if name.startswith(k + "_"))
            listed.add((kind, name[len(kind) + 1:], True))
    assert listed == {(name, f.suffix, f.across) for name, kind in REGISTRY.items()
                      for f in kind.figures}


def test_the_package_exports_the_plot_function_of_every_kind():
    """Every ``plot_*`` function of a kind's plotting module is a name of
    :mod:`monkeystudy.plotting`."""
    import importlib
    import inspect

    import monkeystudy.plotting as plotting
    from monkeystudy.study.steps import REGISTRY

    for name in REGISTRY:
        module = importlib.import_module(f"monkeystudy.plotting.kinds.{name}")
        for fname, f in inspect.getmembers(module, inspect.isfunction):
            if fname.startswith("plot_") and f.__module__ == module.__name__:
                assert getattr(plotting, fname, None) is f, (name, fname)


def test_report_writes_every_figure_with_provenance(reported_study):
    figs = reported_study / "figures"
    expected = {f"{n}.{e}" for n in STILLS for e in ("png", "pdf")}
    expected |= {f"{n}.mp4" for n in ANIMATIONS}
    assert expected <= set(os.listdir(figs))
    sha = xr.open_dataset(reported_study / "error_map.nc").attrs["study_sha256"]
    for name in expected:
        p = figs / name
        assert p.stat().st_size > 1000, p
        if p.suffix == ".png":
            assert_png(p, sha)
        elif p.suffix == ".pdf":
            assert_pdf(p, sha)
        else:
            assert p.read_bytes()[4:8] == b"ftyp"                # an MP4 container
    assert (figs / MANIFEST).exists()


def test_report_returns_the_written_paths(reported_study, study_dir):
    would = report_study(study_dir, dry_run=True, **FAST)
    assert not (study_dir / "figures").exists()          # a dry run writes nothing
    figs = reported_study / "figures"
    on_disk = {p.name for p in figs.iterdir()} - {MANIFEST}
    assert {p.name for p in would} == on_disk
    assert all(p.parent == study_dir / "figures" for p in would)


def test_second_report_changes_nothing(reported_copy):
    before = mtimes(reported_copy / "figures")
    assert report_study(reported_copy, **FAST) == []
    assert mtimes(reported_copy / "figures") == before


def test_only_figures_of_a_changed_dataset_are_redrawn(reported_copy):
    figs = reported_copy / "figures"
    before = mtimes(figs)
    with xr.open_dataset(reported_copy / "error_map.nc") as ds:
        changed = ds.load()
    changed["error"] = changed["error"] * 2.0
    write_nc(changed, reported_copy / "error_map.nc")
    written = {p.name for p in report_study(reported_copy, **FAST)}
    assert written == {f"error_map_{w}.{e}" for w in ("surface", "map", "swap_time")
                       for e in ("png", "pdf")} | {PAGE}   # the page: its key numbers changed
    after = mtimes(figs)
    untouched = [n for n in before if n not in written and n != MANIFEST]
    assert len(untouched) > 20 and all(after[n] == before[n] for n in untouched)


def test_stability_figures_depend_on_their_run_only(reported_copy):
    from monkeystudy.plotting.report import plan
    jobs = {j.name: [p.name for p in j.inputs] for j in plan(reported_copy)}
    assert jobs["stability_2_error"] == ["stability_2.nc", "refine_2.nc"]  # refine: the gait
    assert jobs["error_map_surface"] == ["error_map.nc"]
    assert set(jobs["stability_error_comparison"]) >= {"stability_1.nc", "stability_2.nc"}


def test_a_missing_figure_file_is_redrawn_alone(reported_copy):
    (reported_copy / "figures" / "error_map_map.pdf").unlink()
    written = report_study(reported_copy, **FAST)
    assert {p.name for p in written} == {"error_map_map.png", "error_map_map.pdf"}


def test_force_redraws_everything(reported_copy):
    would = report_study(reported_copy, force=True, dry_run=True, **FAST)
    assert len(would) == 2 * len(STILLS) + len(ANIMATIONS) + 1     # + the page


def test_a_broken_dataset_fails_alone(reported_copy):
    with xr.open_dataset(reported_copy / "error_map.nc") as ds:
        broken = ds.load().drop_vars("status")
    write_nc(broken, reported_copy / "error_map.nc")
    before = mtimes(reported_copy / "figures")
    with pytest.raises(ReportError) as exc:
        report_study(reported_copy, **FAST)
    assert set(exc.value.failures) == {"error_map_surface", "error_map_map",
                                       "error_map_swap_time"}
    # nothing else read that dataset; the page says its key numbers are unavailable
    assert exc.value.written == [reported_copy / "figures" / PAGE]
    assert "key numbers unavailable" in (reported_copy / "figures" / PAGE).read_text()
    after = mtimes(reported_copy / "figures")
    assert {n: t for n, t in after.items() if n != PAGE} == \
        {n: t for n, t in before.items() if n != PAGE}
    # the failed figures are retried next time (and fail again), nothing else is redone
    with pytest.raises(ReportError) as again:
        report_study(reported_copy, **FAST)
    assert set(again.value.failures) == {"error_map_surface", "error_map_map",
                                         "error_map_swap_time"}


def test_datasets_of_other_step_kinds_are_left_alone(reported_copy):
    # a kind without figures, with a 'cycle' dim that is not a stability run (the analysis
    # kinds have their own figures: test_plotting_analysis.py)
    other = xr.Dataset({"error": (("tick", "cycle"), np.ones((2, 3)))},
                       coords={"tick": [0.0, 0.001], "cycle": [1, 2, 3]},
                       attrs={"step_kind": "some_future_kind", "step_name": "sweep"})
    write_nc(other, reported_copy / "sweep.nc")
    assert report_study(reported_copy, **FAST) == []


def test_figures_of_a_deleted_dataset_are_removed(reported_copy):
    figs = reported_copy / "figures"
    (reported_copy / "refine_1.nc").unlink()
    (reported_copy / "stability_1.nc").unlink()
    with pytest.raises(StudyIncomplete) as err:     # the study has steps without a dataset
        report_study(reported_copy, animation=False, **FAST)   # animations: kept
    assert err.value.missing == ["refine_1", "stability_1"] and not err.value.failed
    names = set(os.listdir(figs))
    assert not {n for n in names if n.startswith(("refine_1_", "stability_1_"))}
    assert {"refine_2_convergence.png", "stability_2_animation.mp4"} <= names
    assert "stability_error_comparison.png" not in names    # one run left: no comparison


def test_empty_folder_is_refused_and_names_the_study_folders_below(tmp_path, reported_copy):
    """Nothing to report is an error, not a silent success; on the parent of study folders
    (an easy mistake) the message names them."""
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(NoStudyDatasets, match="holds no study datasets") as err:
        report_study(empty)
    assert "below it" not in str(err.value)
    with pytest.raises(NoStudyDatasets, match=re.escape(str(reported_copy))):
        report_study(reported_copy.parent)
    assert not (empty / "figures").exists()


def test_two_datasets_never_draw_one_figure_file(study_dir):
    """A basin step ``b`` and a grid step ``b_cycles`` would both draw ``b_cycles_map`` (a
    study file refuses such names; a folder can still hold such datasets, say of an older
    study): the report refuses before drawing anything and names both."""
    from monkeystudy.plotting.report import FigureNameClash, plan

    (study_dir / "error_map.nc").rename(study_dir / "b_cycles.nc")
    basin = xr.Dataset({"cycles": (("d_dtheta1", "d_dtheta2"), np.ones((2, 2), np.int32))},
                       attrs={"step_kind": "basin", "step_name": "b"})
    write_nc(basin, study_dir / "b.nc")
    with pytest.raises(FigureNameClash, match=r"figure b_cycles_map would be drawn from "
                       r"b_cycles.nc \(its grid figure map\) and from b.nc \(its basin "
                       r"figure cycles_map\)"):
        plan(study_dir)
    with pytest.raises(FigureNameClash):
        report_study(study_dir, **FAST)
    assert not (study_dir / "figures").exists()


def test_every_step_of_the_study_is_listed_with_what_became_of_it(reported_copy):
    """A step whose run failed, one not run because of it (their failure markers) and one
    without a dataset or a marker: the page and the log list each with what became of it,
    the other steps' figures are all there, and the report says the study is incomplete:
    exit 1 while a step failed, 3 when steps are only still to run."""
    from click.testing import CliRunner

    from monkeystudy.cli import app
    from monkeystudy.study.failures import StepFailure, write_failure

    text = xr.open_dataset(reported_copy / "error_map.nc").attrs["study_text"]
    for name in ("refine_2", "stability_2", "stability_1"):
        (reported_copy / f"{name}.nc").unlink()
    why = "refine_2: the refinement found nothing"
    write_failure(reported_copy, StepFailure("refine_2", "refine", "failed", why, "plot_test",
                                             text, "2999-01-01T00:00:00+00:00"))
    write_failure(reported_copy, StepFailure("stability_2", "stability", "not_run",
                                             "step 'refine_2', which it depends on, failed",
                                             "plot_test", text, "2999-01-01T00:00:00+00:00"))
    lines: list[str] = []
    with pytest.raises(StudyIncomplete) as err:
        report_study(reported_copy, animation=False, progress=lines.append, **FAST)
    assert err.value.failed == {
        "refine_2": f"failed: {why}",
        "stability_2": "not run: step 'refine_2', which it depends on, failed"}
    assert err.value.missing == ["stability_1"]
    assert f"step refine_2: failed: {why}" in lines
    assert "step stability_2: not run: step 'refine_2', which it depends on, failed" in lines
    assert any(x.startswith("step stability_1: no dataset") for x in lines)
    assert lines[-1].endswith("3 steps without a current dataset")
    page = (reported_copy / "figures" / PAGE).read_text().replace("&#x27;", "'")
    for name in ("error_map", "refine_1", "refine_2", "stability_1", "stability_2"):
        assert f'<h3 id="step-{name}">' in page, name
    assert f'<p class="failed">failed: {why}.</p>' in page
    assert "not run: step 'refine_2', which it depends on, failed." in page
    assert "3 of 5 steps have no dataset" in page
    assert (reported_copy / "figures" / "refine_1_convergence.png").exists()
    res = CliRunner().invoke(app, ["report", str(reported_copy), "--no-animation"])
    assert res.exit_code == 1 and "the study is incomplete: 2 steps failed" in res.output
    (reported_copy / "refine_2.failed.json").unlink()
    (reported_copy / "stability_2.failed.json").unlink()
    res = CliRunner().invoke(app, ["report", str(reported_copy), "--no-animation"])
    assert res.exit_code == 3, res.output
    assert "3 steps without a dataset (refine_2, stability_1, stability_2): run the study" \
        in res.output


def test_a_folder_whose_every_step_failed_gets_a_page_saying_why(tmp_path):
    """No dataset, only the failure markers of the last run: the page lists the study's
    steps and why each has no dataset; exit 1 (not the "no datasets" refusal, exit 2)."""
    from click.testing import CliRunner

    from monkeystudy.cli import app
    from monkeystudy.study.failures import StepFailure, write_failure

    text = TINY
    write_failure(tmp_path, StepFailure("m", "grid", "failed", "task b000000 failed: "
                                        "MemoryError: ", "tiny", text))
    write_failure(tmp_path, StepFailure("g", "refine", "failed", "task 0 failed: "
                                        "MemoryError: ", "tiny", text))
    write_failure(tmp_path, StepFailure("c", "stability", "not_run", "step 'g', which it "
                                        "depends on, failed", "tiny", text))
    res = CliRunner().invoke(app, ["report", str(tmp_path), "--no-animation"])
    assert res.exit_code == 1, res.output
    assert "step m: failed: task b000000 failed: MemoryError" in res.output
    page = (tmp_path / "figures" / PAGE).read_text()
    assert "3 of 3 steps have no dataset" in page and "<code>tiny</code>" in page


# --- datasets written by the real study runner ---------------------------------------------
def test_report_on_runner_datasets(runner_study_dir):
    written = report_study(runner_study_dir, formats=("png",), **FAST)   # GIFs: 2 + 1 s
    names = {p.name for p in written}
    for stem in ("coarse_map_surface", "coarse_map_map", "gait1_convergence",
                 "minima_convergence", "gait1_cycles_error", "gait1_cycles_height",
                 "gait1_cycles_kinetic_energy", "gait1_cycles_filmstrip",
                 "minima_cycles_error", "minima_cycles_filmstrip", "stability_error_comparison"):
        assert f"{stem}.png" in names, stem
    assert {"gait1_cycles_animation.mp4", "minima_cycles_animation.mp4"} <= names
    assert report_study(runner_study_dir, formats=("png",), **FAST) == []


def test_runner_multi_start_minima_are_all_marked(runner_study_dir):
    from monkeystudy.plotting import plot_error_map
    d = {p.stem: xr.open_dataset(p).load() for p in runner_study_dir.glob("*.nc")}
    fig = plot_error_map(d["coarse_map"], [d["gait1"], d["minima"]])
    marked = {a.get_gid(): a for a in fig.findobj() if str(a.get_gid()).startswith("minimum_")}
    lo1, hi1 = d["coarse_map"]["dtheta1"].values[[0, -1]]
    lo2, hi2 = d["coarse_map"]["dtheta2"].values[[0, -1]]
    for i in range(d["minima"].sizes["start"]):
        m = d["minima"].isel(start=i)
        x, y = float(m["dtheta1"]), float(m["dtheta2"])
        if lo1 <= x <= hi1 and lo2 <= y <= hi2:
            line = marked[f"minimum_minima #{i + 1}"]
            assert (line.get_xdata()[0], line.get_ydata()[0]) == pytest.approx((x, y))


# --- the pipeline ------------------------------------------------------------------------------
TINY = """\
schema_version: 1
name: tiny
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
integrator: {method: dop853, rtol: 1.0e-8, atol: 1.0e-10, max_time: 3.0}
steps:
  - {name: m, kind: grid, dtheta1: {start: 0.5, stop: 1.5, num: 4},
     dtheta2: {start: 10.0, stop: 12.0, num: 5}}
  - {name: g, kind: refine, start: [0.9, 11.0], maxiter: 10}
  - {name: c, kind: stability, from: g, cycles: 2}
"""


def build(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(REPO / "pipeline" / "build.py"), *args],
                          capture_output=True, text=True, cwd=REPO, timeout=600)


def test_pipeline_builds_then_has_nothing_to_do(tmp_path):
    pytest.importorskip("monkeystudy.study.runner")
    study = tmp_path / "tiny.yaml"
    study.write_text(TINY)
    out = tmp_path / "out"
    dry = build("--studies", str(study), "--out", str(out), "--dry-run")
    assert dry.returncode == 0, dry.stdout + dry.stderr
    assert "missing or stale" in dry.stdout and not out.exists()
    first = build("--studies", str(study), "--out", str(out), "--no-animation",
                  "--formats", "png")
    assert first.returncode == 0, first.stdout + first.stderr
    figs = out / "tiny" / "figures"
    assert {"m_map.png", "m_surface.png", "c_error.png", "c_filmstrip.png"} <= set(
        os.listdir(figs))
    before = mtimes(figs) | {p.name: p.stat().st_mtime_ns for p in (out / "tiny").glob("*.nc")}
    second = build("--studies", str(study), "--out", str(out), "--no-animation",
                   "--formats", "png")
    assert second.returncode == 0, second.stdout + second.stderr
    assert "all 3 datasets up to date" in second.stdout and "wrote 0 files" in second.stdout
    after = mtimes(figs) | {p.name: p.stat().st_mtime_ns for p in (out / "tiny").glob("*.nc")}
    assert after == before


def test_report_command_says_what_it_did(reported_copy, monkeypatch):
    """``monkeystudy report``: a line per figure, then "up to date" when nothing changed;
    --force redraws; a figure that fails exits 1 and names it, the others are kept."""
    from click.testing import CliRunner

    from monkeystudy.cli import app
    from monkeystudy.plotting import report as R

    runner = CliRunner()
    res = runner.invoke(app, ["report", str(reported_copy), "--no-animation"])
    assert res.exit_code == 0, res.output
    assert "error_map_map: up to date" in res.output
    assert res.output.strip().splitlines()[-1].endswith(f"up to date ({len(R.plan(reported_copy, animation=False))} figures, {reported_copy / 'figures' / PAGE})")
    res = runner.invoke(app, ["report", str(reported_copy), "--force", "--no-animation",
                              "--formats", "png"])
    assert res.exit_code == 0, res.output
    assert "error_map_map: drawing" in res.output and "drew" in res.output.splitlines()[-1]

    def broken(d):
        raise RuntimeError("a broken figure")
    monkeypatch.setitem(R.DRAWINGS, ("grid", "surface"),
                        replace(R.DRAWINGS[("grid", "surface")], draw=broken))
    res = runner.invoke(app, ["report", str(reported_copy), "--force", "--no-animation",
                              "--formats", "png"])
    assert res.exit_code == 1
    assert "error_map_surface: RuntimeError: a broken figure" in res.output
    assert (reported_copy / "figures" / "error_map_map.png").exists()


def test_the_page_links_only_to_files_that_exist(reported_study):
    """Every ``href`` and ``src`` of figures/index.html resolves to a file of the study folder
    (figures beside the page, datasets one folder up) or to an anchor of the page; every
    figure on disk is on the page, with its drawing's caption."""
    from monkeystudy.plotting.report import DRAWINGS

    figs = reported_study / "figures"
    text = (figs / PAGE).read_text()
    links = re.findall(r'(?:href|src)="([^"]+)"', text)
    assert links
    anchors = set(re.findall(r'id="([^"]+)"', text))
    for link in links:
        if link.startswith("#"):
            assert link[1:] in anchors, link
            continue
        assert "://" not in link and not link.startswith("/"), link   # self-contained
        assert (figs / link).resolve().is_file(), link
    assert {f"../{p.name}" for p in reported_study.glob("*.nc")} <= set(links)
    for p in figs.glob("*.png"):
        assert p.name in links, p.name
    captions = [how.caption for how in DRAWINGS.values()]
    assert sum(c in text.replace("&#x27;", "'") for c in captions) >= 5


# --- figures with nothing to show, interruptions, workers, progress -------------------------
def test_a_figure_with_nothing_to_show_is_skipped_with_its_reason(reported_copy, monkeypatch):
    """A drawing that raises NothingToDraw is skipped, not failed: the log line and the page
    say why, its earlier files are removed, and the next report finds it up to date."""
    from monkeystudy.plotting import report as R
    from monkeystudy.plotting.drawing import NothingToDraw

    def nothing(d):
        raise NothingToDraw("no swap time in this test")
    how = R.DRAWINGS[("grid", "swap_time")]
    monkeypatch.setitem(R.DRAWINGS, ("grid", "swap_time"),
                        replace(how, draw=nothing))
    figs = reported_copy / "figures"
    assert (figs / "error_map_swap_time.png").exists()
    lines: list[str] = []
    report_study(reported_copy, force=True, animation=False, formats=("png",),
                 progress=lines.append)
    assert any(line.endswith("error_map_swap_time: skipped: no swap time in this test")
               for line in lines)
    assert "1 skipped (nothing to show)" in lines[-1]
    assert not list(figs.glob("error_map_swap_time.*"))
    entry = json.loads((figs / MANIFEST).read_text())["figures"]["error_map_swap_time"]
    assert entry["skipped"] == "no swap time in this test" and entry["outputs"] == []
    page = (figs / PAGE).read_text()
    assert 'id="error_map_swap_time" class="skipped"' in page
    assert "not drawn, no swap time in this test." in page
    assert report_study(reported_copy, animation=False, formats=("png",)) == []


def test_an_interrupted_report_leaves_no_half_written_file_and_resumes(study_dir,
                                                                       monkeypatch):
    """Ctrl-C while a figure is being written: that file is not left half-written, the
    figures finished before are in the manifest, and the next report draws only the rest."""
    from matplotlib.figure import Figure

    from monkeystudy.plotting.report import ReportInterrupted

    real = Figure.savefig
    calls = []

    def savefig(self, fname, *args, **kwargs):
        calls.append(fname)
        if len(calls) == 4:                 # mid-write: some bytes out, then Ctrl-C
            Path(fname).write_bytes(b"\x89PNG half")
            raise KeyboardInterrupt
        return real(self, fname, *args, **kwargs)
    monkeypatch.setattr(Figure, "savefig", savefig)
    with pytest.raises(ReportInterrupted) as exc:
        report_study(study_dir, animation=False, formats=("png",), workers=1)
    figs = study_dir / "figures"
    names = {p.name for p in figs.iterdir()}
    assert not [n for n in names if n.startswith(".")], names        # no temporary file
    done = json.loads((figs / MANIFEST).read_text())["figures"]
    assert len(done) == 3 and exc.value.written
    assert {f"{n}.png" for n in done} == names - {MANIFEST}
    monkeypatch.setattr(Figure, "savefig", real)
    written = report_study(study_dir, animation=False, formats=("png",), workers=1)
    assert not {p.stem for p in written} & set(done)                 # only the rest redrawn
    assert len(json.loads((figs / MANIFEST).read_text())["figures"]) == len(STILLS)


@pytest.mark.parametrize("deaf", [False, True], ids=["stops_on_sigterm", "killed"])
def test_ctrl_c_stops_the_drawing_processes_and_their_files(study_dir, monkeypatch, deaf):
    """With figures drawn on worker processes, Ctrl-C (SIGINT to the report) stops them all:
    the file a worker was writing is removed, and no worker is left running -- also one that
    does not answer SIGTERM (``deaf``: as if stuck in native code), killed after the grace."""
    import signal
    import threading
    import time

    from monkeystudy.plotting import report as R
    from monkeystudy.plotting.common import atomic_path

    started = study_dir / "started"

    def slow(d):                    # a drawing caught in the middle of writing its file
        if deaf:
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
        with atomic_path(study_dir / "figures" / "slow.png") as tmp:
            tmp.write_bytes(b"partial")
            started.write_text(str(os.getpid()))
            time.sleep(600)
    monkeypatch.setitem(R.DRAWINGS, ("refine", "convergence"),
                        replace(R.DRAWINGS[("refine", "convergence")], draw=slow))

    sent = []

    def interrupt():
        for _ in range(12000):
            if started.exists() and started.read_text():
                sent.append(time.monotonic())
                os.kill(os.getpid(), signal.SIGINT)
                return
            time.sleep(0.05)
    threading.Thread(target=interrupt, daemon=True).start()
    with pytest.raises(R.ReportInterrupted):
        report_study(study_dir, animation=False, formats=("png",), workers=2)
    # a hang guard, not a timing: a worker left running would hold the report for its 600 s
    assert sent and time.monotonic() - sent[0] < 300, "the sleeping worker was not stopped"
    worker = int(started.read_text())
    assert not Path(f"/proc/{worker}").exists() or \
        Path(f"/proc/{worker}/stat").read_text().split(")")[1].split()[0] == "Z", \
        "the drawing process is still running"
    names = [p.name for p in (study_dir / "figures").iterdir()]
    assert not [n for n in names if n.startswith(".")], names
    assert "slow.png" not in names


def test_workers_draw_the_same_files_as_one_process(reported_study, study_dir):
    """The figures drawn on two processes are the files one process draws, byte for byte."""
    report_study(study_dir, formats=("png",), workers=2, **FAST)
    one = reported_study / "figures"
    for p in (study_dir / "figures").glob("*.png"):
        assert p.read_bytes() == (one / p.name).read_bytes(), p.name


def test_each_animation_reports_its_frames(study_dir):
    """An animation says how many of its frames are drawn, at each quarter and at the end."""
    lines: list[str] = []
    report_study(study_dir, formats=("png",), progress=lines.append, **FAST)
    for name in ANIMATIONS:
        frames = [re.search(r"animation: (\d+)/(\d+) frames", line)
                  for line in lines if f"] {name}: animation:" in line]
        counts = [(int(m[1]), int(m[2])) for m in frames if m]
        assert len(counts) >= 2 and counts[-1][0] == counts[-1][1], (name, lines)
        assert [c for c, _ in counts] == sorted(c for c, _ in counts)


def test_step_descriptions_on_the_page_are_whole_sentences(reported_study):
    """Each step's description is its kind's first sentence, whole (seven kinds were once
    cut at their docstring's first line, e.g. "...completes max_cycles: survival per")."""
    from monkeystudy.plotting.page import description
    from monkeystudy.study.steps import REGISTRY

    for kind in REGISTRY.values():
        text = description(kind.model.__doc__)
        whole = " ".join((kind.model.__doc__ or "").split())
        assert text.endswith(".") and whole.startswith(text), kind.name
        rest = whole[len(text):]
        assert rest == "" or re.match(r"\s+[A-Z`(]", rest), (kind.name, rest[:20])


def test_a_step_description_names_the_step_s_own_numbers(reported_study):
    """The page printed the stability kind's docstring as is, "for ``cycles``
    cycles": a numeric setting the description names reads as the step's value, in the
    right number; a setting the study file leaves out, as its default."""
    from monkeystudy.plotting.page import description
    from monkeystudy.study.steps import REGISTRY

    doc = REGISTRY["stability"].model.__doc__
    assert description(doc, {"cycles": 30}).endswith("recorded times for 30 cycles.")
    assert description(doc, {"cycles": 1}).endswith("recorded times for 1 cycle.")
    page = (reported_study / "figures" / PAGE).read_text()
    cycles = xr.open_dataset(reported_study / "stability_1.nc").sizes["cycle"]
    assert (f"Repeat a refined gait open-loop from its recorded times for {cycles} "
            f"cycle{'s' if cycles != 1 else ''}.") in page
    assert "<code>cycles</code>" not in page


def test_figures_are_numbered_in_the_order_they_are_said_and_long_work_is_said(
        reported_copy, monkeypatch):
    """Each figure's number is given the first time it is said: the lines count up (the
    longest figures are drawn first, not in the plan's order), and while figures are drawn a
    line says which, for how long, when none came for a while (here: at once)."""
    from monkeystudy.plotting import report as R

    monkeypatch.setattr(R, "STILL_DRAWING", 0.0)
    lines: list[str] = []
    report_study(reported_copy, force=True, animation=False, formats=("png",), workers=2,
                 progress=lines.append)
    first: dict[str, int] = {}
    for line in lines:
        m = re.match(r"\[(\d+)/(\d+)\] (\S+): ", line)
        if m:
            first.setdefault(m[3], int(m[1]))
    assert list(first.values()) == list(range(1, len(first) + 1)), lines
    assert len(first) == len(R.plan(reported_copy, animation=False))
    drawing = [line for line in lines if line.startswith("drawing ")]
    assert drawing and all(re.fullmatch(r"drawing (\S+ \(\d+ s\)(, )?)+", line)
                           for line in drawing), drawing


def test_the_report_command_speaks_before_it_loads_the_plotting_code(reported_copy):
    from click.testing import CliRunner

    from monkeystudy.cli import app

    res = CliRunner().invoke(app, ["report", str(reported_copy), "--no-animation"])
    assert res.exit_code == 0, res.output
    assert res.output.splitlines()[0] == f"{reported_copy}: reading its datasets to plan " \
                                         "the figures"


def test_the_planning_of_the_figures_is_said_while_it_lasts(reported_copy, monkeypatch):
    # reading and hashing a large study's datasets takes seconds: the report ticks through it
    from contextlib import contextmanager

    import monkeystudy.plotting.report as report_module
    ticked = []

    @contextmanager
    def recording(echo, what, every=1.0):
        ticked.append(what)
        echo(f"{what} (1.0 s)")
        yield

    monkeypatch.setattr(report_module, "ticking", recording)
    lines: list[str] = []
    assert report_study(reported_copy, progress=lines.append, **FAST) == []
    assert ticked == ["planning the figures"] and lines[0] == "planning the figures (1.0 s)"
