"""The analysis step kinds (shoot, floquet, tick_sweep, basin, continuation, work_precision):
validation with file:line: key, end-to-end runs through the CLI and the runner, the dataset
contract of docs/datasets.md, and the physics the datasets must show."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner

from monkeystudy.cli import app
from monkeystudy.study import StudyError, load_study, parse_study, plan_study, run_study
from monkeystudy.analysis.replay import cycles_to_bound, growth_per_cycle
from monkeystudy.study.blocks import shard_dir, write_shard
from monkeystudy.study.errors import RunFailed
from monkeystudy.study.steps import REGISTRY
from monkeystudy.study.steps.basin import BasinStep
from monkeystudy.study.steps.continuation import ContinuationStep
from monkeystudy.study.steps.floquet import FloquetStep
from monkeystudy.study.steps.shoot import (
    METHOD_GAUSS_NEWTON, METHOD_GRAZING, ShootStep, dedup_solutions,
)
from monkeystudy.study.steps.tick_sweep import TickSweepStep
from monkeystudy.study.steps.work_precision import WorkPrecisionStep

from studyhelpers import assert_same_datasets, write_study

ROOT = Path(__file__).resolve().parents[2]
SMOKE = ROOT / "studies" / "analysis_smoke.yaml"
SMOKE_FILES = ("shoot.nc", "nm.nc", "shoot_nm.nc", "floquet.nc", "ticks.nc", "ticks_var.nc",
               "basin.nc", "family.nc", "timing.nc")
REPRODUCIBLE = tuple(n for n in SMOKE_FILES if n != "timing.nc")

GLOBAL_ATTRS = ("study_name", "step_name", "step_kind", "study_text", "study_sha256",
                "step_sha256", "robot",
                "gait", "integrator", "monkeystudy_version", "git_revision",
                "library_versions", "history", "Conventions")

#: variables of docs/datasets.md "Analysis steps", with their units and dims
CONTRACT = {
    "shoot": {"dtheta1": ("rad s-1", ("solution",)), "dtheta2": ("rad s-1", ("solution",)),
              "t_switch": ("s", ("solution",)), "t_motor": ("s", ("solution",)),
              "t_end": ("s", ("solution",)), "error": ("rad2 + rad2 s-2", ("solution",)),
              "residual_norm": ("1", ("solution",)), "converged": ("1", ("solution",)),
              "method": ("1", ("solution",)), "history": ("1", ("solution", "iteration"))},
    "floquet": {"multipliers_real": ("1", ("controller", "k")),
                "multipliers_imag": ("1", ("controller", "k")),
                "multipliers_fd_real": ("1", ("controller", "k")),
                "multipliers_fd_imag": ("1", ("controller", "k")),
                "jacobian": ("1", ("controller", "row", "col")),
                "jacobian_fd": ("1", ("controller", "row", "col")),
                "fixed_point": ("1", ("controller", "k")), "map_defect": ("1", ("controller",)),
                "stable": ("1", ("controller",)), "agreement": ("1", ("controller",)),
                "t_switch": ("s", ("controller",)), "t_motor": ("s", ("controller",))},
    "tick_sweep": {"tick": ("s", ("tick",)), "error": ("rad2 + rad2 s-2", ("tick", "cycle")),
                   "pivot_height": ("m", ("tick", "cycle")),
                   "cycles_to_bound": ("1", ("tick",)), "cycles_completed": ("1", ("tick",)),
                   "status": ("1", ("tick",)), "growth_per_cycle": ("1", ("tick",))},
    "basin": {"d_dtheta1": ("rad s-1", ("d_dtheta1",)), "d_dtheta2": ("rad s-1", ("d_dtheta2",)),
              "cycles": ("1", ("d_dtheta1", "d_dtheta2"))},
    "continuation": {"parameter_value": ("m", ("point",)), "dtheta1": ("rad s-1", ("point",)),
                     "dtheta2": ("rad s-1", ("point",)), "t_switch": ("s", ("point",)),
                     "residual": ("1", ("point",)),
                     "multipliers_real": ("1", ("point", "k")),
                     "multipliers_imag": ("1", ("point", "k"))},
    "work_precision": {"time_per_gait": ("s", ("method", "rtol")),
                       "rhs_per_gait": ("1", ("method", "rtol")),
                       "error_value": ("rad2 + rad2 s-2", ("method", "rtol")),
                       "error_times": ("s", ("method", "rtol")),
                       "status_mismatch": ("1", ("method", "rtol")),
                       "scipy_time_per_gait": ("s", ("scipy_method", "scipy_rtol")),
                       "scipy_error_value": ("rad2 + rad2 s-2", ("scipy_method", "scipy_rtol")),
                       "scipy_error_times": ("s", ("scipy_method", "scipy_rtol")),
                       "kernel_time_same_points": ("s", ("scipy_rtol",))},
}
ATTRS = {"shoot": ("message", "starts"), "floquet": (),
         "tick_sweep": ("leading_multiplier", "error_bound"),
         "basin": ("dtheta1", "dtheta2", "t_switch", "t_motor", "max_cycles", "error_bound",
                   "tick"),
         "continuation": ("parameter", "folds", "period_doublings"),
         "work_precision": ("reference", "n_points")}


# --- validation --------------------------------------------------------------------------------
BASE = """\
schema_version: 1
name: v
robot: {robot}
gait: {{kind: horizontal, motor_torque: 0.6354, tick: 0.0}}
steps:
  - {{name: sh, kind: shoot, starts: [[1.0, 12.0]]}}
  - {{name: fl, kind: floquet, from: sh}}
  - {{name: ts, kind: tick_sweep, from: sh, floquet: fl}}
  - {{name: bs, kind: basin, from: sh, offsets: {{d_dtheta1: {{start: -1.0e-3, stop: 1.0e-3, num: 3}}, d_dtheta2: {{start: 0.0, stop: 0.0, num: 1}}}}}}
  - {{name: co, kind: continuation, from: sh, parameter: com, ds: 0.01}}
  - {{name: wp, kind: work_precision, points: [[0.9, 10.9]]}}
  - {{name: rf, kind: refine, start: [1.0, 12.0]}}
  - {{name: sr, kind: shoot, from: rf, method: grazing}}
