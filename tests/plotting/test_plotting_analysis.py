"""Figures of the analysis datasets (shoot, floquet, tick_sweep, basin, continuation,
work_precision): each draws the dataset's numbers (checked on the artists' data, not pixels),
labels its axes with units, says what was run, and report_study draws and redraws them like
the others. The datasets are small but real (analysisdata.py)."""
from __future__ import annotations

import json
import math
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from PIL import Image

from monkeystudy.plotting.kinds import (
    basin, continuation, floquet, shoot, tick_sweep, work_precision,
)
from monkeystudy.plotting.labels import sci
from monkeystudy.plotting.report import DRAWINGS
from monkeystudy.plotting.page import PAGE
from monkeystudy.plotting.report import MANIFEST, StudyIncomplete, plan, report_study

from analysisdata import BASIN_CYCLES, ERROR_BOUND, TICKS, build_analysis_study
from plotdata import write_nc

STEMS = {"shoot": "shoot_newton", "floquet": "floquet_multipliers",
         "ticks": "ticks_error_growth", "basin": "basin_cycles_map",
         "family": "family_branch", "family_com": "family_com_branch",
         "timing": "timing_work_precision"}


@pytest.fixture(scope="module")
def analysis_built(tmp_path_factory) -> Path:
    return build_analysis_study(tmp_path_factory.mktemp("analysis") / "analysis_plot_test")


@pytest.fixture(scope="module")
def ds(analysis_built):
    """The analysis datasets by step name."""
    out = {}
    for p in sorted(analysis_built.glob("*.nc")):
        with xr.open_dataset(p) as d:
            out[p.stem] = d.load()
    return out


@pytest.fixture(scope="module")
def reported(tmp_path_factory, analysis_built) -> Path:
    """The analysis study with its report drawn once (do not modify)."""
    dst = tmp_path_factory.mktemp("reported") / analysis_built.name
    shutil.copytree(analysis_built, dst)
    report_study(dst)
    return dst


@pytest.fixture
def reported_copy(reported, tmp_path) -> Path:
    dst = tmp_path / reported.name
    shutil.copytree(reported, dst)
    return dst


#: axis labels of counts (no units)
COUNTS = ("Newton iteration", "gait cycle")


def by_gid(fig: Figure, gid: str):
    found = [a for a in fig.findobj() if a.get_gid() == gid]
    assert found, f"no artist with gid {gid!r}"
    return found[0]


def gids(fig: Figure) -> set[str]:
    return {a.get_gid() for a in fig.findobj() if a.get_gid()}


def titles(fig: Figure) -> tuple[str, str]:
    """(bold title, subtitle) of an analysis figure."""
    return fig._suptitle.get_text(), fig.subfigs[0]._suptitle.get_text()


def texts(fig: Figure) -> list[str]:
    return [t.get_text() for t in fig.findobj(lambda a: hasattr(a, "get_text"))]


def legend_texts(fig: Figure) -> list[str]:
    legs = list(fig.legends) + [lg for sf in fig.subfigs for lg in sf.legends]
    return [t.get_text() for lg in legs for t in lg.get_texts()]


def finite(y):
    y = np.ma.filled(np.ma.asarray(y, float), np.nan)
    return y[np.isfinite(y)]


# --- every figure ---------------------------------------------------------------------------
def test_every_kind_has_a_figure_and_the_study_data_are_as_expected(ds):
    kinds = {d.attrs["step_kind"] for d in ds.values()}
    analysis = (shoot, floquet, tick_sweep, basin, continuation, work_precision)
    assert kinds == {k for m in analysis for k, _ in m.DRAWINGS} == {
        "shoot", "floquet", "tick_sweep", "basin", "continuation", "work_precision"}
    # the physics the figures show (so a change in the data is noticed here)
    assert ds["shoot"]["converged"].values.tolist() == [1, 0]
    assert ds["floquet"]["stable"].values.tolist() == [0, 1]
    assert ds["ticks"]["cycles_to_bound"].values.tolist() == sorted(
        ds["ticks"]["cycles_to_bound"].values.tolist())          # finer tick: later


