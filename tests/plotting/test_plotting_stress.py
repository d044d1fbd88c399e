"""Figure of the stress dataset: the artists carry the dataset's numbers (read back by gid,
not from pixels), the axes have units, the title states the growth exponents, and
report_study draws it like the analysis figures. The dataset is real: studies/stress_smoke.yaml
run by the study runner (a few seconds)."""
from __future__ import annotations

import json
import re
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.colors import to_rgba
from matplotlib.text import Text
from PIL import Image

from monkeystudy.kernel import layout as L
from monkeystudy.plotting import DRAWINGS, plot_stress
from monkeystudy.plotting.kinds import stress as PS
from monkeystudy.plotting.report import MANIFEST, plan, report_study

from plotdata import write_nc

ROOT = Path(__file__).resolve().parents[2]
SMOKE = ROOT / "studies" / "stress_smoke.yaml"


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> Path:
    from monkeystudy.study import load_study, run_study

    out = tmp_path_factory.mktemp("stress") / "stress_smoke"
    run_study(load_study(SMOKE), out, workers=1)
    return out


@pytest.fixture(scope="module")
def ds(built) -> xr.Dataset:
    with xr.open_dataset(built / "stress.nc") as d:
        return d.load()


@pytest.fixture(scope="module")
def fig(ds):
    return plot_stress(ds)


def by_gid(fig, gid: str):
    found = [a for a in fig.findobj() if a.get_gid() == gid]
    assert found, f"no artist with gid {gid!r}"
    assert len(found) == 1, f"{len(found)} artists with gid {gid!r}"
    return found[0]


def ydata(line) -> np.ndarray:
    return np.ma.filled(np.ma.asarray(line.get_ydata(), float), np.nan)


def test_stress_kind_is_registered_beside_the_analysis_kinds(ds):
    assert DRAWINGS[("stress", "stress")] is PS.DRAWINGS[("stress", "stress")]
    assert DRAWINGS[("stress", "stress")].draw([ds]).get_suptitle() == \
        plot_stress(ds).get_suptitle()
    assert {"shoot", "floquet", "tick_sweep", "basin", "continuation",
            "work_precision"} < {k for k, _ in DRAWINGS}


def test_drift_lines_are_the_dataset(ds, fig):
    t = ds["time"].values
    d = ds["energy_drift"].values
    for i, ph in enumerate(ds["drift_phase"].values):
        for j in range(ds.sizes["drift_rtol"]):
            line = by_gid(fig, f"drift_{ph}_{j}")
            np.testing.assert_array_equal(line.get_xdata(), t[i])
            np.testing.assert_array_equal(ydata(line), d[i, j])
            assert line.axes.get_xscale() == line.axes.get_yscale() == "log"
    # one line style per phase, one colour per tolerance
    assert by_gid(fig, "drift_swing_0").get_linestyle() == "-"
    assert by_gid(fig, "drift_flight_0").get_linestyle() == ":"
    assert by_gid(fig, "drift_swing_0").get_color() == by_gid(fig, "drift_flight_0").get_color()
    assert by_gid(fig, "drift_swing_0").get_color() != by_gid(fig, "drift_swing_2").get_color()


def test_linear_reference_and_round_off_band(ds, fig):
    ref = by_gid(fig, "linear_reference")
    assert ref.get_linestyle() == "--"
    x, y = np.asarray(ref.get_xdata(), float), np.asarray(ref.get_ydata(), float)
    # slope 1 in log-log, through the end of the line with the largest final drift
    assert np.log(y[1] / y[0]) / np.log(x[1] / x[0]) == pytest.approx(1.0, rel=1e-12)
    last = ds["energy_drift"].values[..., -1]
    i, j = np.unravel_index(int(np.argmax(last)), last.shape)
    t_end = ds["time"].values[i, -1]
    assert y[0] * t_end / x[0] == pytest.approx(last[i, j], rel=1e-12)
    band = by_gid(fig, "round_off")                      # axhspan: a Rectangle, y in data
    assert band.get_y() + band.get_height() == pytest.approx(float(ds.attrs["drift_floor"]),
                                                             rel=1e-12)


def test_title_states_the_growth_exponents(ds, fig):
    title = fig._suptitle.get_text()
    expo = ds["growth_exponent"].values
    for i, ph in enumerate(ds["drift_phase"].values):
        order = np.argsort(-ds["drift_rtol"].values)
        want = " / ".join(PS._exp(expo[i, j]) for j in order)
        assert f"{ph} {want}" in title, (want, title)
    assert "1e-8 / 1e-10 / 1e-12" in title
    # the flight run at rtol 1e-12 is at round-off: no exponent, a dash in the title
    assert np.isnan(expo[1, 2]) and PS._exp(expo[1, 2]) == "–"
    sub = fig.subfigs[0]._suptitle.get_text()
    assert "robot seed2009" in sub and "study stress_smoke / stress" in sub


