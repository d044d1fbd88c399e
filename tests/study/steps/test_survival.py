"""The survival step kind end to end: the smoke study through the command line, its dataset
contract, bit-identical results for one and two workers and after a resume."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner

from monkeystudy.cli import app
from monkeystudy.kernel import layout as L
from monkeystudy.study import load_study, plan_study, run_study
from monkeystudy.study.blocks import shard_dir, write_shard
from monkeystudy.study.steps.survival import FAILURE_NAMES, SurvivalStep

from studyhelpers import assert_same_datasets, assert_written_as_declared

ROOT = Path(__file__).resolve().parents[3]
SMOKE = ROOT / "studies" / "survival_smoke.yaml"

#: the survival dataset's variables (docs/datasets.md), with units and dims
CONTRACT = {
    "noise_timing": ("s", ("level",)), "noise_angle": ("rad", ("level",)),
    "mfpt": ("1", ("level",)), "mfpt_low": ("1", ("level",)), "mfpt_high": ("1", ("level",)),
    "mfpt_distance": ("m", ("level",)), "mfpt_method": ("1", ("level",)),
    "restricted_mean": ("1", ("level",)), "hazard_early": ("1", ("level",)),
    "hazard_late": ("1", ("level",)), "advance_per_cycle": ("m", ("level",)),
    "cycles_completed": ("1", ("level", "run")), "failure": ("1", ("level", "run")),
    "distance": ("m", ("level", "run")), "time_survived": ("s", ("level", "run")),
    "final_error": ("rad2 + rad2 s-2", ("level", "run")),
    "survival": ("1", ("level", "cycle")), "failure_count": ("1", ("level", "failure_mode")),
    "height_drift": ("m", ("level", "run")), "noise_latency": ("s", ("level",)),
}


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    out = tmp_path_factory.mktemp("survival") / "out"
    result = CliRunner().invoke(app, ["run", str(SMOKE), "--out", str(out), "--workers", "2"])
    assert result.exit_code == 0, result.output
    return out, result.output


def _open(folder, name):
    with xr.open_dataset(folder / name) as ds:
        return ds.load()


def test_the_smoke_study_writes_the_contract(smoke):
    out, log = smoke
    assert "open_loop: done" in log and "MFPT" in log
    for name in ("open_loop.nc", "state_based.nc"):
        ds = _open(out, name)
        for v, (units, dims) in CONTRACT.items():
            assert ds[v].attrs["units"] == units, (name, v)
            assert ds[v].dims == dims, (name, v)
        for v in ds.variables:
            assert ds[v].attrs.get("units") and ds[v].attrs.get("long_name"), (name, v)
        assert list(ds["failure_mode"].values) == list(FAILURE_NAMES)
        # the bookkeeping adds up: every run ended one way, and the curve starts at 1
        counts = ds["failure_count"].values
        assert np.all(counts.sum(axis=1) == ds.sizes["run"])
        assert np.all(ds["survival"].values[:, 0] == 1.0)
        assert np.all(np.diff(ds["survival"].values, axis=1) <= 0)
        for i in range(ds.sizes["level"]):
            done = ds["cycles_completed"].values[i]
            survived = ds["failure"].values[i] == L.ST_OK
            assert np.all(done[survived] == ds.attrs["max_cycles"])
            assert np.all(done[~survived] < ds.attrs["max_cycles"])


def test_the_open_loop_gait_fails_within_tens_of_cycles_and_sooner_with_more_jitter(smoke):
    ds = _open(smoke[0], "open_loop.nc")
    assert list(ds["noise_timing"].values) == [1e-5, 1e-3]
    assert np.all(ds["failure"].values != L.ST_OK)             # none survives 100 cycles
    mean = ds["mfpt"].values
    assert np.all(ds["mfpt_method"].values == 0)               # uncensored: the sample mean
    np.testing.assert_array_equal(mean, ds["cycles_completed"].values.mean(axis=1))
    assert 10 < mean[1] < mean[0] < 60


def test_one_worker_equals_two_and_a_resume_equals_both(smoke, tmp_path):
    out, _ = smoke
    run_study(load_study(SMOKE), tmp_path / "one", workers=1)
    assert_same_datasets(out, tmp_path / "one")
    # a run interrupted after some blocks: its shards are reused, the dataset is the same
    resumed = tmp_path / "resumed"
    shutil.copytree(out, resumed)
    ref = _open(out, "state_based.nc")
    (resumed / "state_based.nc").unlink()
    loaded = load_study(SMOKE)
    sp = next(s for s in plan_study(loaded, resumed).steps if s.name == "state_based")
    assert len(sp.blocks) >= 2
    flat = {"cycles": ref["cycles_completed"].values.ravel(),
            "failure": ref["failure"].values.ravel(), "distance": ref["distance"].values.ravel(),
            "time": ref["time_survived"].values.ravel(), "error": ref["final_error"].values.ravel(),
            "height": ref["height_drift"].values.ravel()}
    b = sp.blocks[0]
    # nfev is not in the dataset per run: only its total; a shard carries what a block computed
    nfev = np.full(b.size, int(ref.attrs["total_nfev"]) // ref["cycles_completed"].size)
    write_shard(shard_dir(resumed, "state_based", sp.key), b,
                {k: v[b.lo:b.hi] for k, v in flat.items()} | {"nfev": nfev})
    summary = run_study(loaded, resumed, workers=2)
    assert summary.blocks_reused == 1
    got = _open(resumed, "state_based.nc")
    for v in CONTRACT:
        np.testing.assert_array_equal(got[v].values, ref[v].values, err_msg=v)


def test_levels_come_from_the_lists_and_scalars_apply_to_every_level():
    step = SurvivalStep.model_validate({
        "name": "s", "kind": "survival", "from": "g", "runs": 3, "max_cycles": 10,
        "noise": {"timing": [1e-4, 1e-3], "sensor": {"angle": 1e-3},
                  "parameters": {"mass": [0.0, 0.01]}}})
    assert step.n_levels == 2 and step.noise.swept() == ["timing", "mass"]
    assert step.noise.level(1).timing == 1e-3 and step.noise.level(1).mass == 0.01
    assert step.noise.level(0).angle == step.noise.level(1).angle == 1e-3
    blocks = [(b.lo, b.hi) for b in __import__("monkeystudy.study.steps", fromlist=["REGISTRY"])
              .REGISTRY["survival"].blocks(step)]
    assert blocks == [(0, 3), (3, 6)]                          # no block spans two levels


def test_every_noise_source_is_a_key_of_the_study_file_and_a_variable_of_the_dataset():
    """The study file's noise: states each declared source at its key, with its bound, and
    nothing else; the survival dataset has a noise_<name> variable of each, in its units."""
    import pydantic

    from monkeystudy.analysis.survival import SOURCES
    from monkeystudy.study.noise import NoiseSpec
    from monkeystudy.study.steps.survival import VARIABLES

    def keys(model, above=()):
        for name, f in model.model_fields.items():
            sub = f.annotation if isinstance(f.annotation, type) and issubclass(
                f.annotation, pydantic.BaseModel) else None
            yield from keys(sub, above + (name,)) if sub else [above + (name,)]

    assert set(keys(NoiseSpec)) - {("distribution",)} == {s.key for s in SOURCES}
    def stated(key, value) -> dict:
        return {key[0]: stated(key[1:], value) if len(key) > 1 else value}

    for s in SOURCES:
        spec = NoiseSpec.model_validate(stated(s.key, [0.0, 0.1]))
        assert spec.swept() == [s.name] and getattr(spec.level(1), s.name) == 0.1
        if s.bound is not None:
            with pytest.raises(pydantic.ValidationError, match=f"<= {s.bound}"):
                NoiseSpec.model_validate(stated(s.key, 2 * s.bound))
    noise = {k: v for k, v in VARIABLES.items() if k.startswith("noise_")}
    assert {k: v.units for k, v in noise.items()} == {f"noise_{s.name}": s.units
                                                      for s in SOURCES}


def test_the_smoke_datasets_are_written_as_declared(smoke):
    for name in ("open_loop.nc", "state_based.nc"):
        assert_written_as_declared(smoke[0] / name, "survival")


#: the 2009 gait's grazing fixed point found at rtol 1e-8, analysed by a floquet step as the
#: shoot step's point (the open_loop map: not polished), run for a few cycles and under noise
OPEN_LOOP_AT_RTOL_1E8 = """\
schema_version: 1
name: open_loop_at_rtol_1e8
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.0}
integrator: {rtol: 1.0e-8, atol: 1.0e-10}
steps:
  - {name: shoot, kind: shoot, starts: [[1.0, 12.0], [1.44, 10.31]], method: grazing}
  - {name: floquet, kind: floquet, from: shoot, controllers: [open_loop]}
  - {name: cycles, kind: stability, from: floquet, cycles: 2}
  - {name: survive, kind: survival, from: floquet, runs: 2, max_cycles: 3,
     noise: {timing: 1.0e-5}}