@pytest.mark.parametrize("step", list(STEMS))
def test_axes_have_units_and_titles_say_what_was_run(ds, step):
    d = ds[step]
    (how,) = [v for (k, _), v in DRAWINGS.items() if k == d.attrs["step_kind"]]
    fig = how.draw([d])
    title, sub = titles(fig)
    assert title and sub
    assert "robot seed2009" in sub and f"study analysis_plot_test / {step}" in sub
    for ax in fig.findobj(Axes):
        if ax.get_label() == "<colorbar>":
            assert "cycles" in ax.get_ylabel()
            continue
        for lab in (ax.get_xlabel(), ax.get_ylabel()):
            if lab and not lab.startswith(COUNTS):  # shared axes: only the outer labelled
                assert "[" in lab and "]" in lab, (step, lab)
        # every axis is labelled, on itself or on an axes sharing it
        assert any(a.get_xlabel() for a in ax.get_shared_x_axes().get_siblings(ax))
        assert any(a.get_ylabel() for a in ax.get_shared_y_axes().get_siblings(ax))


# --- shoot ----------------------------------------------------------------------------------
def test_shoot_order_panel_labels_the_same_powers_of_ten_on_both_axes(ds):
    """The square r[k+1]-against-r[k] panel labelled every third power of ten on one
    axis and every second on the other, so its slopes did not read from the labels. Both
    axes label the same powers of ten, at least three of them, within the view."""
    fig = shoot.plot_shoot_convergence(ds["shoot"])
    fig.canvas.draw()
    axr = by_gid(fig, "ratio_0").axes

    def labelled(axis):
        lo, hi = sorted(axis.get_view_interval())
        return [round(math.log10(t.get_loc()), 6) for t in axis.get_major_ticks()
                if t.label1.get_text() and lo <= t.get_loc() <= hi]
    xs, ys = labelled(axr.xaxis), labelled(axr.yaxis)
    assert xs == ys and len(xs) >= 3, (xs, ys)


def test_shoot_lines_are_the_newton_histories(ds):
    d = ds["shoot"]
    fig = shoot.plot_shoot_convergence(d)
    hist = d["history"].values
    for i in range(d.sizes["solution"]):
        h = hist[i][np.isfinite(hist[i])]
        line = by_gid(fig, f"history_{i}")
        np.testing.assert_array_equal(finite(line.get_ydata()), h)
        np.testing.assert_array_equal(line.get_xdata(), np.arange(h.size))
        ratio = by_gid(fig, f"ratio_{i}")
        np.testing.assert_array_equal(ratio.get_xdata(), h[:-1])
        np.testing.assert_array_equal(ratio.get_ydata(), h[1:])
        assert by_gid(fig, f"final_{i}").get_text() == f"e = {sci(float(d['error'][i]))}"
    assert ax_yscale(fig, "history_0") == "log"
    # the quadratic guide has slope 2 in log-log and passes near the converged iterates
    g = by_gid(fig, "quadratic_guide")
    x, y = g.get_xdata(), g.get_ydata()
    assert np.polyfit(np.log(x), np.log(y), 1)[0] == pytest.approx(2.0)
    h = hist[0][np.isfinite(hist[0])]
    C = y[0] / x[0] ** 2
    steps = (h[1:] > 1e-13)                   # above round-off: within a factor 10 of C r^2
    assert np.all(np.abs(np.log10(h[1:][steps] / (C * h[:-1][steps] ** 2))) < 1.0)
    assert by_gid(fig, "tol").get_ydata()[0] == d.attrs["tol"]
    leg = legend_texts(fig)
    assert any("solution 0: grazing, converged" in t for t in leg)
    assert any("solution 1: Gauss-Newton, not converged" in t for t in leg)


def ax_yscale(fig, gid):
    return by_gid(fig, gid).axes.get_yscale()


# --- floquet --------------------------------------------------------------------------------
def test_floquet_markers_are_the_multipliers(ds):
    d = ds["floquet"]
    fig = floquet.plot_floquet_multipliers(d)
    for j, c in enumerate(d["controller"].values):
        lam = d["multipliers_real"].values[j] + 1j * d["multipliers_imag"].values[j]
        fd = d["multipliers_fd_real"].values[j] + 1j * d["multipliers_fd_imag"].values[j]
        np.testing.assert_array_equal(by_gid(fig, f"multipliers_{c}").get_offsets(),
                                      np.column_stack([lam.real, lam.imag]))
        np.testing.assert_array_equal(by_gid(fig, f"multipliers_fd_{c}").get_offsets(),
                                      np.column_stack([fd.real, fd.imag]))
        circle = by_gid(fig, f"unit_circle_{c}")
        assert circle.get_radius() == 1.0 and tuple(circle.center) == (0.0, 0.0)
        for k, v in enumerate(lam):
            assert f"|λ| = {abs(v):.4g}" in by_gid(fig, f"modulus_{c}_{k}").get_text()
        ax = by_gid(fig, f"multipliers_{c}").axes
        verdict = "STABLE" if d["stable"].values[j] else "UNSTABLE"
        assert f": {verdict}" in ax.get_title(loc="left")
        # every multiplier inside the view, equal scales (the unit circle is round)
        R = np.abs(lam).max()
        assert ax.get_xlim()[1] > R and ax.get_ylim()[1] > R
        assert np.ptp(ax.get_xlim()) == pytest.approx(np.ptp(ax.get_ylim()))
        assert ax.get_box_aspect() == 1.0
    # open loop unstable (|lambda| 1.748), search stable with the neutral energy multiplier
    ol = by_gid(fig, "multipliers_open_loop").axes.get_title(loc="left")
    assert "UNSTABLE" in ol and "largest |λ| = 1.748" in ol
    assert "(neutral)" in by_gid(fig, "modulus_search_0").get_text()