def test_long_run_bars_are_cycles_coloured_by_status(ds, fig):
    for k, run in enumerate(ds["run"].values):
        bar = by_gid(fig, f"run_{k}")
        assert bar.get_width() == ds["cycles_completed"].values[k]
        st = L.STATUS_NAMES[int(ds["run_status"].values[k])]
        assert bar.get_facecolor() == to_rgba(PS.STATUS_COLOUR[st])
        label = by_gid(fig, f"run_label_{k}").get_text()
        assert label.startswith(f"{st.replace('_', ' ')}: {int(ds['cycles_completed'][k])} "
                                "cycle")
    req = by_gid(fig, "requested_cycles")
    assert req.get_xdata()[0] == int(ds.attrs["cycles"]) == 20
    # the smoke run has both outcomes: the exact open-loop replay falls, the others hold
    colours = {by_gid(fig, f"run_{k}").get_facecolor() for k in range(ds.sizes["run"])}
    assert colours == {to_rgba(PS.STATUS_COLOUR["ok"]), to_rgba(PS.STATUS_COLOUR["fell"])}


def test_extreme_case_bars_are_the_status_counts(ds, fig):
    counts = ds["status_counts"].values
    for i, case in enumerate(ds["case"].values):
        left = 0
        for code in ds["status"].values:
            n = int(counts[i, code])
            gid = f"case_{i}_{L.STATUS_NAMES[code]}"
            found = [a for a in fig.findobj() if a.get_gid() == gid]
            if n == 0:
                assert not found
                continue
            bar = found[0]
            assert (bar.get_x(), bar.get_width()) == (left, n)
            assert bar.get_facecolor() == to_rgba(PS.STATUS_COLOUR[L.STATUS_NAMES[code]])
            left += n
        assert left == int(ds["n_runs"].values[i])
        assert by_gid(fig, f"finite_{i}").get_text() == "finite ✓"


def test_a_non_finite_case_and_unreached_checkpoints_are_shown(ds):
    bad = ds.copy(deep=True)
    bad["finite_ok"][2] = 0
    bad["energy_drift"][0, 0, -3:] = np.nan          # a run that stopped early
    fig = plot_stress(bad)
    assert by_gid(fig, "finite_2").get_text() == "NON-FINITE ✗"
    y = ydata(by_gid(fig, "drift_swing_0"))
    assert np.all(np.isnan(y[-3:])) and np.all(np.isfinite(y[:-3]))


def test_one_requested_cycle_is_counted_in_the_singular(ds):
    """Long runs of one cycle: the title says "dotted: 1 cycle requested"."""
    one = ds.copy(deep=True)
    one.attrs["cycles"] = 1
    texts = [t.get_text() for t in plot_stress(one).findobj(Text)]
    title = [t for t in texts if t.startswith("Long runs")]
    assert len(title) == 1 and "dotted: 1 cycle requested;" in title[0], title


def test_axes_have_units(fig):
    for ax in fig.findobj(Axes):
        for lab in (ax.get_xlabel(), ax.get_ylabel()):
            if lab:
                assert "[" in lab and "]" in lab, lab


def test_report_draws_the_stress_figure_once(built, tmp_path):
    study = tmp_path / built.name
    shutil.copytree(built, study)
    written = {p.name for p in report_study(study)}
    assert written == {"stress_stress.png", "stress_stress.pdf", "index.html"}
    figs = study / "figures"
    sha = xr.open_dataset(study / "stress.nc").attrs["study_sha256"]
    with Image.open(figs / "stress_stress.png") as im:
        assert im.size[0] > 1000 and im.size[1] > 600
        assert im.text.get("study_sha256") == sha
    assert f"study_sha256={sha}".encode() in (figs / "stress_stress.pdf").read_bytes()
    manifest = json.loads((figs / MANIFEST).read_text())["figures"]
    assert list(manifest["stress_stress"]["inputs"]) == ["stress.nc"]
    assert {j.name: [p.name for p in j.inputs] for j in plan(study)} == \
        {"stress_stress": ["stress.nc"]}
    before = {p.name: p.stat().st_mtime_ns for p in figs.iterdir()}
    assert report_study(study) == []                    # unchanged: nothing redrawn
    with xr.open_dataset(study / "stress.nc") as d:
        changed = d.load()
    changed["final_pivot_height"] = changed["final_pivot_height"] + 1.0
    write_nc(changed, study / "stress.nc")
    assert {p.name for p in report_study(study)} == written
    assert set(os.listdir(figs)) == set(before)


def test_long_runs_of_one_cycle_are_counted_in_the_singular(ds):
    """A stress step with ``long_runs: {cycles: 1}``: the subtitle and the long runs' panel
    said "long runs of 1 cycles" and "dotted: 1 cycles requested"."""
    one = ds.copy()
    one.attrs["cycles"] = 1
    one["cycles_completed"] = one["cycles_completed"].clip(max=1)
    texts = [t.get_text() for t in plot_stress(one).findobj(Text)]
    assert any("long runs of 1 cycle and" in t for t in texts), texts
    assert any("dotted: 1 cycle requested" in t for t in texts), texts
    assert not any(re.search(r"(?<![\d.])1 cycles\b", t) for t in texts), texts
