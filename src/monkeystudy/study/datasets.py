"""The netCDF layer of study datasets (``docs/datasets.md``): atomic files, labelled variables.

Files are written with netCDF4-python into a temporary file in the destination folder, closed,
flushed to disk and moved into place with ``os.replace`` (:func:`atomic_netcdf`): a reader
sees either no file or a complete one, and a finished file is never reopened for writing.
Read them with plain ``xarray.open_dataset(path)``. Each step kind writes its own dataset with
these helpers (:mod:`monkeystudy.study.steps`).

Every variable carries ``units`` (UDUNITS) and ``long_name``; status codes carry CF
``flag_values``/``flag_meanings``; attribute values are text or numbers (structured values are
JSON text). A step kind declares its variables once (a mapping of name to :class:`Variable`,
the kind's ``variables``) and writes each from its declaration (:func:`write_declared`); the
tests hold the declarations against docs/datasets.md and against the datasets written.
"""
from __future__ import annotations

import json
import os
import uuid
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Mapping

import netCDF4
import numpy as np

from ..simulation import STATUS_NAMES, StateIndex, physical_points

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

#: units of the gait error: theta2_f^2 is in rad2, the squared rate differences in rad2 s-2 -
#: a sum of mixed units, as the 2009 study defines it (docs/model.md)
ERROR_UNITS = "rad2 + rad2 s-2"
ERROR_COMMENT = ("a sum of mixed units, as the 2009 study defines the error: theta2_f^2 [rad2] "
                 "plus two squared rate differences [rad2 s-2]")

#: what the error of a horizontal gait's evaluation is
GAIT_ERROR = ("gait error: theta2_f^2 + (dtheta1 - dtheta1_f)^2 + (dtheta2 - dtheta2_f)^2 "
              "(docs/model.md)")
#: what the error of a sequence gait's evaluation is
SECTION_ERROR = ("section error: wrap(theta2_f - theta2_0)^2 + (dtheta1_f - dtheta1_0)^2 + "
                 "(dtheta2_f - dtheta2_0)^2 after one cycle")
#: the event ending a horizontal gait's and a sequence gait's evaluation
GAIT_END = "the vertical crossing ending the gait"
SECTION_END = "the section crossing ending the cycle"

#: units and long_name of a gait evaluation's variables (grid, refine, shoot, floquet, ...)
GAIT_ATTRS = {
    "error": {"long_name": GAIT_ERROR + "; NaN unless ok",
              "units": ERROR_UNITS, "comment": ERROR_COMMENT},
    "status": STATUS_ATTRS,
    "t_switch": {"long_name": "time of the swap after the gait start", "units": "s"},
    "t_motor": {"long_name": "motor-on duration after the swap", "units": "s"},
    "t_end": {"long_name": "time of " + GAIT_END, "units": "s"},
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
    "error": {"long_name": SECTION_ERROR + "; NaN unless ok", "units": ERROR_UNITS,
              "comment": ERROR_COMMENT},
    "t_end": {"long_name": "time of " + SECTION_END, "units": "s"},
}


def gait_fields(sequence: bool) -> dict[str, str]:
    """The ``{gait_error}`` and ``{gait_end}`` fields of a declared long_name
    (:class:`Variable`) for a horizontal gait's evaluations or a sequence gait's."""
    return ({"gait_error": SECTION_ERROR, "gait_end": SECTION_END} if sequence
            else {"gait_error": GAIT_ERROR, "gait_end": GAIT_END})


#: long_name of a sequence gait's segment coordinate
SEGMENT_NOTE = "segment of the cycle (the last: the section)"

DTHETA1 = {"long_name": "initial angular rate of link 1 (dtheta1)", "units": RATE}
DTHETA2 = {"long_name": "initial relative angular rate of link 2 (dtheta2)", "units": RATE}