"""


def test_a_floquet_point_converged_to_its_maps_error_level_is_run(tmp_path):
    """At rtol 1e-8 the map moves the shoot's converged point by about 1.3e-8, within the
    map's own error level (the map at a tenth of the tolerances moves by as much): the point
    is converged, and survival runs it as stability does. The 1e-8 bound on the map defect
    is what lets survival and design take a point whose Newton polish stopped short."""
    from studyhelpers import write_study

    study = write_study(tmp_path, OPEN_LOOP_AT_RTOL_1E8, "open_loop.yaml")
    run_study(load_study(study), tmp_path / "out", workers=1)
    with xr.open_dataset(tmp_path / "out" / "floquet.nc") as f, \
            xr.open_dataset(tmp_path / "out" / "survive.nc") as s:
        defect, level = float(f["map_defect"].values[0]), float(f["map_error"].values[0])
        assert int(f["newton_converged"].values[0]) == 1
        assert 1e-8 < defect < 10 * level          # beyond 1e-8, within the map's error
        assert s.attrs["floquet_step"] == "floquet"
        assert s.attrs["floquet_controller"] == "open_loop"
        assert s.attrs["map_defect"] == defect
        assert np.all(s["cycles_completed"].values == 3)


#: the two-swap bar brachiation of tests/test_motor.py (AcroMonk from its URDF, the identified
#: elbow friction and rotor, no hook friction), refined from its fixed point and run under
#: the noise of a built robot on a ladder: friction drawn per run, the ladder's spacing
BAR_STUDY = """\
schema_version: 1
name: bar_survival
robot:
  urdf: {urdf}
  links: [hook_1, link_2]
  joints: [virtul_joint_hook_1, joint_1]
  far_grip: hook_2
  friction: {{joint: {{viscous: 0.04144}}}}
  rotor: {{inertia: 2.453e-4, gear_ratio: 6, housing: 1}}