"""
EXTRA_LINE = 14
NON_MIRROR = ("{links: [{mass: 1.0, length: 0.61, com: 0.5, inertia: 0.018}, "
              "{mass: 1.2, length: 0.61, com: 0.1, inertia: 0.018}]}")


def study_text(extra: str = "", robot: str = "seed2009") -> str:
    return BASE.format(robot=robot) + (f"  - {extra}\n" if extra else "")


def test_every_analysis_kind_validates_with_defaults():
    st = parse_study(study_text()).study
    sh, fl, ts, bs, co, wp = (st.step(n) for n in ("sh", "fl", "ts", "bs", "co", "wp"))
    assert isinstance(sh, ShootStep) and sh.method == "both" and sh.dedup_tol == 1e-6
    assert isinstance(st.step("sr"), ShootStep) and st.step("sr").from_ == "rf"
    assert isinstance(fl, FloquetStep) and fl.controllers == ["open_loop", "search"]
    assert fl.search_start == [0.0248, -1.0869, 16.0168]
    assert isinstance(ts, TickSweepStep) and ts.ticks == [1e-3, 1e-4, 1e-5, 0.0]
    assert ts.cycles == 80 and ts.error_bound == 1e-2
    assert isinstance(bs, BasinStep) and bs.n_points == 3 and bs.rows_per_block == 3
    assert isinstance(co, ContinuationStep) and co.steps == 20 and co.bounds is None
    assert isinstance(wp, WorkPrecisionStep) and wp.methods == ["rk45", "dop853"]
    assert wp.rtols[0] == 1e-4 and wp.rtols[-1] == 1e-13 and len(wp.rtols) == 10
    assert wp.repeat == 3 and wp.point_array().shape == (1, 2)
    for path in ("exact_gait.yaml", "work_precision.yaml", "analysis_smoke.yaml"):
        load_study(ROOT / "studies" / path)


def test_shipped_exact_gait_study_is_the_brief():
    st = load_study(ROOT / "studies" / "exact_gait.yaml").study
    assert st.robot == "seed2009" and st.gait.motor_torque == 0.6354 and st.gait.tick == 0.0
    assert (st.integrator.method, st.integrator.rtol, st.integrator.atol) == \
        ("dop853", 1e-13, 1e-13)
    kinds = [s.kind for s in st.steps]
    assert kinds == ["shoot", "floquet", "tick_sweep", "basin", "continuation"]
    assert st.step("shoot").starts == [[1.44, 10.31], [1.0, 12.0]]
    assert st.step("floquet").controllers == ["open_loop", "search"]
    b = st.step("basin")
    assert (b.offsets.d_dtheta1.num, b.offsets.d_dtheta2.num, b.max_cycles) == (21, 21, 60)
    assert b.offsets.d_dtheta1.start == -1e-3 and b.offsets.d_dtheta2.stop == 1e-3
    c = st.step("com_family")
    assert (c.parameter, c.ds, c.steps) == ("com", 0.01, 15)


BAD = [
    # (extra step, robot, expected "line: key: message" start)
    ("{name: x, kind: shoot, starts: [[1.0, 12.0]], from: rf}", None,
     f"{EXTRA_LINE}: steps[8]: give either starts"),
    ("{name: x, kind: shoot}", None, f"{EXTRA_LINE}: steps[8]: give starts"),
    ("{name: x, kind: shoot, from: fl}", None,
     f"{EXTRA_LINE}: steps[8].from: 'fl' is a floquet step, expected a refine step"),
    ("{name: x, kind: shoot, starts: [[1.0, 12.0]], method: newton}", None,
     f"{EXTRA_LINE}: steps[8].method: must be 'grazing', 'gauss_newton' or 'both', got "
     "'newton'"),
    ("{name: x, kind: shoot, starts: [[1.0, 12.0]], dedup_tol: 0.0}", None,
     f"{EXTRA_LINE}: steps[8].dedup_tol: must be > 0, got 0"),
    ("{name: x, kind: shoot, startz: [[1.0, 12.0]]}", None,
     f"{EXTRA_LINE}: steps[8].startz: unknown key; did you mean 'starts'?"),
    ("{name: x, kind: shoot, starts: [[1.0]]}", None,
     f"{EXTRA_LINE}: steps[8].starts[0]: must have exactly 2 items, got 1"),
    # a floquet step analyses a shoot step's gait or polishes a refine step's start
    ("{name: x, kind: floquet, from: bs}", None,
     f"{EXTRA_LINE}: steps[8].from: 'bs' is a basin step, expected a shoot or refine step"),
    ("{name: x, kind: floquet, from: rf}", None,
     f"{EXTRA_LINE}: steps[8].from: the open_loop controller analyses a shoot step's gait"),
    ("{name: x, kind: floquet, from: later}", None,
     f"{EXTRA_LINE}: steps[8].from: no earlier step named 'later'"),
    ("{name: x, kind: floquet, from: sh, controllers: [open_loop, open_loop]}", None,
     f"{EXTRA_LINE}: steps[8].controllers: controllers must be distinct"),
    ("{name: x, kind: floquet, from: sh, controllers: [closed_loop]}", None,
     f"{EXTRA_LINE}: steps[8].controllers[0]: must be 'open_loop', 'search' or 'sequence', got "
     "'closed_loop'"),
    ("{name: x, kind: floquet, from: sh, controllers: []}", None,
     f"{EXTRA_LINE}: steps[8].controllers: must not be empty"),
    ("{name: x, kind: floquet, controllers: [open_loop]}", None,
     f"{EXTRA_LINE}: steps[8]: the open_loop controller needs from: <shoot step>"),
    ("{name: x, kind: floquet, from: sh, search_start: [0.0, 1.0]}", None,
     f"{EXTRA_LINE}: steps[8].search_start: must have at least 3 items, got 2"),
    ("{name: x, kind: tick_sweep, from: sh, ticks: [0.001, -0.001]}", None,
     f"{EXTRA_LINE}: steps[8].ticks[1]: must be >= 0, got -0.001"),
    ("{name: x, kind: tick_sweep, from: sh, cycles: 2.5}", None,
     f"{EXTRA_LINE}: steps[8].cycles: must be an integer, got 2.5"),
    ("{name: x, kind: tick_sweep, from: sh, floquet: sh}", None,
     f"{EXTRA_LINE}: steps[8].floquet: 'sh' is a shoot step, expected a floquet step"),
    ("{name: x, kind: tick_sweep, from: sr, floquet: fl}", None,
     f"{EXTRA_LINE}: steps[8].floquet: 'fl' analyses shoot step 'sh', this step 'sr'"),
    ("{name: x, kind: tick_sweep, from: sh, error_bound: .inf}", None,
     f"{EXTRA_LINE}: steps[8].error_bound: must be finite"),
    ("{name: x, kind: basin, from: sh, offsets: {d_dtheta1: {start: 0.0, stop: 1.0, num: 0}, "
     "d_dtheta2: {start: 0.0, stop: 0.0, num: 1}}}", None,
     f"{EXTRA_LINE}: steps[8].offsets.d_dtheta1.num: must be >= 1, got 0"),
    ("{name: x, kind: basin, from: sh}", None,
     f"{EXTRA_LINE}: steps[8].offsets: required key missing"),
    ("{name: x, kind: basin, from: sh, max_cycles: 0, offsets: {d_dtheta1: {start: 0.0, "
     "stop: 0.0, num: 1}, d_dtheta2: {start: 0.0, stop: 0.0, num: 1}}}", None,
     f"{EXTRA_LINE}: steps[8].max_cycles: must be >= 1, got 0"),
    ("{name: x, kind: continuation, from: sh, parameter: mass, ds: 0.01}", None,
     f"{EXTRA_LINE}: steps[8].parameter: must be 'com', 'inertia', 'gravity', 'torque', "
     "'mass_ratio', 'joint_viscous' or 'pivot_viscous', got 'mass'"),
    ("{name: x, kind: continuation, from: sh, parameter: mass_ratio, ds: 0.01}", None,
     f"{EXTRA_LINE}: steps[8].parameter: the horizontal gait's collisionless family is "
     "continued in com, inertia, gravity"),
    ("{name: x, kind: continuation, from: sh, parameter: com, ds: 0.01, ds_max: 0.1}", None,
     f"{EXTRA_LINE}: steps[8].ds_max: the collisionless family is continued with a fixed "
     "step"),
    ("{name: x, kind: continuation, from: sh, parameter: com, ds: 0.0}", None,
     f"{EXTRA_LINE}: steps[8].ds: must be non-zero"),
    ("{name: x, kind: continuation, from: sh, parameter: com, ds: '0.01'}", None,
     f"{EXTRA_LINE}: steps[8].ds: must be a number, got the text '0.01' (remove the quotes)"),
    ("{name: x, kind: continuation, from: sh, parameter: com, ds: 0.01, bounds: [1.0, 0.5]}",
     None, f"{EXTRA_LINE}: steps[8].bounds: must be [lo, hi] with lo < hi"),
    ("{name: x, kind: work_precision, points: [[0.9, 10.9]], methods: [euler]}", None,
     f"{EXTRA_LINE}: steps[8].methods[0]: must be 'rk45', 'dop853', 'vern9', 'rk45+pi', "
     "'dop853+pi' or 'vern9+pi', got 'euler'"),
    ("{name: x, kind: work_precision, points: [[0.9, 10.9]], rtols: [1.0e-6, 0.0]}", None,
     f"{EXTRA_LINE}: steps[8].rtols[1]: must be >= "),
    ("{name: x, kind: work_precision, points: all}", None,
     f"{EXTRA_LINE}: steps[8].points: must be a list of points"),
    ("{name: x, kind: work_precision, points: [[0.9, 10.9]], repeat: 0}", None,
     f"{EXTRA_LINE}: steps[8].repeat: must be >= 1, got 0"),
    ("{name: x, kind: work_precision, points: [[0.9, 10.9]], rtols: [1.0e-6, 1.0e-6]}", None,
     f"{EXTRA_LINE}: steps[8].rtols: rtols must be distinct"),
    # one-cycle return maps need mirror-image links: refused before any work
    ("", NON_MIRROR, "7: steps[1].kind: a floquet step needs mirror-image links"),
    ("", NON_MIRROR, "10: steps[4].kind: a continuation step needs mirror-image links"),
    # so do multi-cycle runs: each cycle is measured in the frame of the end it ends on
    ("", NON_MIRROR, "8: steps[2].kind: a tick_sweep step needs mirror-image links"),
    ("", NON_MIRROR, "9: steps[3].kind: a basin step needs mirror-image links"),
]


@pytest.mark.parametrize("extra,robot,want", BAD, ids=[w for _, _, w in BAD])
def test_bad_analysis_step_is_rejected_with_file_line_key(extra, robot, want):
    with pytest.raises(StudyError) as info:
        parse_study(study_text(extra, robot or "seed2009"), "x.yaml")
    lines = str(info.value).splitlines()
    assert any(line.startswith(f"x.yaml:{want}") for line in lines), (want, lines)


def test_mirror_links_are_not_required_by_the_other_kinds():
    """Shooting, refining and timing the integrators need no return map of one cycle."""
    text = BASE.format(robot=NON_MIRROR)
    for line in ("  - {name: fl, kind: floquet, from: sh}\n",
                 "  - {name: ts, kind: tick_sweep, from: sh, floquet: fl}\n",
                 "  - {name: co, kind: continuation, from: sh, parameter: com, ds: 0.01}\n"):
        assert line in text
        text = text.replace(line, "")
    text = "\n".join(t for t in text.splitlines() if "kind: basin" not in t) + "\n"
    loaded = parse_study(text)      # raises StudyError if any remaining step is refused
    kinds = {s.kind for s in loaded.study.steps}
    assert kinds == {"shoot", "refine", "work_precision"}


# --- end to end --------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    """The analysis smoke study through ``monkeystudy run`` on 2 workers."""
    out = tmp_path_factory.mktemp("analysis_smoke") / "out"
    result = CliRunner().invoke(app, ["run", str(SMOKE), "--out", str(out), "--workers", "2"])
    assert result.exit_code == 0, result.output
    return out, result


def _open(out: Path, name: str) -> xr.Dataset:
    with xr.open_dataset(out / name) as ds:
        return ds.load()


def test_smoke_runs_every_analysis_kind_through_the_cli(smoke):
    out, result = smoke
    assert sorted(p.name for p in out.glob("*.nc")) == sorted(SMOKE_FILES)
    assert not list(out.glob(".*"))                        # no shards or temp files left
    for name in SMOKE_FILES:
        assert f"wrote {out / name}" in result.stdout
    text = SMOKE.read_text()
    for name in SMOKE_FILES:
        ds = _open(out, name)
        kind = ds.attrs["step_kind"]
        for a in GLOBAL_ATTRS:
            assert a in ds.attrs, (name, a)
        assert ds.attrs["study_text"] == text and ds.attrs["Conventions"] == "CF-1.10"
        for v in ds.variables:
            assert "units" in ds[v].attrs and "long_name" in ds[v].attrs, (name, v)
        for v, (units, dims) in CONTRACT.get(kind, {}).items():
            assert ds[v].attrs["units"] == units, (name, v)
            assert ds[v].dims == dims, (name, v)
        for a in ATTRS.get(kind, ()):
            assert a in ds.attrs, (name, a)


def test_shoot_finds_the_exact_grazing_gait_once(smoke):
    ds = _open(smoke[0], "shoot.nc")
    method = ds["method"].values
    grazing = np.flatnonzero(method == METHOD_GRAZING)
    # both starts land on the same collisionless gait: merged into one solution
    assert grazing.size == 1
    g = int(grazing[0])
    assert json.loads(ds.attrs["solution_starts"])[g] == [0, 1]
    assert ds["error"].values[g] < 1e-20                   # exact by construction
    assert ds["converged"].values[g] == 1 and ds["status"].values[g] == 0
    assert ds["t_motor"].values[g] == 0.0
    assert ds["t_end"].values[g] == pytest.approx(2 * ds["t_switch"].values[g], rel=1e-9)
    assert ds["dtheta1"].values[g] == pytest.approx(1.49524375, abs=1e-6)
    assert ds["dtheta2"].values[g] == pytest.approx(10.2468454, abs=1e-6)
    assert int(ds.attrs["best_solution"]) == g
    h = ds["history"].values[g]
    assert h[np.isfinite(h)][-1] < 1e-13
    # gauss_newton stalls on the grazing border (the error is not smooth there)
    assert np.all(ds["error"].values[method == METHOD_GAUSS_NEWTON] > 1e-8)
    assert len(json.loads(ds.attrs["message"])) == ds.sizes["solution"]


def test_floquet_multipliers_and_agreement(smoke):
    ds = _open(smoke[0], "floquet.nc")
    assert list(ds["controller"].values) == ["open_loop", "search"]
    lam = ds["multipliers_real"].values + 1j * ds["multipliers_imag"].values
    lam_fd = ds["multipliers_fd_real"].values + 1j * ds["multipliers_fd_imag"].values
    assert np.all(ds["agreement"].values < 1e-7)            # var-eq vs finite differences
    np.testing.assert_allclose(np.abs(lam), np.abs(lam_fd), rtol=1e-6)
    assert np.all(ds["map_defect"].values < 1e-11)
    ol, se = 0, 1
    # the open-loop exact gait is unstable, its leading multiplier ~1.75
    assert ds["stable"].values[ol] == 0 and abs(lam[ol, 0]) == pytest.approx(1.748, abs=2e-3)
    np.testing.assert_array_equal(ds["fixed_point"].values[ol, 0], 0.0)
    assert ds["t_motor"].values[ol] == 0.0
    # the state-based controller: one neutral multiplier (energy), the others inside
    assert ds["stable"].values[se] == 1 and ds["neutral"].values[se] == 1
    assert np.min(np.abs(lam[se] - 1.0)) < 1e-7
    assert np.all(np.abs(lam[se][np.abs(lam[se] - 1.0) > 1e-6]) < 1.0)
    assert ds["t_motor"].values[se] > 0.0


def test_tick_sweep_exact_timing_lasts_longest(smoke):
    ds = _open(smoke[0], "ticks.nc")
    fl = _open(smoke[0], "floquet.nc")
    c = dict(zip(ds["tick"].values, ds["cycles_to_bound"].values))
    assert c[0.0] > c[0.001]                               # the tick only seeds the fall
    assert ds.sizes["cycle"] == 60 and list(ds["cycle"].values[:2]) == [1, 2]
    lead = float(ds.attrs["leading_multiplier"])
    lam = fl["multipliers_real"].values[0, 0] + 1j * fl["multipliers_imag"].values[0, 0]
    assert lead == pytest.approx(abs(lam), rel=1e-6)      # FD here, var-eq in floquet
    exact = int(np.flatnonzero(ds["tick"].values == 0.0)[0])
    assert float(ds["growth_per_cycle"][exact]) == pytest.approx(lead, rel=0.02)
    e = ds["error"].values[exact]
    k = int(ds["cycles_to_bound"][exact])
    assert e[k - 1] > 1e-2 and np.all(e[:k - 1] <= 1e-2)
    assert np.all(np.isnan(e[int(ds["cycles_completed"][exact]):]))


def test_tick_sweep_takes_the_multiplier_of_a_floquet_step(smoke):
    ds = _open(smoke[0], "ticks_var.nc")
    fl = _open(smoke[0], "floquet.nc")
    lam = fl["multipliers_real"].values[0, 0] + 1j * fl["multipliers_imag"].values[0, 0]
    assert float(ds.attrs["leading_multiplier"]) == abs(lam)
    assert "floquet step floquet" in ds.attrs["leading_multiplier_source"]


def test_shoot_from_a_refine_step(smoke):
    nm = _open(smoke[0], "nm.nc")
    ds = _open(smoke[0], "shoot_nm.nc")
    sh = _open(smoke[0], "shoot.nc")
    assert json.loads(ds.attrs["starts"]) == [[float(nm["dtheta1"]), float(nm["dtheta2"])]]
    assert ds.attrs["refine_step"] == "nm" and ds.sizes["solution"] == 1
    g = int(sh.attrs["best_solution"])
    assert ds["error"].values[0] < 1e-20
    assert ds["dtheta1"].values[0] == pytest.approx(sh["dtheta1"].values[g], abs=1e-9)


def test_basin_is_peaked_at_the_gait(smoke):
    ds = _open(smoke[0], "basin.nc")
    c = ds["cycles"].values
    assert c.shape == (21, 21) and c.dtype == np.int32
    assert c[10, 10] == c.max() and c[10, 10] > 2 * np.delete(c.ravel(), 220).max()
    assert int(ds.attrs["n_blocks"]) > 1                   # > 400 points: blocks on the pool
    assert float(ds.attrs["tick"]) == 0.0 and int(ds.attrs["max_cycles"]) == 55


def test_continuation_follows_the_family(smoke):
    ds = _open(smoke[0], "family.nc")
    sh = _open(smoke[0], "shoot.nc")
    g = int(sh.attrs["best_solution"])
    assert ds.sizes["point"] == 4 and ds.attrs["parameter"] == "com"
    assert ds["parameter_value"].values[0] == 0.543754     # seed2009's link 1 CG
    assert ds["dtheta1"].values[0] == sh["dtheta1"].values[g]
    assert np.all(ds["residual"].values < 1e-12)
    assert np.all(np.diff(ds["parameter_value"].values) > 0)
    assert json.loads(ds.attrs["folds"]) == [] and json.loads(ds.attrs["period_doublings"]) == []


def test_work_precision_dataset_is_marked_not_reproducible(smoke):
    ds = _open(smoke[0], "timing.nc")
    assert list(ds["method"].values) == ["dop853"] and list(ds["rtol"].values) == [1e-6, 1e-8]
    assert list(ds["scipy_method"].values) == ["DOP853"]
    assert int(ds.attrs["bit_reproducible"]) == 0 and "timings" in ds.attrs["reproducibility"]
    assert np.all(ds["time_per_gait"].values > 0)
    e = ds["error_value"].values[0]
    assert e[1] < e[0]                                     # tighter tolerance, smaller error
    assert np.all(ds["status_mismatch"].values == 0)


def test_inspect_summarizes_every_analysis_dataset(smoke):
    out = smoke[0]
    want = {"shoot.nc": "(best)", "floquet.nc": "open_loop: multipliers",
            "ticks.nc": "cycles to bound", "basin.nc": "cycles: at the least offset",
            "family.nc": "folds", "timing.nc": "time per gait"}
    for name, text in want.items():
        r = CliRunner().invoke(app, ["inspect", str(out / name)])
        assert r.exit_code == 0, r.output
        assert "summary:" in r.output and text in r.output, (name, r.output)


def test_dry_run_lists_the_analysis_steps_and_their_dependencies(smoke, tmp_path):
    r = CliRunner().invoke(app, ["run", str(SMOKE), "--out", str(tmp_path / "o"), "--dry-run"])
    assert r.exit_code == 0, r.output
    for line in ("shoot [shoot] -> shoot.nc: 2 tasks",
                 "floquet [floquet] -> floquet.nc: 2 tasks after shoot",
                 "ticks [tick_sweep] -> ticks.nc: 1 task after shoot",
                 "basin [basin] -> basin.nc: 6 of 6 blocks to do (441 starts, 0 saved) after "
                 "shoot", "family [continuation] -> family.nc: 1 task after shoot",
                 "timing [work_precision] -> timing.nc: 1 task"):
        assert line in r.output, (line, r.output)
    assert not (tmp_path / "o").exists()
    r = CliRunner().invoke(app, ["run", str(SMOKE), "--out", str(smoke[0]), "--dry-run"])
    assert "everything is up to date" in r.output


def test_one_worker_equals_two_except_timings(smoke, tmp_path):
    """Bit for bit, like the other steps; the work-precision timings are skipped."""
    run_study(load_study(SMOKE), tmp_path / "one", workers=1)
    assert_same_datasets(smoke[0], tmp_path / "one", list(REPRODUCIBLE))
    assert_same_datasets(smoke[0], tmp_path / "one")       # skips timing.nc by itself


def test_basin_resumes_from_saved_blocks(smoke, tmp_path):
    """Finished basin blocks are shards: a rerun computes only the missing ones and writes
    the same dataset."""
    out = tmp_path / "out"
    shutil.copytree(smoke[0], out)
    loaded = load_study(SMOKE)
    ref = _open(out, "basin.nc")
    (out / "basin.nc").unlink()
    plan = plan_study(loaded, out)
    sp = next(s for s in plan.steps if s.name == "basin")
    assert [s.name for s in plan.steps if not s.up_to_date] == ["basin"]
    folder = shard_dir(out, "basin", sp.key)
    flat = ref["cycles"].values.ravel()
    for b in sp.blocks[:4]:
        write_shard(folder, b, {"cycles": flat[b.lo:b.hi]})
    summary = run_study(loaded, out, workers=2)
    assert summary.blocks_reused == 4 and summary.blocks_computed == len(sp.blocks) - 4
    assert [p.name for p in summary.written] == ["basin.nc"]
    assert not list(out.glob(".basin.parts"))
    assert_same_datasets(smoke[0], out, ["basin.nc"])


def test_a_dependency_without_a_usable_gait_fails_clearly(tmp_path):
    text = """\
