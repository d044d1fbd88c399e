"""Datasets of study steps, exactly as ``docs/datasets.md`` describes them.

Files are written with netCDF4-python into a temporary file in the destination folder, closed,
flushed to disk and moved into place with ``os.replace``: a reader sees either no file or a
complete one, and a finished file is never reopened for writing. Grids are streamed block by
block from their shards (xarray cannot write regions of a netCDF file), so memory stays flat
as a grid grows; refine and stability datasets are small. Read them with plain
``xarray.open_dataset(path)``.

Every variable carries ``units`` (UDUNITS) and ``long_name``; status codes carry CF
``flag_values``/``flag_meanings``; attribute values are text or numbers (structured values are
JSON text).
"""
from __future__ import annotations

import json
import os
import uuid
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterable, Iterator

import netCDF4
import numpy as np

from ..kernel.layout import STATUS_NAMES
from ..stress import EXTREME_CASES as EXTREME_DESCRIPTIONS
from .drivers import GRID_VARIABLES

CONVENTIONS = "CF-1.10"

STATUS_ATTRS = {
    "long_name": "outcome of the run",
    "units": "1",
    "flag_values": np.arange(len(STATUS_NAMES), dtype=np.int8),
    "flag_meanings": " ".join(STATUS_NAMES),
}

PHASE_ATTRS = {
    "long_name": "phase of motion", "units": "1",
    "flag_values": np.array([0, 1, 2], dtype=np.int8), "flag_meanings": "swing flight fixed",
}

RATE = "rad s-1"

#: units and long_name of the grid variables (and the refine scalars of the same name)
GRID_ATTRS = {
    "error": {"long_name": "gait error: theta2_f^2 + (dtheta1 - dtheta1_f)^2 + "
                           "(dtheta2 - dtheta2_f)^2 (MODEL.md section 4); NaN unless ok",
              "units": "1"},
    "status": STATUS_ATTRS,
    "t_switch": {"long_name": "time of the swap after the gait start", "units": "s"},
    "t_motor": {"long_name": "motor-on duration after the swap", "units": "s"},
    "t_end": {"long_name": "time of the vertical crossing ending the gait", "units": "s"},
    "steps": {"long_name": "accepted integrator steps", "units": "1"},
    "nfev": {"long_name": "right-hand-side evaluations", "units": "1"},
    "rejected": {"long_name": "rejected integrator steps", "units": "1"},
    # sequence gaits (monkeystudy.controllers.SequenceGait)
    "t_segment": {"long_name": "time each segment of the cycle was left (the last: the "
                               "section ending the cycle)", "units": "s"},
    "x_advance": {"long_name": "horizontal displacement of the attached end over the cycle",
                  "units": "m"},
    "y_advance": {"long_name": "vertical displacement of the attached end over the cycle "
                               "(> 0: climbing)", "units": "m"},
}

#: the sequence gait's error and end time (same variable names, other meanings)
SEQUENCE_ATTRS = {
    "error": {"long_name": "section error: wrap(theta2_f - theta2_0)^2 + (dtheta1_f - "
                           "dtheta1_0)^2 + (dtheta2_f - dtheta2_0)^2 after one cycle; NaN "
                           "unless ok", "units": "1"},
    "t_end": {"long_name": "time of the section crossing ending the cycle", "units": "s"},
}


#: long_name of a sequence gait's segment coordinate
SEGMENT_NOTE = "segment of the cycle (the last: the section)"


def variable_attrs(name: str, sequence: bool) -> dict:
    """Attributes of a grid or refine variable for the horizontal or a sequence gait."""
    return (SEQUENCE_ATTRS.get(name) or GRID_ATTRS[name]) if sequence else GRID_ATTRS[name]

DTHETA1 = {"long_name": "initial angular rate of link 1 (dtheta1)", "units": RATE}
DTHETA2 = {"long_name": "initial relative angular rate of link 2 (dtheta2)", "units": RATE}