# --- declared variables ------------------------------------------------------------------------
@dataclass(frozen=True)
class Variable:
    """A dataset variable as its step kind declares it.

    ``long_name`` (and ``units``) may hold ``str.format`` fields (``{gait_end}``) for the
    words that depend on the run (a continuation's parameter and its units), filled when the
    variable is written (:func:`write_declared`); ``attrs`` are the
    attributes after ``long_name`` and ``units`` (``comment``, CF ``flag_values`` and
    ``flag_meanings``, ...). An ``optional`` variable is written by some runs only (a sequence
    gait's, or one a step option asks for); every other one is in every dataset of its kind.
    ``dims`` are those of the usual layout (a writer may state others: a grid's point list).
    """

    dims: tuple[str, ...]
    dtype: Any
    units: str
    long_name: str
    attrs: Mapping[str, Any] = field(default_factory=dict)
    optional: bool = False

    @classmethod
    def of(cls, dims: tuple[str, ...], dtype, attrs: Mapping[str, Any], *,
           long_name: str | None = None, optional: bool = False) -> "Variable":
        """A variable with the attributes ``attrs`` (``long_name``, ``units`` and the rest),
        its long_name replaced by ``long_name`` when given."""
        rest = {k: v for k, v in attrs.items() if k not in ("long_name", "units")}
        return cls(tuple(dims), dtype, attrs["units"],
                   attrs["long_name"] if long_name is None else long_name, rest, optional)

    def attributes(self, **fields) -> dict[str, Any]:
        """Its attributes as written: ``long_name`` and ``units`` (``fields`` filled in), then
        the rest."""
        return {"long_name": self.long_name.format(**fields),
                "units": self.units.format(**fields), **self.attrs}


def complex_variables(name: str, dims: tuple[str, ...], what: str,
                      optional: bool = False) -> dict[str, Variable]:
    """The declarations of a complex variable stored as ``<name>_real`` and ``<name>_imag``
    (:func:`write_complex`), dimensionless; ``what`` is the long_name before ", real part"."""
    return {f"{name}_{part}": Variable(tuple(dims), np.float64, "1", f"{what}, {label} part",
                                       optional=optional)
            for part, label in (("real", "real"), ("imag", "imaginary"))}


def index_coordinate(dim: str, long_name: str, optional: bool = False) -> Variable:
    """The declaration of an integer coordinate numbering dimension ``dim``."""
    return Variable((dim,), np.int32, "1", long_name, optional=optional)


def label_coordinate(dim: str, long_name: str, optional: bool = False) -> Variable:
    """The declaration of a text coordinate naming the entries of dimension ``dim``."""
    return Variable((dim,), str, "1", long_name, optional=optional)


#: points gathered from consecutive blocks before one write per variable: each netCDF slice
#: write costs ~0.1 ms of library overhead, so a 10^5-point map written block by block and
#: row piece by row piece spent ~0.2 s there; the buffer (~15 MB) keeps memory flat in the
#: grid size
WRITE_BUFFER_POINTS = 1 << 17


# --- writing -----------------------------------------------------------------------------------
def fsync_dir(folder: Path) -> None:
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
        fsync_dir(path.parent)
    except BaseException:
        try:
            nc.close()
        except Exception:  # already closed
            pass
        tmp.unlink(missing_ok=True)
        raise


def attr_value(value: Any) -> Any:
    """A value netCDF can store as an attribute: bools as 0/1, dicts and lists as JSON text,
    None as empty text."""
    if isinstance(value, (bool, np.bool_)):
        return int(value)
    if isinstance(value, (dict, list, tuple)):
        return json.dumps(value, sort_keys=True)
    if value is None:
        return ""
    return value


def add_variable(nc, name: str, dims: tuple, dtype, attrs: dict, data=None,
                 coordinates: str = ""):
    """Create variable ``name`` over ``dims`` with ``attrs`` (units, long_name, ...) and
    write ``data``; NaN is the fill value of float variables."""
    dtype = np.dtype(dtype) if dtype is not str else str
    fill = np.nan if dtype is not str and np.dtype(dtype).kind == "f" else False
    v = nc.createVariable(name, dtype, dims, fill_value=fill)
    for k, val in attrs.items():
        v.setncattr(k, attr_value(val))
    if coordinates:
        v.setncattr("coordinates", coordinates)
    if data is not None:
        if dims:
            v[...] = np.asarray(data, dtype=dtype) if dtype is not str else np.asarray(data,
                                                                                       object)
        else:
            v.assignValue(np.asarray(data, dtype=dtype))
    return v


def write_declared(nc, declared: Mapping[str, Variable], name: str, data=None, *,
                   dims: tuple[str, ...] | None = None, coordinates: str = "",
                   written_as: str | None = None, **fields):
    """Create variable ``name`` as ``declared`` says (dims, dtype, units, long_name with
    ``fields`` filled in, attributes) and write ``data``; ``dims`` replaces the declared dims
    for a layout other than the usual one, ``written_as`` the name for a variable declared
    once for many (a design's ``<parameter>``, written as each free parameter's name). Fields
    a long_name does not use are ignored."""
    var = declared[name]
    return add_variable(nc, name if written_as is None else written_as,
                        var.dims if dims is None else dims, var.dtype,
                        var.attributes(**fields), data, coordinates=coordinates)


