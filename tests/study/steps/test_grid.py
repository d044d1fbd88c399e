"""The grid step: its task, its streamed dataset, the starts it gives a refine step."""
from __future__ import annotations


import numpy as np
import pytest
import xarray as xr

from monkeystudy import Integrator, Robot, evaluate_gaits
from monkeystudy.kernel.layout import ST_OK, ST_UNREACHABLE
from monkeystudy.study import datasets as D
from monkeystudy.study.blocks import make_blocks
from monkeystudy.study.runner import load_kernels, run_grid
from monkeystudy.study.spec import GaitSpec
from monkeystudy.study.steps import grid
from monkeystudy.study.steps.gait_source import best_grid_points

from studyhelpers import assert_written_as_declared

TORQUE = 0.6354
INTEG = Integrator(rtol=1e-8, atol=1e-10)


@pytest.fixture(scope="module")
def spec():
    s = GaitSpec(Robot.preset("seed2009"), INTEG, TORQUE, 0.001)
    load_kernels(s, runs=True)
    return s


def test_grid_block_is_evaluate_gaits(spec):
    pts = np.array([[0.902, 10.935], [0.0, 9.0], [1.5, 12.0], [0.1, 5.0]])
    got = grid.grid_block(spec, pts)
    ref = evaluate_gaits(pts, robot="seed2009", torque=TORQUE, tick=0.001, integrator=INTEG)
    for k, dt in grid.HORIZONTAL_VARIABLES.items():
        assert got[k].dtype == dt
        np.testing.assert_array_equal(got[k], ref[k].astype(dt))
    assert got["status"][3] == ST_UNREACHABLE        # too little energy to reach the swap
    assert np.isnan(got["error"][got["status"] != ST_OK]).all()


def test_best_grid_points_prefers_local_minima():
    d1 = np.linspace(0, 1, 5)
    d2 = np.linspace(0, 1, 6)
    e = np.add.outer((d1 - 0.25) ** 2, (d2 - 0.2) ** 2) + 1.0
    e[4, 5] = 0.5                     # a corner minimum, lower than the bowl
    e[0, 0] = np.nan                  # failed point: ignored
    pts = best_grid_points(e, d1, d2, 3)
    np.testing.assert_array_equal(pts[0], [1.0, 1.0])
    np.testing.assert_array_equal(pts[1], [0.25, 0.2])
    assert len(pts) == 3
    with pytest.raises(ValueError):
        best_grid_points(np.full((2, 2), np.nan), d1[:2], d2[:2], 1)


@pytest.mark.parametrize("block_size", [1, 4, 7, 9, 11, 40])
def test_grid_streams_blocks_that_cut_rows(tmp_path, block_size):
    a1, a2 = np.linspace(0, 1, 4), np.linspace(5, 6, 9)
    n = a1.size * a2.size
    flat = {k: (np.arange(n) * 1.5).astype(dt) for k, dt in grid.HORIZONTAL_VARIABLES.items()}
    flat["status"] = (np.arange(n) % 6).astype(np.int8)
    blocks = [(b.lo, {k: v[b.lo:b.hi] for k, v in flat.items()})
              for b in make_blocks(n, block_size)]
    info = grid.write_grid(tmp_path / "g.nc", {"study_name": "t"}, axes=(a1, a2), blocks=blocks)
    assert info["skipped_fraction"] == pytest.approx(np.mean(flat["status"] == 5))
    with xr.open_dataset(tmp_path / "g.nc", engine="netcdf4") as ds:
        for k, v in flat.items():
            np.testing.assert_array_equal(ds[k].values, v.reshape(4, 9))
        assert ds["status"].attrs["flag_meanings"].split()[5] == "unreachable"


def test_run_grid_serial_and_pool_agree():
    a1, a2 = np.linspace(0.5, 1.5, 5), np.linspace(10.0, 12.0, 7)
    serial = run_grid(a1, a2, tick=0.001, integrator=INTEG, workers=0, block_size=6)
    pooled = run_grid(a1, a2, tick=0.001, integrator=INTEG, workers=2, block_size=6)
    for k in grid.HORIZONTAL_VARIABLES:
        assert serial[k].shape == (5, 7)
        assert serial[k].tobytes() == pooled[k].tobytes()
    pts = np.stack(np.meshgrid(a1, a2, indexing="ij"), -1).reshape(-1, 2)
    flat = run_grid(pts, tick=0.001, integrator=INTEG, workers=0)
    assert flat["error"].shape == (35,)
    assert flat["error"].tobytes() == serial["error"].ravel().tobytes()


def test_coalesce_merges_contiguous_blocks_up_to_the_limit():
    variables = {"status": np.int8, "error": np.float64}

    def block(lo, m):
        return lo, {"status": np.arange(lo, lo + m) % 7, "error": np.arange(lo, lo + m) * 0.5}

    # contiguous 0..30 in blocks of 10, then a gap (40..), then one block larger than the limit
    blocks = [block(0, 10), block(10, 10), block(20, 10), block(40, 10), block(50, 35)]
    pieces = list(grid.coalesce(iter(blocks), variables, limit=25))
    assert [(lo, len(a["status"])) for lo, a in pieces] == [(0, 20), (20, 10), (40, 10),
                                                            (50, 35)]
    for lo, a in pieces:
        m = len(a["status"])
        assert a["status"].dtype == np.int8 and a["error"].dtype == np.float64
        np.testing.assert_array_equal(a["status"], np.arange(lo, lo + m) % 7)
        np.testing.assert_array_equal(a["error"], np.arange(lo, lo + m) * 0.5)


