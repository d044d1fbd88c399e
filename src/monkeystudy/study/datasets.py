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
}

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
               blocks: Iterable[tuple[int, dict[str, np.ndarray]]] = ()) -> dict:
    """Write a grid dataset, streaming ``blocks`` of ``(first flat index, arrays)``.

    ``axes`` (dtheta1, dtheta2 values) give dims ``dtheta1 x dtheta2`` (flat index in C order);
    ``points[n, 2]`` give dim ``point``. Returns ``{"skipped_fraction", "n_points"}``.
    """
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
        vs = {name: _var(nc, name, dims, dt, GRID_ATTRS[name], coordinates=coords)
              for name, dt in GRID_VARIABLES.items()}
        written = skipped = 0
        for lo, arrays in blocks:
            for name, v in vs.items():
                _write_flat(v, shape, lo, np.asarray(arrays[name], GRID_VARIABLES[name]))
            written += len(arrays["status"])
            skipped += int(np.count_nonzero(arrays["status"] == STATUS_NAMES.index("unreachable")))
        if written != n:
            raise RuntimeError(f"grid {path.name}: {written} of {n} points written")
        frac = skipped / n if n else 0.0
        _global_attrs(nc, dict(attrs, skipped_fraction=frac, n_points=n))
    return {"skipped_fraction": frac, "n_points": n}


def _write_flat(var, shape: tuple, lo: int, data: np.ndarray) -> None:
    """Write ``data`` at flat (C-order) indices ``lo..lo+len`` of a 1-D or 2-D variable."""
    if len(shape) == 1:
        var[lo:lo + data.size] = data
        return
    n2 = shape[1]
    pos, k = lo, 0
    while k < data.size:
        i, j = divmod(pos, n2)
        if j == 0 and data.size - k >= n2:        # whole rows at once
            rows = (data.size - k) // n2
            var[i:i + rows, :] = data[k:k + rows * n2].reshape(rows, n2)
            pos += rows * n2
            k += rows * n2
        else:                                     # a partial row
            m = min(n2 - j, data.size - k)
            var[i, j:j + m] = data[k:k + m]
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
        for key in ("error", "t_switch", "t_motor", "t_end"):
            _var(nc, key, sdim, np.float64, GRID_ATTRS[key], col(key))
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
    with atomic_netcdf(path) as nc:
        nc.createDimension("cycle", n)
        nc.createDimension("sample", ns)
        nc.createDimension("xy", 2)
        _var(nc, "cycle", ("cycle",), np.int32, {"long_name": "cycle number", "units": "1"},
             np.arange(1, n + 1))
        _var(nc, "xy", ("xy",), str, {"long_name": "world axis", "units": "1"}, np.array(["x", "y"], object))
        per_cycle = {
            "error": ("error against the initial rates at the vertical crossing ending the "
                      "cycle (MODEL.md section 4)", "1"),
            "kinetic_energy": ("kinetic energy at that vertical crossing", "J"),
            "pivot_height": ("world height of the attached end after the cycle's swap", "m"),
            "x_advance": ("horizontal displacement of the attached end in the cycle", "m"),
            "t_cross": ("time of the vertical crossing ending the cycle", "s"),
            "t_swap": ("time of the cycle's swap", "s"),
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
        _global_attrs(nc, dict(attrs, t_switch=float(gait["t_switch"]),
                               t_motor=float(gait["t_motor"]),
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
        vals = {k: np.atleast_1d(nc.variables[k][...]) for k in keys}
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