# --- writing -----------------------------------------------------------------------------------
def _fsync_dir(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


@contextmanager
def atomic_netcdf(path: Path) -> Iterator[netCDF4.Dataset]:
    """A new netCDF4 file that appears at ``path`` only when complete (temp + os.replace)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.parent / f".{path.name}.{uuid.uuid4().hex[:8]}.tmp"
    nc = netCDF4.Dataset(tmp, "w", format="NETCDF4")
    try:
        nc.set_auto_mask(False)
        yield nc
        nc.close()
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
        _fsync_dir(path.parent)
    except BaseException:
        try:
            nc.close()
        except Exception:  # already closed
            pass
        tmp.unlink(missing_ok=True)
        raise


def _attr(value: Any) -> Any:
    if isinstance(value, (bool, np.bool_)):
        return int(value)
    if isinstance(value, (dict, list, tuple)):
        return json.dumps(value, sort_keys=True)
    if value is None:
        return ""
    return value


def _var(nc, name: str, dims: tuple, dtype, attrs: dict, data=None, coordinates: str = ""):
    dtype = np.dtype(dtype) if dtype is not str else str
    fill = np.nan if dtype is not str and np.dtype(dtype).kind == "f" else False
    v = nc.createVariable(name, dtype, dims, fill_value=fill)
    for k, val in attrs.items():
        v.setncattr(k, _attr(val))
    if coordinates:
        v.setncattr("coordinates", coordinates)
    if data is not None:
        if dims:
            v[...] = np.asarray(data, dtype=dtype) if dtype is not str else np.asarray(data,
                                                                                       object)
        else:
            v.assignValue(np.asarray(data, dtype=dtype))
    return v


def _global_attrs(nc, attrs: dict) -> None:
    for k, val in attrs.items():
        nc.setncattr(k, _attr(val))


def write_grid(path: Path, attrs: dict, *, axes: tuple[np.ndarray, np.ndarray] | None = None,
               points: np.ndarray | None = None,
               blocks: Iterable[tuple[int, dict[str, np.ndarray]]] = (),
               variables: dict | None = None, n_segments: int = 0) -> dict:
    """Write a grid dataset, streaming ``blocks`` of ``(first flat index, arrays)``.

    ``axes`` (dtheta1, dtheta2 values) give dims ``dtheta1 x dtheta2`` (flat index in C order);
    ``points[n, 2]`` give dim ``point``. ``variables`` (name -> dtype) default to the
    horizontal gait's; ``n_segments > 0`` (a sequence gait) adds dim ``segment`` for
    ``t_segment``. Returns ``{"skipped_fraction", "n_points"}``.
    """
    variables = GRID_VARIABLES if variables is None else variables
    sequence = n_segments > 0
    with atomic_netcdf(path) as nc:
        if axes is not None:
            a1, a2 = (np.asarray(a, np.float64) for a in axes)
            nc.createDimension("dtheta1", a1.size)
            nc.createDimension("dtheta2", a2.size)
            _var(nc, "dtheta1", ("dtheta1",), np.float64, DTHETA1, a1)
            _var(nc, "dtheta2", ("dtheta2",), np.float64, DTHETA2, a2)
            dims, shape, coords = ("dtheta1", "dtheta2"), (a1.size, a2.size), ""
        else:
            pts = np.asarray(points, np.float64).reshape(-1, 2)
            nc.createDimension("point", pts.shape[0])
            _var(nc, "point", ("point",), np.int32, {"long_name": "grid point index",
                                                     "units": "1"}, np.arange(pts.shape[0]))
            _var(nc, "dtheta1", ("point",), np.float64, DTHETA1, pts[:, 0])
            _var(nc, "dtheta2", ("point",), np.float64, DTHETA2, pts[:, 1])
            dims, shape, coords = ("point",), (pts.shape[0],), "dtheta1 dtheta2"
        n = int(np.prod(shape))
        if sequence:
            _index_coord(nc, "segment", n_segments, SEGMENT_NOTE)
        vs = {name: _var(nc, name, dims + (("segment",) if name == "t_segment" else ()), dt,
                         variable_attrs(name, sequence), coordinates=coords)
              for name, dt in variables.items()}
        written = skipped = 0
        for lo, arrays in _coalesce(blocks, variables):
            for name, v in vs.items():
                _write_flat(v, shape, lo, arrays[name])
            written += len(arrays["status"])
            skipped += int(np.count_nonzero(arrays["status"] == STATUS_NAMES.index("unreachable")))
        if written != n:
            raise RuntimeError(f"grid {path.name}: {written} of {n} points written")
        frac = skipped / n if n else 0.0
        _global_attrs(nc, dict(attrs, skipped_fraction=frac, n_points=n))
    return {"skipped_fraction": frac, "n_points": n}


#: points gathered from consecutive blocks before one write per variable: each netCDF slice
#: write costs ~0.1 ms of library overhead, so a 10^5-point map written block by block and
#: row piece by row piece spent ~0.2 s there; the buffer (~15 MB) keeps memory flat in the
#: grid size
WRITE_BUFFER_POINTS = 1 << 17


def _coalesce(blocks: Iterable[tuple[int, dict[str, np.ndarray]]], variables: dict,
              limit: int | None = None) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
    """Merge runs of contiguous blocks ``(first flat index, arrays)`` into pieces of at most
    ``limit`` points (default :data:`WRITE_BUFFER_POINTS`; a larger block is passed on
    alone, never split), cast to the variables' dtypes."""
    limit = WRITE_BUFFER_POINTS if limit is None else limit
    pending: list[dict[str, np.ndarray]] = []
    start = nxt = 0
    count = 0

    def merged():
        return start, {name: np.concatenate([np.asarray(a[name], dt) for a in pending])
                       if len(pending) > 1 else np.asarray(pending[0][name], dt)
                       for name, dt in variables.items()}

    for lo, arrays in blocks:
        m = len(arrays["status"])
        if pending and (lo != nxt or count + m > limit):
            yield merged()
            pending, count = [], 0
        if not pending:
            start = lo
        pending.append(arrays)
        count += m
        nxt = lo + m
    if pending:
        yield merged()


def _write_flat(var, shape: tuple, lo: int, data: np.ndarray) -> None:
    """Write ``data[m, ...]`` at flat (C-order) point indices ``lo..lo+m`` of a variable over
    ``shape`` (1-D or 2-D) points, with any trailing dims of ``data`` (e.g. ``segment``)."""
    count = data.shape[0]
    if len(shape) == 1:
        var[lo:lo + count] = data
        return
    n2 = shape[1]
    trail = data.shape[1:]
    pos, k = lo, 0
    while k < count:
        i, j = divmod(pos, n2)
        if j == 0 and count - k >= n2:            # whole rows at once
            rows = (count - k) // n2
            var[i:i + rows, ...] = data[k:k + rows * n2].reshape((rows, n2) + trail)
            pos += rows * n2
            k += rows * n2
        else:                                     # a partial row
            m = min(n2 - j, count - k)
            var[i, j:j + m, ...] = data[k:k + m]
            pos += m
            k += m


def write_refine(path: Path, attrs: dict, results: list[dict], multi: bool) -> None:
    """Write a refine dataset from :func:`~monkeystudy.study.drivers.refine_task` results.

    ``multi`` (a ``{from: grid, best: k}`` start): every variable gains a leading dim ``start``
    and the iterations are padded with NaN (``iterate_nfev`` with -1); ``n_iterations(start)``
    says how many are real.
    """
    n_it = max(len(r["iterate_error"]) for r in results)
    with atomic_netcdf(path) as nc:
        nc.createDimension("iteration", n_it)
        sdim: tuple = ()
        if multi:
            nc.createDimension("start", len(results))
            sdim = ("start",)
            _var(nc, "start", ("start",), np.int32,
                 {"long_name": "start index (grid minima, lowest error first)", "units": "1"},
                 np.arange(len(results)))
        _var(nc, "iteration", ("iteration",), np.int32,
             {"long_name": "Nelder-Mead iteration (0: the start)", "units": "1"},
             np.arange(n_it))

        def col(key, dtype=np.float64, index=None):
            vals = [r[key] if index is None else r[key][index] for r in results]
            arr = np.array(vals, dtype=dtype)
            return arr if multi else arr[0]

        _var(nc, "dtheta1", sdim, np.float64, dict(DTHETA1, long_name="refined " +
                                                    DTHETA1["long_name"]), col("x", index=0))
        _var(nc, "dtheta2", sdim, np.float64, dict(DTHETA2, long_name="refined " +
                                                    DTHETA2["long_name"]), col("x", index=1))
        sequence = "t_segment" in results[0]
        if sequence:
            _index_coord(nc, "segment", len(results[0]["t_segment"]), SEGMENT_NOTE)
            _var(nc, "t_segment", sdim + ("segment",), np.float64, GRID_ATTRS["t_segment"],
                 col("t_segment"))
        keys = (("error", "t_end", "x_advance", "y_advance") if sequence
                else ("error", "t_switch", "t_motor", "t_end"))
        for key in keys:
            _var(nc, key, sdim, np.float64, variable_attrs(key, sequence), col(key))
        _var(nc, "status", sdim, np.int8, STATUS_ATTRS, col("status", np.int8))
        _var(nc, "start_dtheta1", sdim, np.float64, dict(DTHETA1, long_name="start of the "
                                                          "refinement, dtheta1"),
             col("start", index=0))
        _var(nc, "start_dtheta2", sdim, np.float64, dict(DTHETA2, long_name="start of the "
                                                          "refinement, dtheta2"),
             col("start", index=1))
        _var(nc, "converged", sdim, np.int8, {"long_name": "Nelder-Mead met xatol and fatol "
                                                           "(1) or hit a limit (0)",
                                               "units": "1"}, col("converged", np.int8))
        _var(nc, "nit", sdim, np.int32, {"long_name": "Nelder-Mead iterations", "units": "1"},
             col("nit", np.int32))
        _var(nc, "n_iterations", sdim, np.int32, {"long_name": "recorded iterates (start "
                                                               "included)", "units": "1"},
             np.array([len(r["iterate_error"]) for r in results], np.int32)
             if multi else len(results[0]["iterate_error"]))
        idim = sdim + ("iteration",)

        def padded(key, index=None, fill=np.nan, dtype=np.float64):
            arr = np.full((len(results), n_it), fill, dtype=dtype)
            for i, r in enumerate(results):
                v = r[key] if index is None else r[key][:, index]
                arr[i, :len(v)] = v
            return arr if multi else arr[0]

        _var(nc, "iterate_dtheta1", idim, np.float64, dict(DTHETA1, long_name="best vertex per "
                                                            "iteration, dtheta1"),
             padded("iterate_x", 0))
        _var(nc, "iterate_dtheta2", idim, np.float64, dict(DTHETA2, long_name="best vertex per "
                                                            "iteration, dtheta2"),
             padded("iterate_x", 1))
        _var(nc, "iterate_error", idim, np.float64,
             {"long_name": "gait error of the best vertex per iteration (NaN: gait failed)",
              "units": "1"}, padded("iterate_error"))
        _var(nc, "iterate_nfev", idim, np.int32,
             {"long_name": "objective evaluations so far (-1: padding)", "units": "1"},
             padded("iterate_nfev", fill=-1, dtype=np.int32))
        conv = [r["converged"] for r in results]
        msgs = [r["message"] for r in results]
        _global_attrs(nc, dict(
            attrs, converged=int(all(conv)),
            message=json.dumps(msgs) if multi else msgs[0],
            nfev=json.dumps([r["nfev"] for r in results]) if multi else results[0]["nfev"],
        ))


def write_stability(path: Path, attrs: dict, result: dict, gait: dict) -> None:
    """Write a stability dataset from a :func:`~monkeystudy.study.drivers.stability_task`
    result; ``gait`` is the replayed refined gait (rates [rad s-1], times [s])."""
    n = len(result["error"])
    ns = len(result["time"])
    at = "section crossing" if attrs.get("replay") in ("gait", "open_loop") and \
        "section_theta1" in attrs else "vertical crossing"
    with atomic_netcdf(path) as nc:
        nc.createDimension("cycle", n)
        nc.createDimension("sample", ns)
        nc.createDimension("xy", 2)
        _var(nc, "cycle", ("cycle",), np.int32, {"long_name": "cycle number", "units": "1"},
             np.arange(1, n + 1))
        _var(nc, "xy", ("xy",), str, {"long_name": "world axis", "units": "1"}, np.array(["x", "y"], object))
        section = at == "section crossing"
        per_cycle = {
            "error": (f"error against the initial state at the {at} ending the cycle "
                      f"(MODEL.md section 4{'; the section error' if section else ''})", "1"),
            "kinetic_energy": (f"kinetic energy at that {at}", "J"),
            "pivot_height": ("world height of the attached end at that section crossing"
                             if section else "world height of the attached end after the "
                             "cycle's swap", "m"),
            "x_advance": ("horizontal displacement of the attached end in the cycle", "m"),
            "t_cross": (f"time of the {at} ending the cycle", "s"),
            "t_swap": ("time of the cycle's first magnet action (NaN: none)" if section
                       else "time of the cycle's swap", "s"),
        }
        for key, (long_name, units) in per_cycle.items():
            _var(nc, key, ("cycle",), np.float64, {"long_name": long_name, "units": units},
                 result[key])
        _var(nc, "status", (), np.int8, dict(STATUS_ATTRS, long_name="why the run stopped "
                                             "(ok: all cycles ran)"), result["status"])
        _var(nc, "dtheta1", (), np.float64, dict(DTHETA1, long_name="replayed " +
                                                 DTHETA1["long_name"]), gait["dtheta1"])
        _var(nc, "dtheta2", (), np.float64, dict(DTHETA2, long_name="replayed " +
                                                 DTHETA2["long_name"]), gait["dtheta2"])
        _var(nc, "time", ("sample",), np.float64, {"long_name": "time", "units": "s"},
             result["time"])
        for key, what in (("A", "end A"), ("joint", "the joint"), ("B", "end B")):
            _var(nc, key, ("sample", "xy"), np.float64,
                 {"long_name": f"world position of {what}", "units": "m"}, result[key],
                 coordinates="time")
        _var(nc, "phase", ("sample",), np.int8, PHASE_ATTRS, result["phase"],
             coordinates="time")
        _var(nc, "motor_torque", ("sample",), np.float64,
             {"long_name": "motor torque on theta2 of the frame", "units": "N m"},
             result["motor_torque"], coordinates="time")
        times = {k: float(gait[k]) for k in ("t_switch", "t_motor") if k in gait}
        _global_attrs(nc, dict(attrs, **times,
                               cycles_completed=int(result["cycles_completed"]),
                               steps=int(result["steps"]), nfev=int(result["nfev"])))


# --- reading -----------------------------------------------------------------------------------
def read_attrs(path: Path) -> dict | None:
    """Global attributes of a dataset, or None if it is missing or unreadable."""
    try:
        with netCDF4.Dataset(path, "r") as nc:
            return {k: nc.getncattr(k) for k in nc.ncattrs()}
    except (OSError, RuntimeError):
        return None


def read_refined(path: Path, start_index: int | None = None) -> tuple[dict, int]:
    """The refined gait of a refine dataset: ``({dtheta1, dtheta2, t_switch, t_motor, t_end,
    status}, start index)``; for a multi-start dataset the given start or the lowest error."""
    keys = ("dtheta1", "dtheta2", "t_switch", "t_motor", "t_end", "error", "status")
    with netCDF4.Dataset(path, "r") as nc:
        nc.set_auto_mask(False)
        # a sequence gait's refine has no t_switch, t_motor
        vals = {k: np.atleast_1d(nc.variables[k][...]) for k in keys if k in nc.variables}
    if start_index is None:
        err = np.where(np.isfinite(vals["error"]), vals["error"], np.inf)
        start_index = int(np.argmin(err))
    g = {k: float(v[start_index]) for k, v in vals.items()}
    g["status"] = int(g["status"])
    return g, start_index


def read_grid_error(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(error, dtheta1, dtheta2)`` of a grid dataset (2-D for axes, 1-D for points)."""
    with netCDF4.Dataset(path, "r") as nc:
        nc.set_auto_mask(False)
        return (np.array(nc.variables["error"][...]), np.array(nc.variables["dtheta1"][...]),
                np.array(nc.variables["dtheta2"][...]))


def best_grid_points(error: np.ndarray, d1: np.ndarray, d2: np.ndarray, k: int) -> np.ndarray:
    """The ``k`` best starts of a grid, ``[k, 2]``: local minima of the error map (no finite
    8-neighbour lower), lowest first, then the lowest remaining points; ties by flat index."""
    e = np.asarray(error, np.float64)
    finite = np.isfinite(e)
    if int(finite.sum()) < k:
        raise ValueError(f"the grid has {int(finite.sum())} points with an error value, "
                         f"{k} requested")
    if e.ndim == 2:
        big = np.where(finite, e, np.inf)
        pad = np.pad(big, 1, constant_values=np.inf)
        local = finite.copy()
        n1, n2 = e.shape
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                if di or dj:
                    local &= big <= pad[1 + di:1 + di + n1, 1 + dj:1 + dj + n2]
        g1, g2 = np.meshgrid(d1, d2, indexing="ij")
        pts = np.stack([g1.ravel(), g2.ravel()], axis=1)
        local = local.ravel()
    else:
        pts = np.stack([d1, d2], axis=1)
        local = np.zeros(e.size, bool)
    flat = e.ravel()
    idx = np.arange(flat.size)
    fin = np.isfinite(flat)
    order_local = idx[local][np.lexsort((idx[local], flat[local]))]
    rest = idx[fin & ~local]
    order_rest = rest[np.lexsort((rest, flat[rest]))]
    chosen = np.concatenate([order_local, order_rest])[:k]
    return pts[chosen]


# --- analysis steps (docs/datasets.md "Analysis steps") ------------------------------------------
#: shoot ``method`` flags
SHOOT_METHOD_ATTRS = {
    "long_name": "how the fixed point was found", "units": "1",
    "flag_values": np.array([0, 1], dtype=np.int8),
    "flag_meanings": "gauss_newton grazing",
}

#: units of the continuation parameters
PARAMETER_UNITS = {"com": "m", "inertia": "kg m2", "gravity": "m s-2", "torque": "N m",
                   "mass_ratio": "1", "joint_viscous": "N m s", "pivot_viscous": "N m s"}

_SECTION_NOTE = ("on the gait's section (theta1 = 0 unless the gait says), components (theta2 [rad], dtheta1 [rad s-1], "
                 "dtheta2 [rad s-1])")


def _complex_vars(nc, name: str, dims: tuple, values: np.ndarray, what: str) -> None:
    """A complex array as ``<name>_real`` and ``<name>_imag`` (netCDF4 classic types)."""
    v = np.asarray(values, complex)
    _var(nc, f"{name}_real", dims, np.float64, {"long_name": f"{what}, real part",
                                                "units": "1"}, v.real)
    _var(nc, f"{name}_imag", dims, np.float64, {"long_name": f"{what}, imaginary part",
                                                "units": "1"}, v.imag)


def _index_coord(nc, dim: str, n: int, long_name: str, start: int = 0) -> None:
    nc.createDimension(dim, n)
    _var(nc, dim, (dim,), np.int32, {"long_name": long_name, "units": "1"},
         np.arange(start, start + n))


def _label_coord(nc, dim: str, labels: list[str], long_name: str) -> None:
    nc.createDimension(dim, len(labels))
    _var(nc, dim, (dim,), str, {"long_name": long_name, "units": "1"},
         np.array(list(labels), object))


def write_shoot(path: Path, attrs: dict, solutions: list[dict]) -> None:
    """Write a shoot dataset from the deduplicated solutions of
    :func:`~monkeystudy.study.analysis_tasks.dedup_solutions` (discovery order)."""
    n = len(solutions)
    n_it = max(1, max(len(s["history"]) for s in solutions))
    with atomic_netcdf(path) as nc:
        _index_coord(nc, "solution", n, "solution index (discovery order)")
        _index_coord(nc, "iteration", n_it, "Newton iteration (0: the start)")

        def col(key, dtype=np.float64):
            return np.array([s[key] for s in solutions], dtype=dtype)

        _var(nc, "dtheta1", ("solution",), np.float64, dict(DTHETA1, long_name="fixed point, "
                                                             + DTHETA1["long_name"]),
             col("dtheta1"))
        _var(nc, "dtheta2", ("solution",), np.float64, dict(DTHETA2, long_name="fixed point, "
                                                             + DTHETA2["long_name"]),
             col("dtheta2"))
        for key in ("t_switch", "t_motor", "t_end"):
            _var(nc, key, ("solution",), np.float64, GRID_ATTRS[key], col(key))
        _var(nc, "error", ("solution",), np.float64,
             {"long_name": "gait error of the solution (MODEL.md section 4): grazing: "
                           "|P(z) - z|^2 of the motorless open-loop map; gauss_newton: the "
                           "study's gait error", "units": "1"}, col("error"))
        _var(nc, "residual_norm", ("solution",), np.float64,
             {"long_name": "norm of the Newton residual at the solution (grazing: B's height "
                           "and velocity; gauss_newton: the gait residual)", "units": "1"},
             col("residual_norm"))
        _var(nc, "converged", ("solution",), np.int8,
             {"long_name": "Newton met its tolerance (1) or stopped (0)", "units": "1"},
             col("converged", np.int8))
        _var(nc, "method", ("solution",), np.int8, SHOOT_METHOD_ATTRS, col("method", np.int8))
        _var(nc, "status", ("solution",), np.int8, dict(STATUS_ATTRS, long_name="outcome of "
                                                        "the solution's gait cycle"),
             col("status", np.int8))
        _var(nc, "start_index", ("solution",), np.int32,
             {"long_name": "first start that found the solution", "units": "1"},
             col("start_index", np.int32))
        hist = np.full((n, n_it), np.nan)
        for i, s in enumerate(solutions):
            hist[i, :len(s["history"])] = s["history"]
        _var(nc, "history", ("solution", "iteration"), np.float64,
             {"long_name": "residual norm per Newton iteration (NaN: padding)", "units": "1"},
             hist)
        _global_attrs(nc, dict(attrs, message=[s["message"] for s in solutions],
                               solution_starts=[s["starts"] for s in solutions]))


def write_floquet(path: Path, attrs: dict, results: list[dict]) -> None:
    """Write a floquet dataset from :func:`~monkeystudy.study.analysis_tasks.floquet_task`
    results, one per controller (in the step's order)."""
    with atomic_netcdf(path) as nc:
        _label_coord(nc, "controller", [r["controller"] for r in results],
                     "return map: open_loop (recorded times) or search (state-based)")
        _index_coord(nc, "k", 3, "multiplier (by decreasing modulus) or fixed-point component")
        _index_coord(nc, "row", 3, "Jacobian row: d(theta2, dtheta1, dtheta2) after a cycle")
        _index_coord(nc, "col", 3, "Jacobian column: d(theta2, dtheta1, dtheta2) before")

        def stack(key, dtype=np.float64):
            return np.array([r[key] for r in results], dtype=dtype)

        _complex_vars(nc, "multipliers", ("controller", "k"), stack("multipliers", complex),
                      "Floquet multipliers by variational equations (decreasing modulus)")
        _complex_vars(nc, "multipliers_fd", ("controller", "k"),
                      stack("multipliers_fd", complex),
                      "Floquet multipliers by finite differences (decreasing modulus)")
        _var(nc, "jacobian", ("controller", "row", "col"), np.float64,
             {"long_name": "Jacobian of the return map by variational equations (saltation "
                           "matrices at the events), " + _SECTION_NOTE, "units": "1"},
             stack("jacobian"))
        _var(nc, "jacobian_fd", ("controller", "row", "col"), np.float64,
             {"long_name": "Jacobian of the return map by fourth-order central differences, "
                           + _SECTION_NOTE, "units": "1"}, stack("jacobian_fd"))
        _var(nc, "fixed_point", ("controller", "k"), np.float64,
             {"long_name": "fixed point " + _SECTION_NOTE, "units": "1",
              "components": "theta2 dtheta1 dtheta2", "component_units": "rad, rad s-1, rad s-1"},
             stack("fixed_point"))
        _var(nc, "map_defect", ("controller",), np.float64,
             {"long_name": "|P(z) - z| at the fixed point", "units": "1"}, stack("map_defect"))
        _var(nc, "stable", ("controller",), np.int8,
             {"long_name": "all multipliers inside the unit circle (1), neutral ones "
                           "(|lambda - 1| < 1e-6) excluded", "units": "1"},
             stack("stable", np.int8))
        _var(nc, "neutral", ("controller",), np.int8,
             {"long_name": "neutral multipliers (|lambda - 1| < 1e-6)", "units": "1"},
             stack("neutral", np.int8))
        _var(nc, "agreement", ("controller",), np.float64,
             {"long_name": "max |J - J_fd| / max |J|", "units": "1"}, stack("agreement"))
        _var(nc, "t_switch", ("controller",), np.float64,
             {"long_name": "swap time of the fixed point's cycle", "units": "s"},
             stack("t_switch"))
        _var(nc, "t_motor", ("controller",), np.float64,
             {"long_name": "motor-on duration of the fixed point's cycle", "units": "s"},
             stack("t_motor"))
        _var(nc, "motor_torque", ("controller",), np.float64,
             {"long_name": "motor torque of the return map", "units": "N m"}, stack("torque"))
        if "t_segment" in results[0]:       # a sequence gait's cycle
            _index_coord(nc, "segment", len(results[0]["t_segment"]), SEGMENT_NOTE)
            _var(nc, "t_segment", ("controller", "segment"), np.float64,
                 GRID_ATTRS["t_segment"], stack("t_segment"))
            for key in ("x_advance", "y_advance"):
                _var(nc, key, ("controller",), np.float64, GRID_ATTRS[key], stack(key))
            _var(nc, "error", ("controller",), np.float64, SEQUENCE_ATTRS["error"],
                 stack("error"))
        _var(nc, "newton_converged", ("controller",), np.int8,
             {"long_name": "Newton polish of the fixed point converged (1; open_loop: the "
                           "shoot's point, 1)", "units": "1"},
             stack("newton_converged", np.int8))
        _global_attrs(nc, attrs)


def write_tick_sweep(path: Path, attrs: dict, ticks, result: dict) -> None:
    """Write a tick_sweep dataset from a
    :func:`~monkeystudy.study.analysis_tasks.tick_sweep_task` result."""
    err = np.asarray(result["error"], float)
    section = "section_theta1" in attrs
    at = "section crossing" if section else "vertical crossing"
    with atomic_netcdf(path) as nc:
        nc.createDimension("tick", len(ticks))
        _var(nc, "tick", ("tick",), np.float64,
             {"long_name": "controller tick (0: exact event timing)", "units": "s"},
             np.asarray(ticks, float))
        _index_coord(nc, "cycle", err.shape[1], "cycle number", start=1)
        _var(nc, "error", ("tick", "cycle"), np.float64,
             {"long_name": f"error against the gait start at the {at} ending the cycle "
                           "(MODEL.md section 4; NaN: not reached)", "units": "1"}, err)
        _var(nc, "pivot_height", ("tick", "cycle"), np.float64,
             {"long_name": "world height of the attached end at the section crossing ending "
                           "the cycle" if section else "world height of the attached end "
                           "after the cycle's swap", "units": "m"}, result["pivot_height"])
        _var(nc, "cycles_to_bound", ("tick",), np.int32,
             {"long_name": "first cycle whose error exceeds error_bound (else the cycles "
                           "reached)", "units": "1"}, result["cycles_to_bound"])
        _var(nc, "cycles_completed", ("tick",), np.int32,
             {"long_name": f"cycles that reached their {at}", "units": "1"},
             result["cycles_completed"])
        _var(nc, "status", ("tick",), np.int8, dict(STATUS_ATTRS, long_name="why the run "
                                                    "stopped (ok: all cycles ran)"),
             result["status"])
        _var(nc, "growth_per_cycle", ("tick",), np.float64,
             {"long_name": "fitted geometric growth of sqrt(error) per cycle where 1e-10 < "
                           "sqrt(error) < 1e-4 (NaN: fewer than 3 such cycles)", "units": "1"},
             result["growth_per_cycle"])
        _global_attrs(nc, attrs)


def write_basin(path: Path, attrs: dict, offsets1: np.ndarray, offsets2: np.ndarray,
                cycles: np.ndarray) -> None:
    """Write a basin dataset: cycles survived ``[len(offsets1), len(offsets2)]``."""
    with atomic_netcdf(path) as nc:
        for dim, vals, what in (("d_dtheta1", offsets1, "dtheta1"),
                                ("d_dtheta2", offsets2, "dtheta2")):
            nc.createDimension(dim, len(vals))
            _var(nc, dim, (dim,), np.float64, {"long_name": f"offset of the start's {what} "
                                                            "from the gait", "units": RATE},
                 np.asarray(vals, float))
        _var(nc, "cycles", ("d_dtheta1", "d_dtheta2"), np.int32,
             {"long_name": "cycles survived before the error against the gait exceeded "
                           "error_bound, the run fell or stopped (max_cycles: never)",
              "units": "1"}, np.asarray(cycles, np.int32))
        _global_attrs(nc, attrs)


def write_continuation(path: Path, attrs: dict, result: dict) -> None:
    """Write a continuation dataset from a
    :func:`~monkeystudy.study.analysis_tasks.continuation_task` (horizontal gait) or
    :func:`~monkeystudy.study.analysis_tasks.sequence_continuation_task` result."""
    n = len(result["value"])
    par = result["parameter"]
    sequence = "t_segment" in result
    what = "sequence gait's fixed point" if sequence else "collisionless gait"
    with atomic_netcdf(path) as nc:
        _index_coord(nc, "point", n, "point on the branch (0: the "
                     + ("floquet step's fixed point)" if sequence else "shoot's gait)"))
        _index_coord(nc, "k", 3, "multiplier (by decreasing modulus)")
        _var(nc, "parameter_value", ("point",), np.float64,
             {"long_name": f"continuation parameter {par}", "units": PARAMETER_UNITS[par]},
             result["value"])
        _var(nc, "dtheta1", ("point",), np.float64, dict(DTHETA1, long_name=f"{what}, "
                                                          + DTHETA1["long_name"]),
             result["dtheta1"])
        _var(nc, "dtheta2", ("point",), np.float64, dict(DTHETA2, long_name=f"{what}, "
                                                          + DTHETA2["long_name"]),
             result["dtheta2"])
        if sequence:
            _index_coord(nc, "segment", np.shape(result["t_segment"])[1], SEGMENT_NOTE)
            _var(nc, "residual", ("point",), np.float64,
                 {"long_name": "|P(z) - z| of the return map after correction", "units": "1"},
                 result["residual"])
            _var(nc, "theta2", ("point",), np.float64,
                 {"long_name": "theta2 of the fixed point on the section (held at the "
                               "start's when theta2_pinned)", "units": "rad"},
                 result["theta2"])
            _var(nc, "corrector_iterations", ("point",), np.int32,
                 {"long_name": "Gauss-Newton corrector iterations (0: the start)",
                  "units": "1"}, np.asarray(result["iterations"], np.int32))
            _var(nc, "arclength", ("point",), np.float64,
                 {"long_name": "cumulative arclength in (theta2, dtheta1, dtheta2, parameter)",
                  "units": "1"}, result["arclength"])
            _var(nc, "stable", ("point",), np.int8,
                 {"long_name": "1: every non-neutral multiplier inside the unit circle",
                  "units": "1"}, np.asarray(result["stable"], np.int8))
            _var(nc, "neutral", ("point",), np.int8,
                 {"long_name": "multipliers within 1e-6 of 1 (the free energy level)",
                  "units": "1"}, np.asarray(result["neutral"], np.int8))
            _var(nc, "t_segment", ("point", "segment"), np.float64,
                 GRID_ATTRS["t_segment"], result["t_segment"])
            for name in ("x_advance", "y_advance"):
                _var(nc, name, ("point",), np.float64, GRID_ATTRS[name], result[name])
            _complex_vars(nc, "multipliers", ("point", "k"), result["multipliers"],
                          "Floquet multipliers of the cycle's return map (variational "
                          "equations)")
            extra = {"theta2_pinned": int(result["theta2_pinned"]),
                     "stop_reason": result["stop_reason"],
                     "through_plus_one": list(result["through_plus_one"]),
                     "neimark_sacker": list(result["neimark_sacker"])}
        else:
            _var(nc, "t_switch", ("point",), np.float64,
                 {"long_name": "swap time (B at A's height at rest)", "units": "s"},
                 result["t_switch"])
            _var(nc, "residual", ("point",), np.float64,
                 {"long_name": "|G| (B's height and velocity at t_switch) after correction",
                  "units": "1"}, result["residual"])
            _complex_vars(nc, "multipliers", ("point", "k"), result["multipliers"],
                          "Floquet multipliers of the motorless open-loop map (variational "
                          "equations)")
            extra = {}
        _global_attrs(nc, dict(attrs, parameter=par, parameter_units=PARAMETER_UNITS[par],
                               value0=float(result["value0"]), folds=list(result["folds"]),
                               period_doublings=list(result["period_doublings"]), **extra))


#: the note stored with work-precision datasets
NOT_REPRODUCIBLE = ("wall-clock timings depend on the machine and its load: time variables "
                    "differ between runs (errors and counts do not)")


def write_work_precision(path: Path, attrs: dict, result: dict) -> None:
    """Write a work_precision dataset from :func:`monkeystudy.precision.work_precision`."""
    with atomic_netcdf(path) as nc:
        _label_coord(nc, "method", list(result["methods"]), "kernel integrator")
        nc.createDimension("rtol", len(result["rtols"]))
        _var(nc, "rtol", ("rtol",), np.float64, {"long_name": "relative tolerance",
                                                 "units": "1"}, result["rtols"])
        _label_coord(nc, "scipy_method", list(result["scipy_methods"]),
                     "scipy.integrate.solve_ivp method")
        nc.createDimension("scipy_rtol", len(result["scipy_rtols"]))
        _var(nc, "scipy_rtol", ("scipy_rtol",), np.float64,
             {"long_name": "relative tolerance of the scipy runs", "units": "1"},
             result["scipy_rtols"])
        mr, sr = ("method", "rtol"), ("scipy_method", "scipy_rtol")
        _var(nc, "time_per_gait", mr, np.float64,
             {"long_name": "wall time per gait evaluation (best of repeat)", "units": "s"},
             result["time"])
        _var(nc, "rhs_per_gait", mr, np.float64,
             {"long_name": "right-hand-side evaluations per gait (mean)", "units": "1"},
             result["nfev"])
        _var(nc, "error_value", mr, np.float64,
             {"long_name": "max |gait error - reference gait error|", "units": "1"},
             result["error_value"])
        _var(nc, "error_times", mr, np.float64,
             {"long_name": "max |event time - reference| (t_switch, t_motor, t_end)",
              "units": "s"}, result["error_times"])
        _var(nc, "status_mismatch", mr, np.int32,
             {"long_name": "points whose status differs from the reference", "units": "1"},
             result["status_mismatch"])
        _var(nc, "scipy_time_per_gait", sr, np.float64,
             {"long_name": "wall time per gait evaluation, scipy solve_ivp with events",
              "units": "s"}, result["scipy_time"])
        _var(nc, "scipy_error_value", sr, np.float64,
             {"long_name": "max |gait error - reference gait error|, scipy", "units": "1"},
             result["scipy_error_value"])
        _var(nc, "scipy_error_times", sr, np.float64,
             {"long_name": "max |event time - reference|, scipy", "units": "s"},
             result["scipy_error_times"])
        _var(nc, "kernel_time_same_points", ("scipy_rtol",), np.float64,
             {"long_name": "wall time per gait of the kernel's dop853 on the scipy points",
              "units": "s"}, result["kernel_time_same_points"])
        _global_attrs(nc, dict(attrs, reference=result["reference"],
                               n_points=int(result["n_points"]), bit_reproducible=0,
                               reproducibility=NOT_REPRODUCIBLE))


def write_stress(path: Path, attrs: dict, phases: list[str], rtols: list[float],
                 drift: list[dict], runs: list[dict], cases: list[dict]) -> None:
    """Write a stress dataset (docs/datasets.md, ``stress``) from the results of
    :func:`~monkeystudy.study.analysis_tasks.stress_drift_task` (phase-major, one per phase
    and tolerance), :func:`~monkeystudy.study.analysis_tasks.stress_long_run_task` (one per
    run, with its ``run`` name, ``controller`` and ``tick``) and
    :func:`~monkeystudy.study.analysis_tasks.stress_extreme_task` (one per case)."""
    n_r = len(rtols)
    n_c = len(drift[0]["time"])
    grid = {(r["phase"], r["rtol"]): r for r in drift}

    def cell(key, dtype=np.float64):
        return np.array([[grid[(ph, rt)][key] for rt in rtols] for ph in phases], dtype=dtype)

    def per_phase(key):
        return np.array([grid[(ph, rtols[0])][key] for ph in phases], dtype=np.float64)

    n_status = len(STATUS_NAMES)
    counts = np.zeros((len(cases), n_status), np.int32)
    for i, c in enumerate(cases):
        counts[i] = np.bincount(np.asarray(c["status"], np.int64), minlength=n_status)
    with atomic_netcdf(path) as nc:
        # energy drift
        _label_coord(nc, "drift_phase", phases, "phase of the unforced, frictionless run: "
                     "swing (hanging from end A) or flight (nothing attached)")
        nc.createDimension("drift_rtol", n_r)
        _var(nc, "drift_rtol", ("drift_rtol",), np.float64,
             {"long_name": "relative tolerance of the run (atol = rtol * atol_ratio)",
              "units": "1"}, np.asarray(rtols, float))
        _index_coord(nc, "checkpoint", n_c, "checkpoint (log-spaced in time)")
        pc = ("drift_phase", "drift_rtol")
        _var(nc, "period", ("drift_phase",), np.float64,
             {"long_name": "reference period: mean interval between rising crossings of "
                           "theta1 = 0 (oscillation), or 2 pi / |mean dtheta1/dt| (link 1 "
                           "tumbling)", "units": "s"}, per_phase("period"))
        _var(nc, "time", ("drift_phase", "checkpoint"), np.float64,
             {"long_name": "time of the checkpoint (1 to `periods` reference periods, "
                           "log-spaced)", "units": "s"},
             np.array([grid[(ph, rtols[0])]["time"] for ph in phases], float))
        _var(nc, "energy_drift", pc + ("checkpoint",), np.float64,
             {"long_name": "relative energy drift |E - E0| / (|K| + |V|) at the checkpoint "
                           "(NaN: not reached)", "units": "1"},
             np.array([[grid[(ph, rt)]["drift"] for rt in rtols] for ph in phases], float))
        _var(nc, "growth_exponent", pc, np.float64,
             {"long_name": "log-log slope of the drift against time over the last decade of "
                           "checkpoints, fitted above drift_floor (NaN: fewer than 3 such "
                           "checkpoints); 1 = linear growth", "units": "1"},
             cell("growth_exponent"))
        _var(nc, "drift_per_period", pc, np.float64,
             {"long_name": "final energy drift / number of reference periods",
              "units": "1"}, cell("drift_per_period"))
        _var(nc, "drift_steps", pc, np.int64,
             {"long_name": "accepted integrator steps of the run", "units": "1"},
             cell("steps", np.int64))
        _var(nc, "drift_status", pc, np.int8,
             dict(STATUS_ATTRS, long_name="how the run ended (end_time: every checkpoint "
                                          "reached)"), cell("status", np.int8))
        _var(nc, "initial_energy", ("drift_phase",), np.float64,
             {"long_name": "total energy E0 at the start (world frame)", "units": "J"},
             per_phase("energy0"))
        # long runs
        _label_coord(nc, "run", [r["run"] for r in runs], "long run: controller and timing")
        _var(nc, "controller", ("run",), str,
             {"long_name": "controller: open_loop (the gait's recorded times replayed) or "
                           "search (state-based, looped)", "units": "1"},
             np.array([r["controller"] for r in runs], object))
        _var(nc, "tick", ("run",), np.float64,
             {"long_name": "controller tick (0: exact event timing)", "units": "s"},
             [r["tick"] for r in runs])
        _var(nc, "run_status", ("run",), np.int8,
             dict(STATUS_ATTRS, long_name="why the run stopped (ok: all cycles ran)"),
             [r["status"] for r in runs])
        for key, long_name, dtype in (
                ("cycles_completed", "cycles completed", np.int32),
                ("steps", "accepted integrator steps", np.int64),
                ("nfev", "right-hand-side evaluations", np.int64),
                ("rejected", "rejected integrator steps", np.int64)):
            _var(nc, key, ("run",), dtype, {"long_name": long_name, "units": "1"},
                 [r[key] for r in runs])
        _var(nc, "final_pivot_height", ("run",), np.float64,
             {"long_name": "world height of the attached end when the run stopped (start: "
                           "0)", "units": "m"}, [r["final_pivot_height"] for r in runs])
        _var(nc, "t_final", ("run",), np.float64,
             {"long_name": "simulated time when the run stopped", "units": "s"},
             [r["t_final"] for r in runs])
        _var(nc, "final_state_finite", ("run",), np.int8,
             {"long_name": "the final state is finite (1) or not (0)", "units": "1"},
             [r["finite"] for r in runs])
        _var(nc, "t_switch", ("run",), np.float64,
             {"long_name": "swap time replayed by an open-loop run (NaN: state-based)",
              "units": "s"}, [r["t_switch"] for r in runs])
        _var(nc, "t_motor", ("run",), np.float64,
             {"long_name": "motor-on duration replayed by an open-loop run (NaN: "
                           "state-based)", "units": "s"}, [r["t_motor"] for r in runs])
        # extreme cases
        _label_coord(nc, "case", [c["case"] for c in cases], "extreme case")
        nc.createDimension("status", n_status)
        _var(nc, "status", ("status",), np.int8, dict(STATUS_ATTRS, long_name="run status"),
             np.arange(n_status))
        _var(nc, "description", ("case",), str,
             {"long_name": "what the case changes", "units": "1"},
             np.array([EXTREME_DESCRIPTIONS.get(c["case"], "") for c in cases], object))
        _var(nc, "status_counts", ("case", "status"), np.int32,
             {"long_name": "runs of the case ending with each status", "units": "1"}, counts)
        _var(nc, "n_runs", ("case",), np.int32,
             {"long_name": "runs of the case (gait evaluations or one free run)",
              "units": "1"}, counts.sum(axis=1))
        _var(nc, "finite_ok", ("case",), np.int8,
             {"long_name": "every run marked ok (free run: end_time) has finite results and "
                           "every other run's error is NaN (1) or not (0)", "units": "1"},
             [c["finite_ok"] for c in cases])
        _var(nc, "max_steps_taken", ("case",), np.int64,
             {"long_name": "most accepted integrator steps of one run of the case",
              "units": "1"}, [c["max_steps"] for c in cases])
        _var(nc, "energy_change", ("case",), np.float64,
             {"long_name": "final minus initial total energy of the free run (NaN: gait "
                           "evaluations)", "units": "J"}, [c["energy_change"] for c in cases])
        _var(nc, "friction_events", ("case",), np.int32,
             {"long_name": "stick and slip events of the free run (0: gait evaluations)",
              "units": "1"}, [c["friction_events"] for c in cases])
        _global_attrs(nc, attrs)


def read_shoot(path: Path) -> list[dict]:
    """The solutions of a shoot dataset: ``[{dtheta1, dtheta2, t_switch, t_motor, t_end,
    error, residual_norm, converged, method, status}, ...]`` (solution order)."""
    keys = ("dtheta1", "dtheta2", "t_switch", "t_motor", "t_end", "error", "residual_norm",
            "converged", "method", "status")
    with netCDF4.Dataset(path, "r") as nc:
        nc.set_auto_mask(False)
        vals = {k: np.atleast_1d(np.array(nc.variables[k][...])) for k in keys}
    n = len(vals["dtheta1"])
    out = []
    for i in range(n):
        d = {k: float(vals[k][i]) for k in keys}
        for k in ("converged", "method", "status"):
            d[k] = int(d[k])
        d["index"] = i
        out.append(d)
    return out


def read_floquet_point(path: Path, controller: str = "sequence") -> dict:
    """One controller's analysed point of a floquet dataset: ``{fixed_point (3,), map_defect,
    newton_converged}`` (``newton_converged`` -1 when the dataset has none)."""
    with netCDF4.Dataset(path, "r") as nc:
        nc.set_auto_mask(False)
        labels = [str(x) for x in np.atleast_1d(nc.variables["controller"][...])]
        if controller not in labels:
            raise ValueError(f"{Path(path).name} has no {controller} controller")
        i = labels.index(controller)
        out = {"fixed_point": np.array(nc.variables["fixed_point"][i, :], float),
               "map_defect": float(nc.variables["map_defect"][i])}
        nc_conv = nc.variables.get("newton_converged")
        out["newton_converged"] = int(nc_conv[i]) if nc_conv is not None else -1
    return out


def read_floquet_multipliers(path: Path, controller: str = "open_loop") -> np.ndarray:
    """The variational multipliers of one controller of a floquet dataset (complex)."""
    with netCDF4.Dataset(path, "r") as nc:
        nc.set_auto_mask(False)
        labels = [str(x) for x in np.atleast_1d(nc.variables["controller"][...])]
        if controller not in labels:
            raise ValueError(f"{Path(path).name} has no {controller} controller")
        i = labels.index(controller)
        re = np.array(nc.variables["multipliers_real"][i, :])
        im = np.array(nc.variables["multipliers_imag"][i, :])
    return re + 1j * im