gait: {gait}
integrator: {{method: dop853, rtol: 1.0e-12, atol: 1.0e-13, max_time: 6.0}}
steps:
  - {{name: refine, kind: refine, start: [{d1}, {d2}], xatol: 1.0e-10, fatol: 1.0e-18}}
  - name: survive
    kind: survival
    from: refine
    runs: 6
    max_cycles: 3
    seed: 4
    min_advance: 0.3
    noise:
      bar_spacing: 1.0e-3
      friction: {{joint_viscous: [0.0, 1.0e-5]}}
"""


@pytest.fixture(scope="module")
def bar_survival(tmp_path_factory):
    import json

    from studyhelpers import write_study
    from test_motor import BAR_BRACHIATION, Z_BAR_BRACHIATION

    folder = tmp_path_factory.mktemp("bar_survival")
    urdf = ROOT / "data" / "acromonk" / "model" / "acromonk.urdf"
    study = write_study(folder, BAR_STUDY.format(urdf=urdf, gait=json.dumps(BAR_BRACHIATION),
                                                 d1=Z_BAR_BRACHIATION[1],
                                                 d2=Z_BAR_BRACHIATION[2]), "bar.yaml")
    run_study(load_study(study), folder / "out", workers=1)
    return folder / "out", urdf


def test_a_bar_gaits_mfpt_is_stated_in_brachiations_too(bar_survival):
    """A gait that catches two bars per cycle: the dataset says so (catches_per_cycle) and
    gives the MFPT and its interval in brachiations, twice the cycles; the noise variables
    of the sources the study sets are written in their units, those it leaves out are not."""
    ds = _open(bar_survival[0], "survive.nc")
    assert ds.attrs["catches_per_cycle"] == 2
    for key in ("mfpt", "mfpt_low", "mfpt_high"):
        cycles, brachiations = ds[key].values, ds[f"{key}_brachiations"].values
        assert np.array_equal(np.isnan(cycles), np.isnan(brachiations)), key
        assert np.all(brachiations[~np.isnan(cycles)] == 2 * cycles[~np.isnan(cycles)]), key
        assert "brachiations" in ds[f"{key}_brachiations"].attrs["long_name"]
    # every noiseless-friction run lasts: its advance of 0.68 m per cycle towards -x is
    # measured the way it travels, not stalled below min_advance
    assert ds["restricted_mean"].values[0] == 3.0
    assert list(ds["noise_bar_spacing"].values) == [1e-3, 1e-3]
    assert ds["noise_bar_spacing"].attrs["units"] == "m"
    assert list(ds["noise_joint_viscous"].values) == [0.0, 1e-5]
    assert ds["noise_joint_viscous"].attrs["units"] == "N m s"
    for absent in ("noise_pivot_viscous", "noise_pivot_coulomb", "noise_joint_coulomb"):
        assert absent not in ds
    # the ladder differs from run to run: so does the distance of the runs that lasted
    done = ds["failure"].values[0] == L.ST_OK
    assert len(set(ds["distance"].values[0][done])) == done.sum() > 1
    assert_written_as_declared(bar_survival[0] / "survive.nc", "survival")


def test_a_urdf_robots_datasets_name_the_file_and_its_hash(bar_survival):
    from monkeystudy.study.provenance import file_sha256

    out, urdf = bar_survival
    for name in ("refine.nc", "survive.nc"):
        ds = _open(out, name)
        assert ds.attrs["robot_urdf"] == str(urdf)
        assert ds.attrs["robot_urdf_sha256"] == file_sha256(urdf)


def test_a_gait_without_bars_has_no_brachiations_and_no_later_noise_variables(smoke):
    """The smoke study (the 2009 robot's magnet gait, a preset robot): no catches_per_cycle,
    no MFPT in brachiations, no noise variable of a source it does not set, no URDF."""
    for name in ("open_loop.nc", "state_based.nc"):
        ds = _open(smoke[0], name)
        assert "catches_per_cycle" not in ds.attrs and "robot_urdf" not in ds.attrs
        assert not [v for v in ds.variables if v.endswith("_brachiations")]
        for absent in ("noise_bar_spacing", "noise_pivot_coulomb", "noise_joint_viscous"):
            assert absent not in ds


def test_noise_keys_added_later_are_in_the_step_only_when_set():
    """friction and bar_spacing appear in a step's dump (its datasets' step attribute, its
    key) only when the study sets them: studies without them keep their step keys."""
    base = {"name": "s", "kind": "survival", "from": "g", "runs": 3, "max_cycles": 10,
            "noise": {"timing": 1e-3}}
    dumped = SurvivalStep.model_validate(base).model_dump(mode="json", by_alias=True)
    assert set(dumped["noise"]) == {"distribution", "timing", "sensor", "torque",
                                    "parameters", "initial_state"}
    both = SurvivalStep.model_validate(dict(base, noise={
        "timing": 1e-3, "bar_spacing": 1e-3, "friction": {"pivot_coulomb": 0.1}}))
    dumped = both.model_dump(mode="json", by_alias=True)
    assert dumped["noise"]["bar_spacing"] == 1e-3
    assert dumped["noise"]["friction"]["pivot_coulomb"] == 0.1
    assert both.noise.level(0).to_dict()["pivot_coulomb"] == 0.1
    assert "joint_coulomb" not in both.noise.level(0).to_dict()
