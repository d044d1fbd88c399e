"""The wall the robot climbs, as data: steel regions with holes, the start and the goal.

A value type beside :mod:`monkeystudy.robot`: no simulation. Coordinates are the simulator's
world frame in the plane of the wall, ``x`` along the wall and ``y`` up [m]; the robot swings in
that plane and a magnet holds wherever it lands on steel (docs/route.md).

* A :class:`Region` is one steel plate: a simple polygon (its outline) less the simple
  polygons of its holes (a window, a cut-out). An edge of the wall is just a region's
  boundary; regions may touch or overlap.
* Steel is a closed set: a point on an outline or on a hole's boundary (within
  :data:`BOUNDARY_TOL`) is on steel; a hole removes its interior only.
* A catch holds when the magnet's footprint, the disc of radius :attr:`Wall.margin` about the
  catch point, lies on one region (:meth:`Wall.clearance`). A footprint across the seam of
  two touching or overlapping regions is not counted: draw one plate as one region.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Sequence

import numpy as np

#: the robot's two magnets (link 1 carries end A, link 2 end B)
END_NAMES = ("A", "B")

#: how close to a boundary a point counts as on it [m]
BOUNDARY_TOL = 1e-9

#: points per block of the vectorised polygon tests (bounds their N x M work arrays)
_BLOCK = 4096


def _orientation(p, q, r) -> float:
    """Twice the signed area of the triangle ``p q r`` [m2] (> 0: counter-clockwise)."""
    return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])


def _segments_meet(a, b, c, d, tol: float) -> bool:
    """Whether the closed segments ``a b`` and ``c d`` share a point (within ``tol`` [m2] of
    collinearity)."""
    o1, o2 = _orientation(a, b, c), _orientation(a, b, d)
    o3, o4 = _orientation(c, d, a), _orientation(c, d, b)
    if ((o1 > tol and o2 < -tol) or (o1 < -tol and o2 > tol)) and \
            ((o3 > tol and o4 < -tol) or (o3 < -tol and o4 > tol)):
        return True

    def on(p, q, r, o):        # r collinear with p q and within its bounding box
        return abs(o) <= tol and min(p[0], q[0]) - 1e-12 <= r[0] <= max(p[0], q[0]) + 1e-12 \
            and min(p[1], q[1]) - 1e-12 <= r[1] <= max(p[1], q[1]) + 1e-12
    return on(a, b, c, o1) or on(a, b, d, o2) or on(c, d, a, o3) or on(c, d, b, o4)


def simple_polygon(vertices: Sequence[Sequence[float]]) -> tuple[tuple[float, float], ...]:
    """The vertices of a simple polygon [m], checked: at least three distinct finite points,
    no repeated consecutive vertex, a non-zero area, no edge meeting another but its
    neighbours at their shared vertex. A closing vertex equal to the first is dropped.

    Raises
    ------
    ValueError
        Saying what is degenerate (vertices numbered from 0).
    """
    try:
        v = np.asarray(vertices, dtype=float)
    except (TypeError, ValueError):
        raise ValueError("vertices must be (x, y) pairs of numbers [m]") from None
    if v.ndim != 2 or v.shape[1] != 2:
        raise ValueError(f"vertices must be (x, y) pairs [m], got an array of shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError("vertices must be finite")
    if len(v) > 1 and np.array_equal(v[0], v[-1]):
        v = v[:-1]
    n = len(v)
    if n < 3:
        raise ValueError(f"a polygon needs at least 3 vertices, got {n}")
    nxt = np.roll(v, -1, axis=0)
    length = np.hypot(*(nxt - v).T)
    scale = float(np.max(np.abs(v))) or 1.0
    if np.any(length <= BOUNDARY_TOL):
        k = int(np.argmax(length <= BOUNDARY_TOL))
        raise ValueError(f"vertices {k} and {(k + 1) % n} coincide at "
                         f"({v[k, 0]:g}, {v[k, 1]:g})")
    tol = 1e-12 * scale * scale
    for i in range(n):
        for j in range(i + 1, n):
            if j == i + 1 or (i == 0 and j == n - 1):
                # neighbours share a vertex; they overlap only if they fold back on each other
                a, b, c = (v[i], v[j], nxt[j]) if j == i + 1 else (v[j], v[0], v[1])
                o = _orientation(a, b, c)
                back = np.dot(np.subtract(b, a), np.subtract(c, b)) < 0
                if abs(o) <= tol and back:
                    raise ValueError(f"edges {i} and {j} fold back onto each other")
                continue
            if _segments_meet(v[i], nxt[i], v[j], nxt[j], tol):
                raise ValueError(f"the polygon crosses itself: edge {i} (vertices {i}-"
                                 f"{(i + 1) % n}) meets edge {j} (vertices {j}-{(j + 1) % n})")
    area = 0.5 * float(np.sum(v[:, 0] * nxt[:, 1] - nxt[:, 0] * v[:, 1]))
    if abs(area) <= BOUNDARY_TOL * scale:
        raise ValueError(f"the polygon has no area (its {n} vertices are collinear)")
    return tuple((float(x), float(y)) for x, y in v)


def _as_points(points) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.shape == (2,):
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"points must be (x, y) pairs [m], got an array of shape {p.shape}")
    return p


def _inside_odd(poly: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Even-odd test of points ``p`` (N, 2) against polygon ``poly`` (M, 2): True strictly
    inside (a point on the boundary may go either way: callers decide it by distance)."""
    a, b = poly, np.roll(poly, -1, axis=0)
    x, y = p[:, 0:1], p[:, 1:2]
    straddles = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return (np.sum(straddles & (x < x_cross), axis=1) % 2).astype(bool)