# --- tick sweep -----------------------------------------------------------------------------
def test_tick_sweep_lines_and_the_multiplier_prediction(ds):
    d = ds["ticks"]
    fig = tick_sweep.plot_tick_sweep(d)
    err = d["error"].values
    cyc = d["cycle"].values
    for i in range(d.sizes["tick"]):
        line = by_gid(fig, f"error_{i}")
        np.testing.assert_array_equal(line.get_xdata(), cyc)
        y = np.ma.filled(np.ma.asarray(line.get_ydata(), float), np.nan)
        np.testing.assert_array_equal(np.isnan(y), np.isnan(err[i]))
        np.testing.assert_array_equal(y[~np.isnan(y)], err[i][~np.isnan(err[i])])
        n = int(d["cycles_to_bound"][i])
        mark = by_gid(fig, f"to_bound_{i}")
        assert (mark.get_xdata()[0], mark.get_ydata()[0]) == (cyc[n - 1], ERROR_BOUND)
        assert err[i][n - 1] > ERROR_BOUND >= np.nanmax(err[i][:n - 1], initial=0)
        assert f"stop_{i}" in gids(fig)                     # every run fell
    lam = d.attrs["leading_multiplier"]
    pred = by_gid(fig, "prediction")
    y = np.asarray(pred.get_ydata(), float)
    np.testing.assert_allclose(y[1:] / y[:-1], lam ** 2, rtol=1e-12)     # |lambda|^(2n)
    # anchored on the exact-timing run: it follows the prediction in its linear regime
    e0 = err[list(TICKS).index(0.0)]
    lin = (e0 > 1e-20) & (e0 < 1e-8)
    assert lin.sum() > 10
    assert np.all(np.abs(np.log10(e0[lin] / y[lin])) < 0.15)
    assert by_gid(fig, "error_bound").get_ydata()[0] == ERROR_BOUND
    assert pred.axes.get_yscale() == "log"
    title, sub = titles(fig)
    assert title.startswith("Was it the 1 ms time grid?\nNo: with exact timing")
    assert f"|λmax| = {lam:.4g}" in sub and "Verdict:" in sub
    leg = legend_texts(fig)
    for t, n in zip(d["tick"].values, d["cycles_to_bound"].values):
        name = "exact event timing" if t == 0 else f"{t * 1e3:g} ms controller tick"
        assert any(s.startswith(name) and f"from cycle {n}" in s for s in leg), (name, leg)


def test_tick_sweep_title_when_exact_timing_holds(ds):
    d = ds["ticks"].copy(deep=True)
    e = d["error"].values
    e[2] = np.where(np.isfinite(e[2]), np.minimum(e[2], 1e-6), np.nan)   # exact run holds
    d["cycles_to_bound"].values[2] = int(np.isfinite(e[2]).sum())
    title, sub = titles(tick_sweep.plot_tick_sweep(d))
    assert "Yes: with exact timing the gait holds" in title
    assert "the tick's rounding is what drives the runs off the gait" in sub


