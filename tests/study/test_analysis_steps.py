"""The analysis step kinds together (shoot, floquet, tick_sweep, basin, continuation,
work_precision): validation with file:line: key, the analysis smoke study end to end through
the CLI and the runner (``analysis_smoke``, tests/study/conftest.py), the dataset contract of
docs/datasets.md. Each kind's own physics is tested in tests/study/steps/test_<kind>.py."""
from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from monkeystudy.cli import app
from monkeystudy.study import StudyError, load_study, parse_study, run_study
from monkeystudy.study.errors import RunFailed
from monkeystudy.study.steps.basin import BasinStep
from monkeystudy.study.steps.continuation import ContinuationStep
from monkeystudy.study.steps.floquet import FloquetStep
from monkeystudy.study.steps.shoot import ShootStep
from monkeystudy.study.steps.tick_sweep import TickSweepStep
from monkeystudy.study.steps.work_precision import WorkPrecisionStep

from studyhelpers import ANALYSIS_SMOKE as SMOKE, assert_same_datasets, open_dataset, write_study

ROOT = Path(__file__).resolve().parents[2]
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
     "'mass_ratio', 'joint_viscous', 'pivot_viscous', 'link1_mass', 'link1_com', "
     "'link1_inertia', 'link2_mass', 'link2_com' or 'link2_inertia', got 'mass'"),
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
def test_smoke_runs_every_analysis_kind_through_the_cli(analysis_smoke):
    out, result = analysis_smoke
    assert sorted(p.name for p in out.glob("*.nc")) == sorted(SMOKE_FILES)
    assert not list(out.glob(".*"))                        # no shards or temp files left
    for name in SMOKE_FILES:
        assert f"wrote {out / name}" in result.stdout
    text = SMOKE.read_text()
    for name in SMOKE_FILES:
        ds = open_dataset(out, name)
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


def test_inspect_summarizes_every_analysis_dataset(analysis_smoke):
    out = analysis_smoke[0]
    want = {"shoot.nc": "(best)", "floquet.nc": "open_loop: multipliers",
            "ticks.nc": "cycles to bound", "basin.nc": "cycles: at the least offset",
            "family.nc": "folds", "timing.nc": "time per gait"}
    for name, text in want.items():
        r = CliRunner().invoke(app, ["inspect", str(out / name)])
        assert r.exit_code == 0, r.output
        assert "summary:" in r.output and text in r.output, (name, r.output)


def test_dry_run_lists_the_analysis_steps_and_their_dependencies(analysis_smoke, tmp_path):
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
    r = CliRunner().invoke(app, ["run", str(SMOKE), "--out", str(analysis_smoke[0]), "--dry-run"])
    assert "everything is up to date" in r.output


def test_one_worker_equals_two_except_timings(analysis_smoke, tmp_path):
    """Bit for bit, like the other steps; the work-precision timings are skipped."""
    run_study(load_study(SMOKE), tmp_path / "one", workers=1)
    assert_same_datasets(analysis_smoke[0], tmp_path / "one", list(REPRODUCIBLE))
    assert_same_datasets(analysis_smoke[0], tmp_path / "one")       # skips timing.nc by itself


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


