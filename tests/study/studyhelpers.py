"""Helpers of the study tests: a small study, and bit-for-bit dataset comparison."""
from __future__ import annotations

import re
import threading
from pathlib import Path

import numpy as np
import xarray as xr

from monkeystudy.study.progress import Reporter

#: A small study exercising every step kind: a 7 x 9 grid in blocks of 10 points (blocks cut
#: rows), a point-list grid, a two-start refinement from the grid's minima and a stability
#: run of the best one with the run-on clock.
TINY = """\
schema_version: 1
name: tiny
description: small study for the runner tests
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
integrator: {rtol: 1.0e-8, atol: 1.0e-10}
steps:
  - {name: map, kind: grid, block_size: 10,
     dtheta1: {start: 0.0, stop: 2.0, num: 7}, dtheta2: {start: 9.5, stop: 12.5, num: 9}}
  - {name: pts, kind: grid, points: [[0.9, 10.9], [1.0, 11.0], [0.1, 9.0]], block_size: 2}
  - {name: best, kind: refine, start: {from: map, best: 2}, maxiter: 15}
  - {name: cycles, kind: stability, from: best, cycles: 3, controller: {clock: run_on}}
"""

TINY_FILES = ("map.nc", "pts.nc", "best.nc", "cycles.nc")


def write_study(folder: Path, text: str = TINY, name: str = "tiny.yaml") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    p = folder / name
    p.write_text(text)
    return p


def assert_same_datasets(a: Path, b: Path, names=None) -> None:
    """Every dataset in folder ``a`` equals its namesake in ``b`` bit for bit (values, dtypes,
    attributes), except the ``history`` attribute (the time of the run).

    Without ``names``, datasets marked ``bit_reproducible = 0`` (work_precision: wall-clock
    timings) are skipped."""
    if names is None:
        names = sorted(p.name for p in Path(a).glob("*.nc") if _reproducible(p))
    assert names, f"no datasets in {a}"
    for name in names:
        with xr.open_dataset(Path(a) / name, engine="netcdf4") as da, \
                xr.open_dataset(Path(b) / name, engine="netcdf4") as db:
            da.load()
            db.load()
        ha, hb = da.attrs.pop("history"), db.attrs.pop("history")
        assert ha and hb
        xr.testing.assert_identical(da, db)
        for v in list(da.variables):
            x, y = np.asarray(da[v].values), np.asarray(db[v].values)
            assert x.dtype == y.dtype, (name, v)
            if x.dtype.kind in "fiu":
                assert x.tobytes() == y.tobytes(), f"{name}:{v} differs"
            else:
                assert np.array_equal(x, y), f"{name}:{v} differs"


def _reproducible(path: Path) -> bool:
    with xr.open_dataset(path, engine="netcdf4") as ds:
        return int(ds.attrs.get("bit_reproducible", 1)) != 0


#: the analysis smoke study (every analysis kind on the seed2009 gait, small budgets)
ANALYSIS_SMOKE = Path(__file__).resolve().parents[2] / "studies" / "analysis_smoke.yaml"


def open_dataset(folder: Path, name: str) -> xr.Dataset:
    """Dataset ``name`` of a study output ``folder``, loaded and closed."""
    with xr.open_dataset(Path(folder) / name) as ds:
        return ds.load()


def declared_text_pattern(template: str) -> re.Pattern:
    """A declared long_name or units (:class:`~monkeystudy.study.datasets.Variable`) as a
    pattern: its text literally, each ``{field}`` any text (empty too)."""
    parts = re.split(r"\{[a-z_]+\}", template)
    return re.compile("(?s)" + ".*".join(re.escape(p) for p in parts))


def refine_starts_dims(name: str, dims: tuple) -> tuple:
    """The dims of a refine dataset's variable when its start is ``{from: grid, best: k}``:
    dim ``start`` before the declared dims (the coordinates keep theirs)."""
    return dims if name in ("start", "iteration", "segment") else ("start",) + dims


def assert_written_as_declared(path: Path, kind: str, dims_of=None, name_of=None) -> None:
    """Dataset ``path`` holds the variables kind ``kind`` declares (its ``variables``):
    every non-optional one, no undeclared one, each with the declared dtype, units,
    long_name (its fields any text) and attributes. ``dims_of(name, declared dims)`` gives
    the dims expected for a layout other than the declared one (a grid's point list, a
    refine step's starts); by default the declared dims. ``name_of(written name)`` gives the
    declaration a written variable is one of (a design's ``<parameter>``); by default its
    own name."""
    import netCDF4

    from monkeystudy.study.steps import REGISTRY

    declared = REGISTRY[kind].variables
    assert declared, f"{kind} declares no variables"
    declaration_of = name_of or (lambda n: n)
    with netCDF4.Dataset(path) as nc:
        written = {declaration_of(n) for n in nc.variables}
        missing = {n for n, v in declared.items() if not v.optional} - written
        assert not missing, f"{path.name}: declared, not written: {sorted(missing)}"
        assert written <= set(declared), \
            f"{path.name}: written, not declared: {sorted(written - set(declared))}"
        for name in sorted(nc.variables):
            var, v = declared[declaration_of(name)], nc.variables[name]
            want_dims = var.dims if dims_of is None else dims_of(name, var.dims)
            assert v.dimensions == tuple(want_dims), (path.name, name, v.dimensions)
            if var.dtype is str:
                assert v.dtype is str, (path.name, name, v.dtype)
            else:
                assert v.dtype == np.dtype(var.dtype), (path.name, name, v.dtype)
            attrs = {k: v.getncattr(k) for k in v.ncattrs()}
            for key, template in (("long_name", var.long_name), ("units", var.units)):
                assert declared_text_pattern(template).fullmatch(attrs[key]), \
                    f"{path.name}:{name} {key} {attrs[key]!r} is not the declared {template!r}"
            extra = set(attrs) - {"long_name", "units", "_FillValue", "coordinates"}
            assert extra == set(var.attrs), (path.name, name, extra, set(var.attrs))
            for key, value in var.attrs.items():
                assert np.array_equal(np.asarray(attrs[key]), np.asarray(value)), \
                    (path.name, name, key)


class RecordingReporter(Reporter):
    """Every reporter call, in order (the counts come from a thread of their own)."""

    def __init__(self):
        self.events = []
        self.lock = threading.Lock()

    def start(self, name, total, done=0, unit="blocks"):
        with self.lock:
            self.events.append(("start", name, total, done, unit))

    def phase(self, name, label, total, unit, then="", done=0):
        with self.lock:
            self.events.append(("phase", name, label, total, unit, then, done))

    def advance(self, name, n=1):
        with self.lock:
            self.events.append(("advance", name, n))

    def finish(self, name, message=""):
        with self.lock:
            self.events.append(("finish", name))

    def counted(self, name) -> int:
        with self.lock:
            return sum(e[2] for e in self.events if e[0] == "advance" and e[1] == name)
