"""What the robot senses of its own position on the wall, and how well (docs/route.md, "What
the robot senses").

A walked route replans after each catch from the *sensed* position of the attached magnet,
and each catch fires at a planned world height the robot judges from that estimate, so the
estimate's error ``e = estimate - true`` [m] shifts every catch. A sensor model turns the true
motion of one catch into the robot's new estimate:

* :class:`Exact` - the estimate is the truth (the reference).
* :class:`Odometry` - dead reckoning: at each catch the robot reads the attached link's
  absolute angle (an inclinometer) and the joint angle (an encoder) and adds the step vector
  of the read angles to its estimate; the errors add up from catch to catch.
* :class:`RangeFinder` - an absolute height (a range finder to the floor) for ``y``, odometry
  (or the truth) for ``x``: the height's error does not add up.
* :class:`Markers` - markers on the wall: at a catch near one the estimate is reset to the
  truth plus the marker reading's noise; elsewhere odometry.

Every model has ``initial(true_start, draws)`` (the estimate at the start) and ``update(
estimate, true_before, true_after, theta_at_catch, draws, *, lengths, attached)`` (the
estimate after one catch), pure functions of their arguments, ``to_dict()`` (plain JSON data)
and :func:`sensor_from_dict` to read it back.

Angles and frames
-----------------
``theta_at_catch = (theta1, theta2)`` [rad] are the kernel's angles at the catch in the frame
of the magnet the robot hung from (docs/model.md sections 1 and 3): ``theta1`` the attached
link's angle from the downward vertical (counter-clockwise positive), ``theta2`` the joint
angle of the far link relative to it. The free magnet then catches at the attached one plus the
step vector ``L1 (sin th1, -cos th1) + L2 (sin(th1 + th2), -cos(th1 + th2))``
(:func:`step_vector`), ``(L1, L2)`` the lengths of that frame: the robot's ``(link 1, link 2)``
with end A attached, ``(link 2, link 1)`` with end B attached. ``lengths`` is always the
robot's ``(link 1, link 2)`` [m] as built (``Robot.link1.length``, ``Robot.link2.length``) and
``attached`` the end it hung from (``"A"`` or ``"B"``); the model orders the lengths for the
frame. The encoder reads the physical joint angle, which is ``theta2`` with A attached and
``-theta2`` with B attached (the flip, ``theta2' = -theta2``), so its zero offset enters the
frame's ``theta2`` with the sign of the frame; each link carries its own inclinometer, whose
offset enters ``theta1`` with its own sign whichever end hangs (both frames measure angles
counter-clockwise).

Random draws
------------
A model reads its random numbers from a :class:`SensorDraws` value, built by
:func:`sensor_draws` from ``(seed, run, catch)`` alone (numpy's ``Philox`` with the seed as its
key and ``(run, catch, SENSOR_STREAM)`` in its counter): the same numbers for any worker count
or order. The per-run offsets are the draws of ``catch`` word ``PER_RUN_CATCH``, the same for
every catch of the run. Every model reads the same slots, so two models walked with the same
draws see the same noise (common random numbers).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import NamedTuple, Union

import numpy as np

from ..wall import END_NAMES, end_name

#: the counter word that tells the sensor's draws from any other Philox stream of a run
SENSOR_STREAM = 0x53454E53     # "SENS"

#: the catch word of the draws made once per run (the offsets, the start's readings)
PER_RUN_CATCH = 2 ** 64 - 1

_UINT64 = 2 ** 64


@dataclass(frozen=True)
class SensorDraws:
    """Standard normal draws of one catch of one run, and the run's own (:func:`sensor_draws`;
    each 0 by default: no error).

    Parameters
    ----------
    imu_bias_link1, imu_bias_link2 : float
        The run's draws for the zero offsets of the inclinometers on link 1 and link 2.
    encoder_bias : float
        The run's draw for the joint encoder's zero offset.
    range_bias : float
        The run's draw for the range finder's offset.
    range_start : float
        The run's draw for the range finder's reading at the start.
    imu, encoder, range_finder : float
        This catch's draws for the inclinometer's, the encoder's and the range finder's noise.
    marker_x, marker_y : float
        This catch's draws for a marker reading's noise in x and in y.
    """

    imu_bias_link1: float = 0.0
    imu_bias_link2: float = 0.0
    encoder_bias: float = 0.0
    range_bias: float = 0.0
    range_start: float = 0.0
    imu: float = 0.0
    encoder: float = 0.0
    range_finder: float = 0.0
    marker_x: float = 0.0
    marker_y: float = 0.0


#: the draws made once per run and the draws made per catch, in the order they are drawn
RUN_DRAWS = ("imu_bias_link1", "imu_bias_link2", "encoder_bias", "range_bias", "range_start")
CATCH_DRAWS = ("imu", "encoder", "range_finder", "marker_x", "marker_y")


def _word(value, what: str, upper: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{what} must be an integer, got {value!r}")
    v = int(value)
    if not 0 <= v < upper:
        raise ValueError(f"{what} must be in [0, {upper}), got {v}")
    return v


def _normals(seed: int, run: int, catch_word: int, n: int) -> np.ndarray:
    # the counter's lowest word counts the generator's blocks: the draws of one (run, catch)
    # never reach the next run's counter
    counter = np.array([0, run, catch_word, SENSOR_STREAM], dtype=np.uint64)
    rng = np.random.Generator(np.random.Philox(key=seed, counter=counter))
    return rng.standard_normal(n)


def sensor_draws(seed: int, run: int, catch: int) -> SensorDraws:
    """The draws of catch ``catch`` of run ``run`` under ``seed``.

    Parameters
    ----------
    seed : int
        The study's seed, in [0, 2**64): Philox's key.
    run : int
        The run, in [0, 2**64).
    catch : int
        The catch, in [0, 2**64 - 1) (the last word holds the run's own draws).

    Returns
    -------
    SensorDraws
        The run's draws (:data:`RUN_DRAWS`, the same for every catch of the run) and this
        catch's (:data:`CATCH_DRAWS`), each a standard normal; a function of ``(seed, run,
        catch)`` only.
    """
    seed = _word(seed, "seed", _UINT64)
    run = _word(run, "run", _UINT64)
    catch = _word(catch, "catch", PER_RUN_CATCH)
    per_run = _normals(seed, run, PER_RUN_CATCH, len(RUN_DRAWS))
    per_catch = _normals(seed, run, catch, len(CATCH_DRAWS))
    return SensorDraws(**{k: float(v) for k, v in zip(RUN_DRAWS, per_run)},
                      **{k: float(v) for k, v in zip(CATCH_DRAWS, per_catch)})


def step_vector(theta1: float, theta2: float, lengths: tuple[float, float]) -> np.ndarray:
    """The free end relative to the attached end [m] (docs/model.md section 1, end B).

    Parameters
    ----------
    theta1, theta2 : float
        The attached link's angle from the downward vertical and the joint angle [rad], in the
        frame of the attached end.
    lengths : (float, float)
        ``(L1, L2)`` of that frame [m]: the attached link's length, then the far link's.

    Returns
    -------
    numpy.ndarray
        ``L1 (sin th1, -cos th1) + L2 (sin(th1 + th2), -cos(th1 + th2))``, shape (2,).
    """
    l1, l2 = lengths
    a = theta1 + theta2
    return np.array([l1 * math.sin(theta1) + l2 * math.sin(a),
                     -l1 * math.cos(theta1) - l2 * math.cos(a)])


def quantise(value: float, resolution: float) -> float:
    """``value`` rounded to the nearest multiple of ``resolution`` (ties to even); a
    resolution of 0 returns the value. The error is at most ``resolution / 2``."""
    if resolution == 0.0:
        return float(value)
    return float(resolution * np.round(value / resolution))


def _nonnegative(value, what: str) -> float:
    if isinstance(value, bool):
        raise ValueError(f"{what} must be a number >= 0, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a number >= 0, got {value!r}") from None
    if not (math.isfinite(v) and v >= 0.0):
        raise ValueError(f"{what} must be >= 0 and finite, got {value!r}")
    return v


def _pair(value, what: str) -> tuple[float, float]:
    try:
        a, b = value
        pair = (float(a), float(b))
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a pair of numbers, got {value!r}") from None
    if not (math.isfinite(pair[0]) and math.isfinite(pair[1])):
        raise ValueError(f"{what} must be a pair of finite numbers, got {value!r}")
    return pair


def _point(value, what: str) -> np.ndarray:
    return np.array(_pair(value, what))


def frame_lengths(lengths, attached: str) -> tuple[float, float]:
    """``(L1, L2)`` [m] of the frame of the end ``attached`` from the robot's ``(link 1,
    link 2)`` lengths ``lengths`` [m]: as given with A attached, exchanged with B."""
    l1, l2 = _pair(lengths, "lengths")
    if not (l1 > 0.0 and l2 > 0.0):
        raise ValueError(f"lengths must be > 0 [m], got {lengths!r}")
    return (l1, l2) if end_name(attached) == END_NAMES[0] else (l2, l1)


def _check_fields(obj, names: tuple[str, ...]) -> None:
    for name in names:
        object.__setattr__(obj, name, _nonnegative(getattr(obj, name), name))


def _check_draws(draws) -> SensorDraws:
    if not isinstance(draws, SensorDraws):
        raise ValueError(f"draws must be a SensorDraws (sensor_draws), got {type(draws).__name__}")
    return draws


class _Catch(NamedTuple):
    """One catch's arguments, checked: the estimate and the true attached magnet before and
    after [m], the angles at the catch [rad], the frame's ``(L1, L2)`` [m] and the sign of the
    physical joint angle in that frame (+1 with A attached, -1 with B)."""

    estimate: np.ndarray
    true_before: np.ndarray
    true_after: np.ndarray
    theta: tuple[float, float]
    frame: tuple[float, float]
    joint_sign: float


def _catch(estimate, true_before, true_after, theta_at_catch, draws, lengths,
           attached) -> _Catch:
    _check_draws(draws)
    joint_sign = 1.0 if end_name(attached) == END_NAMES[0] else -1.0
    return _Catch(_point(estimate, "estimate"), _point(true_before, "true_before"),
                  _point(true_after, "true_after"), _pair(theta_at_catch, "theta_at_catch"),
                  frame_lengths(lengths, attached), joint_sign)


@dataclass(frozen=True)
class Exact:
    """The estimate is the truth: the reference every other model is compared with."""

    def initial(self, true_start, draws: SensorDraws) -> np.ndarray:
        """The estimate at the start: ``true_start`` [m]."""
        _check_draws(draws)
        return _point(true_start, "true_start")

    def update(self, estimate, true_before, true_after, theta_at_catch, draws: SensorDraws, *,
               lengths, attached: str) -> np.ndarray:
        """The estimate after a catch: ``true_after`` [m] (see :class:`Odometry.update` for
        the arguments, checked here the same way)."""
        return _catch(estimate, true_before, true_after, theta_at_catch, draws, lengths,
                      attached).true_after

    def to_dict(self) -> dict:
        """``{"kind": "exact"}``."""
        return {"kind": "exact"}


@dataclass(frozen=True)
class Odometry:
    """Dead reckoning from the angles read at each catch.

    At a catch the robot reads the attached link's absolute angle ``theta1`` with that link's
    inclinometer and the joint angle with the joint encoder, and adds the step vector of the
    read angles (:func:`step_vector`) to its estimate. Each catch's reading errors move that
    catch's step, so they add up from catch to catch: the noises as a random walk, the
    offsets (fixed for a run) as a drift.

    Parameters
    ----------
    angle_noise : float
        The joint encoder's noise [rad]: standard deviation of a reading's error, drawn per
        catch.
    angle_bias : float
        The joint encoder's zero offset [rad]: standard deviation of the offset each run draws
        once (``angle_bias * SensorDraws.encoder_bias``), the same for every catch of the run.
        It adds to the physical joint angle: to the frame's ``theta2`` with A attached, and
        is subtracted from it with B attached (``theta2' = -theta2``).
    encoder_resolution : float
        The encoder's step [rad]: its reading (offset and noise included) is rounded to the
        nearest multiple; 0 for none.
    imu_noise : float
        The inclinometer's noise [rad]: standard deviation of a reading's error of ``theta1``,
        drawn per catch.
    imu_bias : float
        The inclinometers' zero offset [rad]: standard deviation of the offset each run draws
        once per link (each link carries its own), the same for every catch of the run.
    """

    angle_noise: float = 0.0
    angle_bias: float = 0.0
    encoder_resolution: float = 0.0
    imu_noise: float = 0.0
    imu_bias: float = 0.0

    def __post_init__(self) -> None:
        _check_fields(self, tuple(f.name for f in fields(self)))

    def read_angles(self, theta_at_catch, draws: SensorDraws, attached: str) -> tuple[float, float]:
        """The angles the robot reads at a catch [rad].

        Parameters
        ----------
        theta_at_catch : (float, float)
            The true ``(theta1, theta2)`` [rad] in the frame of the end it hangs from.
        draws : SensorDraws
            The catch's draws (:func:`sensor_draws`).
        attached : {"A", "B"}
            The end it hangs from.

        Returns
        -------
        (float, float)
            The read ``(theta1, theta2)`` [rad], in the same frame.
        """
        theta1, theta2 = _pair(theta_at_catch, "theta_at_catch")
        _check_draws(draws)
        sign = 1.0 if end_name(attached) == END_NAMES[0] else -1.0
        return self._read(theta1, theta2, draws, sign)

    def _read(self, theta1: float, theta2: float, draws: SensorDraws,
              joint_sign: float) -> tuple[float, float]:
        # the attached link's own inclinometer: link 1's with A attached, link 2's with B
        imu_offset = draws.imu_bias_link1 if joint_sign > 0.0 else draws.imu_bias_link2
        read1 = theta1 + self.imu_bias * imu_offset + self.imu_noise * draws.imu
        # the encoder reads the physical joint angle: theta2 in A's frame, -theta2 in B's
        joint = (joint_sign * theta2 + self.angle_bias * draws.encoder_bias
                 + self.angle_noise * draws.encoder)
        return read1, joint_sign * quantise(joint, self.encoder_resolution)

    def _dead_reckon(self, catch: _Catch, draws: SensorDraws) -> np.ndarray:
        read1, read2 = self._read(*catch.theta, draws, catch.joint_sign)
        return catch.estimate + step_vector(read1, read2, catch.frame)

    def initial(self, true_start, draws: SensorDraws) -> np.ndarray:
        """The estimate at the start: ``true_start`` [m] (the robot is placed at a known
        point)."""
        _check_draws(draws)
        return _point(true_start, "true_start")

    def update(self, estimate, true_before, true_after, theta_at_catch, draws: SensorDraws, *,
               lengths, attached: str) -> np.ndarray:
        """The estimate after a catch [m].

        Parameters
        ----------
        estimate : (float, float)
            The estimate of the attached magnet before the catch [m].
        true_before, true_after : (float, float)
            The true attached magnet before and after the catch [m] (dead reckoning reads
            neither; the absolute sensors read ``true_after``).
        theta_at_catch : (float, float)
            The true ``(theta1, theta2)`` at the catch [rad], in the frame of the magnet the
            robot hung from (the kernel's values before the swap).
        draws : SensorDraws
            The catch's draws (:func:`sensor_draws`).
        lengths : (float, float)
            The robot's ``(link 1, link 2)`` lengths [m] as built, whichever end hangs.
        attached : {"A", "B"}
            The end the robot hung from.

        Returns
        -------
        numpy.ndarray
            ``estimate + step_vector(read angles)``, shape (2,).
        """
        return self._dead_reckon(_catch(estimate, true_before, true_after, theta_at_catch,
                                        draws, lengths, attached), draws)

    def to_dict(self) -> dict:
        """``{"kind": "odometry", <field>: value, ...}`` (plain JSON data)."""
        return {"kind": "odometry", **{f.name: getattr(self, f.name) for f in fields(self)}}


#: where a :class:`RangeFinder` takes ``x`` from
X_SOURCES = ("odometry", "exact")


@dataclass(frozen=True)
class RangeFinder:
    """An absolute height: a downward range finder to the floor for ``y``.

    The estimate's ``y`` is the reading ``true y + offset + noise`` rounded to the nearest
    multiple of ``resolution``, at every catch and at the start, so its error does not add
    up. Its ``x`` is dead reckoned (``x_from="odometry"``: the x of the odometry's step added
    to the estimate's x, the errors adding up in x only) or the truth (``x_from="exact"``).

    Parameters
    ----------
    noise : float
        Standard deviation of a reading's error [m], drawn per catch.
    bias : float
        Standard deviation of the run's offset [m], drawn once per run
        (``bias * SensorDraws.range_bias``).
    resolution : float
        The reading's step [m]; 0 for none.
    x_from : {"odometry", "exact"}
        Where ``x`` comes from.
    odometry : Odometry
        The dead reckoning of ``x``.
    """

    noise: float = 0.0
    bias: float = 0.0
    resolution: float = 0.0
    x_from: str = "odometry"
    odometry: Odometry = field(default_factory=Odometry)

    def __post_init__(self) -> None:
        _check_fields(self, ("noise", "bias", "resolution"))
        if self.x_from not in X_SOURCES:
            raise ValueError(f"x_from must be one of {', '.join(X_SOURCES)}, got {self.x_from!r}")
        if not isinstance(self.odometry, Odometry):
            raise ValueError(f"odometry must be an Odometry, got {type(self.odometry).__name__}")

    def read_height(self, true_y: float, draws: SensorDraws, noise_draw: float) -> float:
        """The height read [m] at true height ``true_y`` [m] with the run's offset and the
        standard normal ``noise_draw`` for this reading."""
        return quantise(true_y + self.bias * draws.range_bias + self.noise * noise_draw,
                        self.resolution)

    def initial(self, true_start, draws: SensorDraws) -> np.ndarray:
        """The estimate at the start [m]: the true ``x`` and the height read there (with the
        run's ``range_start`` draw)."""
        start = _point(true_start, "true_start")
        _check_draws(draws)
        return np.array([start[0], self.read_height(start[1], draws, draws.range_start)])

    def update(self, estimate, true_before, true_after, theta_at_catch, draws: SensorDraws, *,
               lengths, attached: str) -> np.ndarray:
        """The estimate after a catch [m] (arguments as :meth:`Odometry.update`)."""
        catch = _catch(estimate, true_before, true_after, theta_at_catch, draws, lengths,
                       attached)
        after = catch.true_after
        x = self.odometry._dead_reckon(catch, draws)[0] if self.x_from == "odometry" else after[0]
        return np.array([x, self.read_height(after[1], draws, draws.range_finder)])

    def to_dict(self) -> dict:
        """``{"kind": "range_finder", ..., "odometry": {...}}`` (plain JSON data)."""
        return {"kind": "range_finder", "noise": self.noise, "bias": self.bias,
                "resolution": self.resolution, "x_from": self.x_from,
                "odometry": self.odometry.to_dict()}


@dataclass(frozen=True)
class Markers:
    """Markers on the wall: a catch near one resets the estimate.

    At a catch whose true position lies within ``radius`` of a marker (its rim included) the
    robot reads the marker: the estimate becomes the true position plus the reading's noise
    (per axis, per catch), and what odometry had added up is gone. At any other catch, and
    from the start (a known point), it is dead reckoned.

    Parameters
    ----------
    positions : sequence of (float, float)
        The markers [m], in the wall's frame.
    radius : float
        How far from a marker a catch reads it [m].
    noise : float
        Standard deviation of a marker reading's error [m] in x and in y, drawn per catch.
    odometry : Odometry
        The dead reckoning between markers.
    """

    positions: tuple[tuple[float, float], ...]
    radius: float
    noise: float = 0.0
    odometry: Odometry = field(default_factory=Odometry)

    def __post_init__(self) -> None:
        try:
            p = np.array(self.positions, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"positions must be a list of (x, y) pairs, got "
                             f"{self.positions!r}") from None
        if p.size == 0:
            p = p.reshape(0, 2)
        if p.ndim != 2 or p.shape[1] != 2 or not np.all(np.isfinite(p)):
            raise ValueError(f"positions must be a list of finite (x, y) pairs, got "
                             f"{self.positions!r}")
        object.__setattr__(self, "positions", tuple((float(x), float(y)) for x, y in p))
        _check_fields(self, ("radius", "noise"))
        if not isinstance(self.odometry, Odometry):
            raise ValueError(f"odometry must be an Odometry, got {type(self.odometry).__name__}")

    def near_marker(self, point) -> bool:
        """Whether ``point`` [m] lies within ``radius`` of a marker (its rim included)."""
        if not self.positions:
            return False
        d = np.hypot(*(np.asarray(self.positions) - _point(point, "point")).T)
        return bool(d.min() <= self.radius)

    def initial(self, true_start, draws: SensorDraws) -> np.ndarray:
        """The estimate at the start: ``true_start`` [m] (a known point)."""
        _check_draws(draws)
        return _point(true_start, "true_start")

    def update(self, estimate, true_before, true_after, theta_at_catch, draws: SensorDraws, *,
               lengths, attached: str) -> np.ndarray:
        """The estimate after a catch [m] (arguments as :meth:`Odometry.update`)."""
        catch = _catch(estimate, true_before, true_after, theta_at_catch, draws, lengths,
                       attached)
        if self.near_marker(catch.true_after):
            return catch.true_after + self.noise * np.array([draws.marker_x, draws.marker_y])
        return self.odometry._dead_reckon(catch, draws)

    def to_dict(self) -> dict:
        """``{"kind": "markers", "positions": [[x, y], ...], ...}`` (plain JSON data)."""
        return {"kind": "markers", "positions": [list(p) for p in self.positions],
                "radius": self.radius, "noise": self.noise,
                "odometry": self.odometry.to_dict()}


#: a sensor model
SensorModel = Union[Exact, Odometry, RangeFinder, Markers]

_KINDS = {"exact": Exact, "odometry": Odometry, "range_finder": RangeFinder, "markers": Markers}


def sensor_from_dict(d: dict) -> SensorModel:
    """The sensor model of ``to_dict``'s plain data (missing fields take their defaults).

    Raises
    ------
    ValueError
        An unknown ``kind`` or key, or a bad value (naming the field).
    """
    if not isinstance(d, dict):
        raise ValueError(f"a sensor is a mapping, got {type(d).__name__}")
    kind = d.get("kind")
    if kind not in _KINDS:
        raise ValueError(f"sensor kind must be one of {', '.join(_KINDS)}, got {kind!r}")
    cls = _KINDS[kind]
    known = {f.name for f in fields(cls)}
    values = {}
    for key, value in d.items():
        if key == "kind":
            continue
        if key not in known:
            raise ValueError(f"sensor {kind}: unknown key {key!r} (known: "
                             f"{', '.join(sorted(known)) or 'none'})")
        if key == "odometry":
            if not (isinstance(value, dict) and value.get("kind", "odometry") == "odometry"):
                raise ValueError(f"sensor {kind}: odometry must be an odometry mapping, got "
                                 f"{value!r}")
            value = sensor_from_dict({**value, "kind": "odometry"})
        values[key] = value
    try:
        return cls(**values)
    except TypeError as exc:     # a required field missing
        raise ValueError(f"sensor {kind}: {exc}") from None


__all__ = ["CATCH_DRAWS", "Exact", "Markers", "Odometry", "PER_RUN_CATCH", "RUN_DRAWS",
           "RangeFinder", "SENSOR_STREAM", "SensorDraws", "SensorModel", "X_SOURCES",
           "frame_lengths", "quantise", "sensor_draws", "sensor_from_dict", "step_vector"]
