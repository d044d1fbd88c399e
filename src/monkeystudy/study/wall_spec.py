"""A study's ``wall:`` block: the steel regions, the start, the goal and the magnet's footprint
(:class:`monkeystudy.wall.Wall`; docs/route.md). Each polygon is checked where it is written
(``wall.regions[0].holes[1]: the polygon crosses itself: ...``); whether the start is on steel
needs every region, so :func:`wall_problems` checks it across the block."""
from __future__ import annotations

from typing import Annotated, Literal

from pydantic import AfterValidator, Field

from ..wall import Goal, Region, Start, Wall, simple_polygon
from .models import StrictModel

Vertex = Annotated[list[float], Field(min_length=2, max_length=2,
                                      description="(x along the wall, y up) [m]")]


def _polygon(vertices: list[list[float]]) -> list[list[float]]:
    simple_polygon(vertices)      # a ValueError names what is degenerate
    return vertices


Polygon = Annotated[list[Vertex], Field(min_length=3, description="a simple polygon's vertices "
                                                                  "(x, y) [m], in either "
                                                                  "sense"),
                    AfterValidator(_polygon)]


class RegionSpec(StrictModel):
    """One steel plate: its outline less its holes."""

    outline: Polygon = Field(description="the plate's outline: vertices (x, y) [m]")
    holes: list[Polygon] = Field(default_factory=list, description="polygons removed from the "
                                 "plate (a window, a hole in the sheet): vertices (x, y) [m]")

    def to_region(self) -> Region:
        return Region(tuple(map(tuple, self.outline)),
                      tuple(tuple(map(tuple, h)) for h in self.holes))


class StartSpec(StrictModel):
    """Where the robot hangs at the start."""

    position: Vertex = Field(description="the attached magnet (x, y) [m], on steel")
    attached: Literal["A", "B"] = Field("A", description="the end attached there")


class GoalSpec(StrictModel):
    """Where the robot is to go."""

    position: Vertex = Field(description="the goal's centre (x, y) [m]")
    radius: float = Field(gt=0, description="a catch within this distance of the centre "
                                            "arrives [m]")


class WallSpec(StrictModel):
    """The wall the robot climbs (docs/route.md): steel regions with holes in the plane of
    the wall (x along it, y up, the simulator's world frame), the start and the goal."""

    regions: list[RegionSpec] = Field(min_length=1, description="the steel plates")
    start: StartSpec = Field(description="the attached magnet at the start")
    goal: GoalSpec = Field(description="the goal: a point and a radius")
    margin: float = Field(0.0, ge=0, description="the magnet's footprint radius [m]: a catch "
                                                 "holds only at least this far inside one "
                                                 "region")

    def to_wall(self) -> Wall:
        """The :class:`~monkeystudy.wall.Wall` of this block (its start checked on steel)."""
        return Wall(tuple(r.to_region() for r in self.regions),
                    Start(tuple(self.start.position), self.start.attached),
                    Goal(tuple(self.goal.position), self.goal.radius), self.margin)


def wall_problems(wall: WallSpec | None) -> list[tuple[tuple, str]]:
    """The problems of a valid ``wall:`` block that need all of it, as ``(path, message)``:
    a start off steel."""
    if wall is None:
        return []
    try:
        wall.to_wall()
    except ValueError as exc:
        return [(("wall", "start", "position"), str(exc))]
    return []


__all__ = ["GoalSpec", "RegionSpec", "StartSpec", "WallSpec", "wall_problems"]