def _edge_distance(poly: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Distance of points ``p`` (N, 2) to the boundary of ``poly`` (M, 2) [m]."""
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    ap_x, ap_y = p[:, 0:1] - a[:, 0], p[:, 1:2] - a[:, 1]
    t = np.clip((ap_x * ab[:, 0] + ap_y * ab[:, 1]) / np.sum(ab * ab, axis=1), 0.0, 1.0)
    return np.min(np.hypot(ap_x - t * ab[:, 0], ap_y - t * ab[:, 1]), axis=1)


@dataclass(frozen=True)
class Region:
    """One steel plate: a simple polygon less the interiors of its holes.

    Parameters
    ----------
    outline : sequence of (x, y)
        The plate's vertices [m], in either sense (:func:`simple_polygon`).
    holes : sequence of sequences of (x, y)
        Polygons removed from it [m] (a window, a hole in the sheet); a hole may reach past
        the outline (a notch in an edge).
    """

    outline: tuple[tuple[float, float], ...]
    holes: tuple[tuple[tuple[float, float], ...], ...] = ()
    _arrays: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        try:
            outline = simple_polygon(self.outline)
        except ValueError as exc:
            raise ValueError(f"outline: {exc}") from None
        holes = []
        for k, hole in enumerate(self.holes):
            try:
                holes.append(simple_polygon(hole))
            except ValueError as exc:
                raise ValueError(f"holes[{k}]: {exc}") from None
        object.__setattr__(self, "outline", outline)
        object.__setattr__(self, "holes", tuple(holes))
        object.__setattr__(self, "_arrays", (np.array(outline),
                                             tuple(np.array(h) for h in holes)))

    def clearance(self, points) -> np.ndarray:
        """For each point (N, 2) [m]: the radius [m] of the largest disc about it that lies on
        this region (0 on its boundary), or ``-inf`` off it."""
        p = _as_points(points)
        outline, holes = self._arrays
        out = np.empty(len(p))
        for lo in range(0, len(p), _BLOCK):
            q = p[lo:lo + _BLOCK]
            d = _edge_distance(outline, q)
            steel = _inside_odd(outline, q) | (d <= BOUNDARY_TOL)
            for hole in holes:
                dh = _edge_distance(hole, q)
                steel &= ~(_inside_odd(hole, q) & (dh > BOUNDARY_TOL))
                d = np.minimum(d, dh)
            out[lo:lo + _BLOCK] = np.where(steel, np.where(d <= BOUNDARY_TOL, 0.0, d), -np.inf)
        return out

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(x_min, y_min, x_max, y_max)`` of the outline [m]."""
        v = self._arrays[0]
        return (float(v[:, 0].min()), float(v[:, 1].min()), float(v[:, 0].max()),
                float(v[:, 1].max()))


def end_name(end: str) -> str:
    """``end`` checked to be one of :data:`END_NAMES` (``A`` or ``B``)."""
    if end not in END_NAMES:
        raise ValueError(f"an end is A or B, got {end!r}")
    return end


def _point(value, what: str) -> tuple[float, float]:
    try:
        x, y = (float(c) for c in value)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be an (x, y) pair [m], got {value!r}") from None
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"{what} must be finite, got ({x!r}, {y!r})")
    return x, y


@dataclass(frozen=True)
class Start:
    """Where the robot hangs: the attached magnet's position [m] and which end it is."""

    position: tuple[float, float]
    attached: str = "A"

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _point(self.position, "start position"))
        end_name(self.attached)


