"""The basin step: cycles to failure over offsets of the start, in resumable blocks.

The end-to-end cases read the analysis smoke study's datasets (``analysis_smoke``,
tests/study/steps/conftest.py)."""
from __future__ import annotations

import shutil

import numpy as np

from monkeystudy.study import load_study, parse_study, plan_study, run_study
from monkeystudy.study.blocks import shard_dir, write_shard
from monkeystudy.study.steps import REGISTRY

from studyhelpers import (ANALYSIS_SMOKE as SMOKE, assert_same_datasets,
                          assert_written_as_declared, open_dataset)

#: a basin of 30 x 21 offsets of a shoot step's gait (how its points fall into blocks)
BIG_BASIN = """\
schema_version: 1
name: v
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.0}
steps:
  - {name: sh, kind: shoot, starts: [[1.0, 12.0]]}
  - {name: big, kind: basin, from: sh, offsets: {d_dtheta1: {start: 0.0, stop: 1.0, num: 30}, d_dtheta2: {start: 0.0, stop: 1.0, num: 21}}}
"""


def test_basin_is_peaked_at_the_gait(analysis_smoke):
    ds = open_dataset(analysis_smoke[0], "basin.nc")
    c = ds["cycles"].values
    assert c.shape == (21, 21) and c.dtype == np.int32
    assert c[10, 10] == c.max() and c[10, 10] > 2 * np.delete(c.ravel(), 220).max()
    assert int(ds.attrs["n_blocks"]) > 1                   # > 400 points: blocks on the pool
    assert float(ds.attrs["tick"]) == 0.0 and int(ds.attrs["max_cycles"]) == 55


def test_basin_resumes_from_saved_blocks(analysis_smoke, tmp_path):
    """Finished basin blocks are shards: a rerun computes only the missing ones and writes
    the same dataset."""
    out = tmp_path / "out"
    shutil.copytree(analysis_smoke[0], out)
    loaded = load_study(SMOKE)
    ref = open_dataset(out, "basin.nc")
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
    assert_same_datasets(analysis_smoke[0], out, ["basin.nc"])


def test_basin_blocks_are_whole_rows():
    st = parse_study(BIG_BASIN).study.step("big")
    blocks = REGISTRY["basin"].blocks(st)
    assert blocks[0].lo == 0 and blocks[-1].hi == 630
    assert all(b.lo % 21 == 0 and b.hi % 21 == 0 for b in blocks)
    assert all(blocks[i].hi == blocks[i + 1].lo for i in range(len(blocks) - 1))
    assert len(blocks) == 8                                # 4 rows (84 points) per block


def test_basin_datasets_are_written_as_declared(analysis_smoke):
    assert_written_as_declared(analysis_smoke[0] / "basin.nc", "basin")