# --- basin ----------------------------------------------------------------------------------
def test_basin_image_is_the_cycles_map(ds):
    d = ds["basin"]
    fig = basin.plot_basin(d)
    mesh = by_gid(fig, "cycles")
    cyc = d["cycles"].transpose("d_dtheta1", "d_dtheta2").values
    np.testing.assert_array_equal(np.asarray(mesh.get_array()).reshape(cyc.T.shape), cyc.T)
    # integer colour steps: every count has its own colour band
    norm = mesh.norm
    assert np.all(np.diff(norm.boundaries) == 1.0) and norm.boundaries[-1] > BASIN_CYCLES
    o1, o2 = d["d_dtheta1"].values, d["d_dtheta2"].values
    for i in range(o1.size):
        for j in range(o2.size):
            t = by_gid(fig, f"count_{i}_{j}")
            assert t.get_text() == str(cyc[i, j]) and t.get_position() == (o1[i], o2[j])
    g = by_gid(fig, "gait")
    assert (g.get_xdata()[0], g.get_ydata()[0]) == (0.0, 0.0)
    cbar = [a for a in fig.findobj(Axes) if a.get_label() == "<colorbar>"][0]
    assert cbar.get_ylabel() == f"cycles before error > {ERROR_BOUND:g}"
    # the gait itself outlasts every perturbed start
    assert cyc[2, 2] == cyc.max() and np.sum(cyc == cyc.max()) == 1


# --- continuation ---------------------------------------------------------------------------
@pytest.mark.parametrize("step", ["family", "family_com"])
def test_continuation_lines_are_the_branch(ds, step):
    d = ds[step]
    fig = continuation.plot_continuation(d)
    mu = d["parameter_value"].values
    for var in ("dtheta1", "dtheta2", "t_switch"):
        line = by_gid(fig, var)
        np.testing.assert_array_equal(line.get_xdata(), mu)
        np.testing.assert_array_equal(line.get_ydata(), d[var].values)
    lam = np.abs(d["multipliers_real"].values + 1j * d["multipliers_imag"].values)
    for k in range(3):
        np.testing.assert_array_equal(by_gid(fig, f"modulus_{k}").get_ydata(), lam[:, k])
    assert list(by_gid(fig, "unit_level").get_ydata()) == [1.0, 1.0]
    assert not {g for g in gids(fig) if g.startswith(("fold_", "period_doubling_"))}
    assert "no folds or period doublings" in titles(fig)[1]
    unit = {"family": "[m s$^{-2}$]", "family_com": "[m]"}[step]
    assert by_gid(fig, "modulus_0").axes.get_xlabel().endswith(unit)


def test_a_continuation_of_one_point_counts_it_in_the_singular(ds):
    """A branch that stops at its start (``no_branch``: the family does not survive a change
    of the parameter) holds one point: "1 point, g = 9.81 m s-2", not "1 points, g = 9.81 →
    9.81"."""
    d = ds["family"].isel(point=[0])
    fig = continuation.plot_continuation(d)
    g = float(d["parameter_value"].values[0])
    assert titles(fig)[1].startswith(f"1 point, g = {g:.6g} m s")
    assert "→" not in titles(fig)[1].splitlines()[0]


def test_continuation_marks_folds_and_period_doublings(ds):
    d = ds["family"].copy()
    d.attrs.update(folds=json.dumps([2]), period_doublings=json.dumps([3]))  # as if found
    fig = continuation.plot_continuation(d)
    mu = d["parameter_value"].values
    assert by_gid(fig, "fold_2").get_xdata()[0] == mu[2]
    span = by_gid(fig, "period_doubling_3").get_path().vertices    # a band, not a line:
    x = by_gid(fig, "period_doubling_3").get_transform().transform(span)[:, 0]   # the
    ax = by_gid(fig, "period_doubling_3").axes                     # crossing lies between
    x = ax.transData.inverted().transform(np.column_stack([x, x]))[:, 0]       # two points
    assert min(x) == pytest.approx(min(mu[2], mu[3])) and \
        max(x) == pytest.approx(max(mu[2], mu[3]))
    assert "1 fold, 1 period doubling (marked)" in titles(fig)[1]
    leg = legend_texts(fig)
    assert any(t.startswith("fold at point 2") for t in leg)
    assert any(t.startswith("period doubling between points 2 and 3") for t in leg)