@dataclass(frozen=True)
class Goal:
    """Where the robot is to go: a catch within ``radius`` [m] of ``position`` [m] arrives
    (the disc is closed, its rim within :data:`BOUNDARY_TOL` included, as steel's is)."""

    position: tuple[float, float]
    radius: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _point(self.position, "goal position"))
        r = float(self.radius)
        if not (math.isfinite(r) and r > 0.0):
            raise ValueError(f"goal radius must be > 0 and finite, got {self.radius!r}")
        object.__setattr__(self, "radius", r)

    def distance(self, points) -> np.ndarray:
        """For each point (N, 2): its distance from the goal's disc [m] (0 inside it)."""
        p = _as_points(points)
        d = np.hypot(p[:, 0] - self.position[0], p[:, 1] - self.position[1]) - self.radius
        return np.where(d <= BOUNDARY_TOL, 0.0, d)


@dataclass(frozen=True)
class Wall:
    """A wall: its steel regions, the start, the goal and the magnet's footprint.

    Parameters
    ----------
    regions : sequence of Region
        The steel plates (at least one).
    start : Start
        The attached magnet, which must be on steel (a footprint within ``margin`` of an edge
        is allowed: the magnet is already holding there).
    goal : Goal
        The point and radius to reach; whether a route gets there is the planner's question
        (:func:`monkeystudy.analysis.route.plan_route`).
    margin : float
        The footprint's radius [m]: a catch holds only when it lands at least ``margin``
        inside one region (:meth:`can_catch`).

    Raises
    ------
    ValueError
        No region, a negative or non-finite margin, or a start off steel.
    """

    regions: tuple[Region, ...]
    start: Start
    goal: Goal
    margin: float = 0.0

    def __post_init__(self) -> None:
        regions = tuple(self.regions)
        if not regions:
            raise ValueError("a wall needs at least one steel region")
        object.__setattr__(self, "regions", regions)
        m = float(self.margin)
        if not (math.isfinite(m) and m >= 0.0):
            raise ValueError(f"margin must be >= 0 and finite [m], got {self.margin!r}")
        object.__setattr__(self, "margin", m)
        if not self.on_steel(self.start.position)[0]:
            x, y = self.start.position
            raise ValueError(f"start ({x:g}, {y:g}) is not on steel: the attached magnet "
                             f"must hold on a region")

    def clearance(self, points) -> np.ndarray:
        """For each point (N, 2) [m]: the radius [m] of the largest disc about it on one
        region (0 on a boundary), ``-inf`` off steel."""
        p = _as_points(points)
        return np.max([r.clearance(p) for r in self.regions], axis=0)

    def on_steel(self, points) -> np.ndarray:
        """Whether each point (N, 2) [m] is on steel (a boundary point is)."""
        return self.clearance(points) >= 0.0

    def can_catch(self, points) -> np.ndarray:
        """Whether a magnet landing at each point (N, 2) [m] holds: its footprint of radius
        :attr:`margin` lies on one region."""
        return self.clearance(points) >= self.margin

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(x_min, y_min, x_max, y_max)`` of the steel [m]: no catch lies outside it."""
        e = np.array([r.extent for r in self.regions])
        return (float(e[:, 0].min()), float(e[:, 1].min()), float(e[:, 2].max()),
                float(e[:, 3].max()))

    def with_start(self, position, attached: str) -> "Wall":
        """This wall with the robot hanging from ``attached`` at ``position`` [m] (checked
        to be on steel)."""
        return replace(self, start=Start(position, attached))

    def to_dict(self) -> dict:
        """The wall as plain lists and numbers (JSON), in the shape of a study's ``wall:``
        block; :meth:`from_dict` reads it back to an equal wall."""
        return {"regions": [{"outline": [list(v) for v in r.outline],
                             "holes": [[list(v) for v in h] for h in r.holes]}
                            for r in self.regions],
                "start": {"position": list(self.start.position),
                          "attached": self.start.attached},
                "goal": {"position": list(self.goal.position), "radius": self.goal.radius},
                "margin": self.margin}

    @classmethod
    def from_dict(cls, data: dict) -> "Wall":
        """The wall of :meth:`to_dict`'s (or a ``wall:`` block's) plain data."""
        return cls(tuple(Region(tuple(map(tuple, r["outline"])),
                                tuple(tuple(map(tuple, h)) for h in r.get("holes", ())))
                         for r in data["regions"]),
                   Start(tuple(data["start"]["position"]), data["start"].get("attached", "A")),
                   Goal(tuple(data["goal"]["position"]), data["goal"]["radius"]),
                   data.get("margin", 0.0))


__all__ = ["BOUNDARY_TOL", "END_NAMES", "Goal", "Region", "Start", "Wall", "end_name",
           "simple_polygon"]