def test_grid_consolidation_memory_is_flat(tmp_path, monkeypatch):
    """Streaming 100 blocks of 1000 points holds about one write buffer in memory, not the
    grid (the buffer is made small here so that a 10^5-point grid is many buffers)."""
    import tracemalloc

    monkeypatch.setattr(D, "WRITE_BUFFER_POINTS", 4000)
    a1, a2 = np.linspace(0, 1, 100), np.linspace(0, 1, 1000)

    def blocks():
        for i in range(100):
            yield i * 1000, {k: np.full(1000, i % 100, dt)
                             for k, dt in grid.HORIZONTAL_VARIABLES.items()}

    tracemalloc.start()
    try:
        grid.write_grid(tmp_path / "big.nc", {}, axes=(a1, a2), blocks=blocks())
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    full = 100 * 1000 * sum(np.dtype(dt).itemsize for dt in grid.HORIZONTAL_VARIABLES.values())
    assert peak < full / 5, (peak, full)
    with xr.open_dataset(tmp_path / "big.nc") as ds:
        assert int(ds["steps"][99, 999]) == 99


@pytest.mark.parametrize("layout", ["axes", "points"])
def test_grid_records_its_least_error_and_where(tmp_path, layout):
    rng = np.random.default_rng(7)
    a1, a2 = np.linspace(0, 1, 5), np.linspace(5, 6, 7)
    n = a1.size * a2.size
    flat = {k: np.zeros(n, dt) for k, dt in grid.HORIZONTAL_VARIABLES.items()}
    flat["error"] = rng.uniform(1.0, 2.0, n)
    flat["error"][::3] = np.nan                     # failed points carry no error
    flat["error"][23] = 0.25
    blocks = [(b.lo, {k: v[b.lo:b.hi] for k, v in flat.items()}) for b in make_blocks(n, 4)]
    seen = []

    def kind(d1, d2):
        seen.append((d1, d2))
        return {"least_error_vertical_passes": 3}

    pts = np.stack(np.meshgrid(a1, a2, indexing="ij"), -1).reshape(-1, 2)
    where = {"axes": (a1, a2)} if layout == "axes" else {"points": pts}
    info = grid.write_grid(tmp_path / "g.nc", {}, blocks=blocks, least_error_attrs=kind, **where)
    assert seen == [tuple(pts[23])]                  # asked once, at the least error's start
    assert info["least_error"] == 0.25 and info["least_error_at"] == tuple(pts[23])
    a = D.read_attrs(tmp_path / "g.nc")
    assert (a["least_error"], a["least_error_dtheta1"], a["least_error_dtheta2"]) == \
        (0.25, pts[23, 0], pts[23, 1])
    assert a["least_error_vertical_passes"] == 3

    flat["error"][:] = np.nan                        # no error anywhere: no such attributes
    blocks = [(0, flat)]
    info = grid.write_grid(tmp_path / "none.nc", {}, blocks=blocks, least_error_attrs=kind, **where)
    assert info["least_error_at"] is None and len(seen) == 1
    assert "least_error" not in D.read_attrs(tmp_path / "none.nc")


def test_grid_names_the_kind_of_its_best_start(tmp_path):
    """A start that swaps only on the backswing is reported as another gait, in the log line,
    the dataset and ``inspect``'s summary."""
    from monkeystudy.study import load_study, run_study
    from monkeystudy.study.steps import REGISTRY
    from studyhelpers import write_study

    text = """\
schema_version: 1
name: kinds
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
integrator: {rtol: 1.0e-8, atol: 1.0e-10}
steps:
  - {name: late, kind: grid, points: [[0.85, 10.85], [0.3, 10.0]]}
"""
    out = tmp_path / "out"
    summary = run_study(load_study(write_study(tmp_path, text)), out, workers=1)
    a = D.read_attrs(out / "late.nc")
    assert a["least_error_dtheta1"] == 0.85 and a["least_error_dtheta2"] == 10.85
    assert a["least_error_vertical_passes"] == 1    # tests/analysis/test_gait_kind.py
    with xr.open_dataset(out / "late.nc", engine="netcdf4") as ds:
        line = REGISTRY["grid"].describe(ds)[-1]
    assert "not a first-swing gait" in line and "swap at 1.2" in line, line
    assert "not a first-swing gait" in summary.notes["late"], summary.notes


def point_list_dims(name: str, dims: tuple) -> tuple:
    """The dims of a point-list grid's variable declared over the axes."""
    if name in grid.MAP:
        return ("point",)
    return ("point",) + dims[2:] if dims[:2] == grid.MAP else dims


def test_grid_datasets_are_written_as_declared(tiny_reference):
    out = tiny_reference[1]
    assert_written_as_declared(out / "map.nc", "grid")
    assert_written_as_declared(out / "pts.nc", "grid", dims_of=point_list_dims)


@pytest.mark.parametrize("finite, k, says", [
    (1, 3, "3 starts requested, but only 1 of its 4 points has a gait (an error value): ask "
           "for at most 1, or widen or move the grid"),
    (2, 3, "only 2 of its 4 points have a gait"),
    (0, 1, "1 start requested, but none of its 4 points has a gait (no error value; its "
           "status says why): widen or move the grid"),
])
def test_best_grid_points_says_how_many_points_have_a_gait(finite, k, says):
    e = np.full((2, 2), np.nan)
    e.ravel()[:finite] = 1.0
    with pytest.raises(ValueError) as exc:
        best_grid_points(e, np.arange(2.0), np.arange(2.0), k)
    assert says in str(exc.value) and " 1 points" not in str(exc.value)