schema_version: 1
name: nogait
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.0}
integrator: {rtol: 1.0e-10, atol: 1.0e-12}
steps:
  - {name: gn, kind: shoot, starts: [[1.0, 12.0]], method: gauss_newton, max_iter: 3}
  - {name: family, kind: continuation, from: gn, parameter: gravity, ds: 0.1, steps: 2}
"""
    study = write_study(tmp_path, text, "nogait.yaml")
    with pytest.raises(RunFailed, match="family: shoot step 'gn' produced no converged "
                                          "grazing gait"):
        run_study(load_study(study), tmp_path / "out", workers=1)
    assert (tmp_path / "out" / "gn.nc").exists()
    assert not (tmp_path / "out" / "family.nc").exists()


# --- task functions ------------------------------------------------------------------------------
def test_dedup_keeps_the_lower_error_and_every_start():
    def cand(d1, err, method=1):
        return {"dtheta1": d1, "dtheta2": 10.0, "error": err, "method": method,
                "t_switch": 0.4, "message": f"found {err:g}"}
    results = [{"start": (1.0, 12.0), "candidates": [cand(1.5, 400.0), cand(1.2, 1e-3, 0)],
                "failures": []},
               {"start": (1.4, 10.3), "candidates": [cand(1.5 + 1e-8, 1e-27)],
                "failures": ["gauss_newton: no gait"]}]
    sols, fails = dedup_solutions(results, 1e-6)
    assert [s["dtheta1"] for s in sols] == [1.5 + 1e-8, 1.2]
    assert sols[0]["error"] == 1e-27 and sols[0]["starts"] == [0, 1]
    assert sols[0]["start_index"] == 0
    assert sols[0]["message"] == ("found 1e-27; the same rates were also reached from start 0 "
                                  "by grazing with the swap at 0.4 s and gait error 400; the "
                                  "lower error is kept")
    assert sols[1]["message"] == "found 0.001"
    assert fails == ["start 1 [1.4, 10.3]: gauss_newton: no gait"]


def test_growth_and_cycles_to_bound():
    e = (1e-9 * 1.5 ** np.arange(40)) ** 2
    assert growth_per_cycle(e) == pytest.approx(1.5, rel=1e-9)
    assert np.isnan(growth_per_cycle(np.array([1e-3, 1e-2])))
    assert cycles_to_bound(np.array([1e-5, 1e-3, 2e-2, 1.0]), 1e-2) == 3
    assert cycles_to_bound(np.array([1e-5, 1e-3]), 1e-2) == 2


def test_basin_blocks_are_whole_rows():
    st = parse_study(study_text(
        "{name: big, kind: basin, from: sh, offsets: {d_dtheta1: {start: 0.0, stop: 1.0, "
        "num: 30}, d_dtheta2: {start: 0.0, stop: 1.0, num: 21}}}")).study.step("big")
    blocks = REGISTRY["basin"].blocks(st)
    assert blocks[0].lo == 0 and blocks[-1].hi == 630
    assert all(b.lo % 21 == 0 and b.hi % 21 == 0 for b in blocks)
    assert all(blocks[i].hi == blocks[i + 1].lo for i in range(len(blocks) - 1))
    assert len(blocks) == 8                                # 4 rows (84 points) per block