def write_coordinate(nc, declared: Mapping[str, Variable], name: str, values,
                     **fields) -> None:
    """Dimension ``name`` of ``len(values)`` entries and its coordinate variable ``values``
    as ``declared`` says."""
    nc.createDimension(name, len(values))
    write_declared(nc, declared, name, values, **fields)


def write_complex(nc, declared: Mapping[str, Variable], name: str, values, *,
                  dims: tuple[str, ...] | None = None, **fields) -> None:
    """A complex array as the declared ``<name>_real`` and ``<name>_imag``
    (:func:`complex_variables`)."""
    v = np.asarray(values, complex)
    write_declared(nc, declared, f"{name}_real", v.real, dims=dims, **fields)
    write_declared(nc, declared, f"{name}_imag", v.imag, dims=dims, **fields)


def set_global_attrs(nc, attrs: dict) -> None:
    """Write ``attrs`` as the file's global attributes (:func:`attr_value`)."""
    for k, val in attrs.items():
        nc.setncattr(k, attr_value(val))


#: long_name tail of a section state's components
SECTION_NOTE = ("on the gait's section (theta1 = 0 unless the gait says), components (theta2 [rad], dtheta1 [rad s-1], "
                 "dtheta2 [rad s-1])")


def status_counts(status: np.ndarray) -> str:
    """``ok 120 (95.2%), no_switch 6 (4.8%)``: how often each status occurs."""
    vals, counts = np.unique(np.asarray(status).ravel(), return_counts=True)
    parts = []
    for v, c in zip(vals, counts):
        name = STATUS_NAMES[int(v)] if 0 <= int(v) < len(STATUS_NAMES) else str(v)
        parts.append(f"{name} {c} ({100.0 * c / status.size:.1f}%)")
    return ", ".join(parts)


def dataset_complex(ds, name: str) -> np.ndarray:
    """A complex variable stored as ``<name>_real`` and ``<name>_imag`` of an xarray Dataset."""
    return ds[f"{name}_real"].values + 1j * ds[f"{name}_imag"].values


def moduli(lam) -> str:
    """``|lambda|`` of each multiplier, as text."""
    return ", ".join(f"{abs(x):.6g}" for x in np.ravel(lam))


# --- reading -----------------------------------------------------------------------------------
def read_attrs(path: Path) -> dict | None:
    """Global attributes of a dataset, or None if it is missing or unreadable."""
    try:
        with netCDF4.Dataset(path, "r") as nc:
            return {k: nc.getncattr(k) for k in nc.ncattrs()}
    except (OSError, RuntimeError):
        return None


def read_variables(path: Path, names) -> dict[str, np.ndarray]:
    """Variables ``names`` of a dataset as numpy arrays (at least 1-D); names it lacks are
    left out."""
    with netCDF4.Dataset(path, "r") as nc:
        nc.set_auto_mask(False)
        return {k: np.atleast_1d(np.array(nc.variables[k][...])) for k in names
                if k in nc.variables}


# --- multi-cycle runs ------------------------------------------------------------------------
#: the frame's angles and rates a dataset of a multi-cycle run samples: (name, index in the 8-state)
TRAJECTORY_ANGLES = (("theta1", StateIndex.THETA1), ("theta2", StateIndex.THETA2),
                     ("theta1_dot", StateIndex.THETA1_DOT),
                     ("theta2_dot", StateIndex.THETA2_DOT))


def run_record(res) -> dict[str, Any]:
    """A multi-cycle run's status, counts and sampled trajectory for a stability dataset:
    world positions [m] of A, the joint and B; the frame's angles [rad] and rates [rad s-1];
    which end the frame hangs from; the phase; the motor torque [N m]."""
    flipped = res.sample_flipped
    pts = physical_points(res.params, res.sample_state, flipped)
    return {
        "status": int(res.status), "cycles_completed": res.cycles,
        "time": res.sample_t.copy(), "A": pts["A"], "joint": pts["joint"], "B": pts["B"],
        **{name: res.sample_state[:, i].copy() for name, i in TRAJECTORY_ANGLES},
        "attached_end": flipped.astype(np.int8),
        "phase": res.sample_phase.astype(np.int8),
        "motor_torque": res.sample_torque.copy(),
        "steps": res.steps, "nfev": res.nfev,
    }