# --- work precision -------------------------------------------------------------------------
def test_work_precision_lines_are_time_against_error(ds):
    d = ds["timing"]
    fig = work_precision.plot_work_precision(d)
    t = d["time_per_gait"].values
    for which in ("value", "times"):
        e = d[f"error_{which}"].values
        for i, m in enumerate(d["method"].values):
            line = by_gid(fig, f"kernel_{m}_{which}")
            np.testing.assert_array_equal(finite(line.get_xdata()), e[i])
            np.testing.assert_array_equal(line.get_ydata(), t[i])
            assert line.axes.get_xscale() == line.axes.get_yscale() == "log"
        se = d[f"scipy_error_{which}"].values
        for i, m in enumerate(d["scipy_method"].values):
            line = by_gid(fig, f"scipy_{m}_{which}")
            np.testing.assert_array_equal(finite(line.get_xdata()), se[i])
            np.testing.assert_array_equal(line.get_ydata(), d["scipy_time_per_gait"].values[i])
            assert line.get_linestyle() == "--"
    for i, m in enumerate(d["method"].values):
        for j, r in enumerate(d["rtol"].values):
            if "+" in m:  # a PI variant: unlabelled, on its pair's colour, dotted
                assert not fig.findobj(lambda a, g=f"rtol_{m}_{j}": a.get_gid() == g)
                continue
            lab = by_gid(fig, f"rtol_{m}_{j}")
            assert lab.get_text() == sci(r, 1)
            assert lab.xy == (d["error_value"].values[i, j], t[i, j])
    pi, pair = by_gid(fig, "kernel_dop853+pi_times"), by_gid(fig, "kernel_dop853_times")
    assert pi.get_color() == pair.get_color() and pi.get_linestyle() == ":"
    assert pair.get_linestyle() == "-"
    assert titles(fig)[0].endswith(f"(reference: {d.attrs['reference']})")
    assert len({by_gid(fig, f"scipy_{m}_value").get_marker()
                for m in d["scipy_method"].values}) == d.sizes["scipy_method"]


# --- report_study ---------------------------------------------------------------------------
def assert_png(path: Path, sha: str):
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with Image.open(path) as im:
        im.verify()
    with Image.open(path) as im:
        assert im.size[0] > 600 and im.size[1] > 400
        assert im.text.get("study_sha256") == sha
        assert im.text.get("monkeystudy_version") and "git_revision" in im.text


def assert_pdf(path: Path, sha: str):
    data = path.read_bytes()
    assert data[:5] == b"%PDF-" and b"%%EOF" in data[-64:]
    assert f"study_sha256={sha}".encode() in data


def test_report_draws_every_analysis_figure_with_provenance(reported):
    figs = reported / "figures"
    expected = {f"{s}.{e}" for s in STEMS.values() for e in ("png", "pdf")}
    assert expected | {MANIFEST, PAGE} == set(os.listdir(figs))
    sha = xr.open_dataset(reported / "shoot.nc").attrs["study_sha256"]
    for name in expected:
        (assert_png if name.endswith(".png") else assert_pdf)(figs / name, sha)
    manifest = json.loads((figs / MANIFEST).read_text())["figures"]
    for step, stem in STEMS.items():
        assert list(manifest[stem]["inputs"]) == [f"{step}.nc"]


def test_plan_has_one_job_per_analysis_dataset(reported):
    jobs = {j.name: [p.name for p in j.inputs] for j in plan(reported)}
    assert jobs == {stem: [f"{step}.nc"] for step, stem in STEMS.items()}


def test_second_report_changes_nothing(reported_copy):
    figs = reported_copy / "figures"
    before = {p.name: p.stat().st_mtime_ns for p in figs.iterdir()}
    assert report_study(reported_copy) == []
    assert report_study(reported_copy, dry_run=True) == []
    assert {p.name: p.stat().st_mtime_ns for p in figs.iterdir()} == before


def test_a_changed_dataset_redraws_its_figure_only(reported_copy):
    figs = reported_copy / "figures"
    before = {p.name: p.stat().st_mtime_ns for p in figs.iterdir()}
    with xr.open_dataset(reported_copy / "basin.nc") as b:
        changed = b.load()
    changed["cycles"] = changed["cycles"] + 1
    write_nc(changed, reported_copy / "basin.nc")
    written = {p.name for p in report_study(reported_copy)}
    assert written == {"basin_cycles_map.png", "basin_cycles_map.pdf", PAGE}  # + its numbers
    after = {p.name: p.stat().st_mtime_ns for p in figs.iterdir()}
    assert all(after[n] == before[n] for n in before if n not in written and n != MANIFEST)
    (reported_copy / "timing.nc").unlink()                 # its figure goes with it
    with pytest.raises(StudyIncomplete) as err:            # a step of the study is missing
        report_study(reported_copy)
    assert err.value.missing == ["timing"]
    assert err.value.written == [figs / PAGE]              # the page says it has no dataset
    assert 'id="step-timing"' in (figs / PAGE).read_text()
    assert not [n for n in os.listdir(figs) if n.startswith("timing_")]


def test_a_branch_of_one_point_counts_in_the_singular(ds):
    """A continuation that holds its start only (a ``no_branch`` stop) was titled "1 points"."""
    d = ds["family"].isel(point=[0])
    assert "1 point, " in titles(continuation.plot_continuation(d))[1]
