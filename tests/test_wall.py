"""The wall as data: steel is the union of regions less their holes, a closed set; a catch
holds when the magnet's footprint lies on one region; degenerate polygons and a start off
steel are refused with what is wrong."""
from __future__ import annotations

import numpy as np
import pytest
from matplotlib.path import Path as MplPath

from monkeystudy.wall import Goal, Region, Start, Wall, simple_polygon

SQUARE = [(0.0, 0.0), (6.0, 0.0), (6.0, 3.0), (0.0, 3.0)]
WINDOW = [(2.0, 1.0), (3.0, 1.0), (3.0, 2.0), (2.0, 2.0)]
#: an L: the notch (3..6, 1.5..3) is not steel
ELL = [(0.0, 0.0), (6.0, 0.0), (6.0, 1.5), (3.0, 1.5), (3.0, 3.0), (0.0, 3.0)]


def wall(regions=None, start=(0.5, 0.5), margin=0.0) -> Wall:
    regions = regions or [Region(SQUARE, [WINDOW])]
    return Wall(regions, Start(start, "A"), Goal((5.5, 1.5), 0.2), margin)


def test_steel_is_the_outline_less_its_holes_boundaries_included():
    w = wall()
    pts = [(1.0, 1.0),        # steel
           (2.5, 1.5),        # in the window
           (7.0, 1.0),        # off the plate
           (6.0, 1.0),        # on the outline
           (0.0, 0.0),        # a corner
           (2.0, 1.5),        # on the window's edge
           (3.0, 2.0)]        # the window's corner
    np.testing.assert_array_equal(w.on_steel(pts),
                                  [True, False, False, True, True, True, True])
    assert w.on_steel((1.0, 1.0)).shape == (1,)


def test_a_concave_outline_leaves_its_notch_off_steel():
    w = wall([Region(ELL)])
    np.testing.assert_array_equal(w.on_steel([(4.5, 2.5), (1.5, 2.5), (4.5, 0.5)]),
                                  [False, True, True])


def test_on_steel_agrees_with_matplotlib_away_from_the_boundaries():
    """An independent even-odd test (matplotlib's) on random points not within 1 mm of an
    edge, for a concave plate with a hole."""
    hole = [(0.5, 0.5), (1.5, 0.5), (1.0, 1.2)]
    w = wall([Region(ELL, [hole])], start=(2.0, 0.3))
    rng = np.random.default_rng(7)
    pts = rng.uniform([-1.0, -1.0], [7.0, 4.0], size=(4000, 2))
    far = np.abs(wall([Region(ELL, [hole])], start=(2.0, 0.3)).clearance(pts)) > 1e-3
    outline, cut = MplPath(np.array(ELL)), MplPath(np.array(hole))
    want = outline.contains_points(pts) & ~cut.contains_points(pts)
    np.testing.assert_array_equal(w.on_steel(pts)[far], want[far])
    assert want[far].sum() > 1000 and (~want[far]).sum() > 1000


def test_clearance_is_the_distance_to_the_nearest_edge_or_hole():
    w = wall()
    np.testing.assert_allclose(w.clearance([(1.0, 0.4), (2.5, 0.7), (1.9, 1.5)]),
                               [0.4, 0.3, 0.1])
    assert w.clearance((2.5, 1.5))[0] == -np.inf


def test_a_catch_needs_its_footprint_inside_one_region():
    w = wall(margin=0.05)
    np.testing.assert_array_equal(
        w.can_catch([(0.06, 1.0), (0.04, 1.0), (1.94, 1.5), (1.96, 1.5), (2.5, 1.5)]),
        [True, False, True, False, False])
    # two plates that touch along x = 3: steel on both, but a footprint across the seam is
    # on neither
    left = Region([(0, 0), (3, 0), (3, 3), (0, 3)])
    right = Region([(3, 0), (6, 0), (6, 3), (3, 3)])
    w2 = wall([left, right], margin=0.05)
    assert w2.on_steel((3.0, 1.0))[0] and w2.on_steel((3.01, 1.0))[0]
    np.testing.assert_array_equal(w2.can_catch([(3.0, 1.0), (3.1, 1.0), (2.9, 1.0)]),
                                  [False, True, True])


def test_extent_is_the_box_of_every_region():
    w = wall([Region(SQUARE), Region([(7, -1), (9, -1), (8, 4)])])
    assert w.extent == (0.0, -1.0, 9.0, 4.0)


@pytest.mark.parametrize("vertices, message", [
    ([(0, 0), (1, 0)], "at least 3 vertices, got 2"),
    ([(0, 0), (1, 0), (1, 0), (0, 1)], "vertices 1 and 2 coincide"),
    ([(0, 0), (1, 1), (2, 2)], "edges"),                               # collinear: folds back
    ([(0, 0), (1, 0), (0, 1), (1, 1)], "crosses itself: edge 1"),      # a bow tie
    ([(0, 0), (2, 0), (2, 2), (1, 0), (0, 2)], "crosses itself"),      # touches its own edge
    ([(0, 0), (1, 0), (float("nan"), 1)], "finite"),
    ([(0, 0, 0), (1, 0, 0), (0, 1, 0)], "(x, y) pairs"),
])
def test_a_degenerate_polygon_is_refused_saying_why(vertices, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        simple_polygon(vertices)


def test_a_closed_ring_is_the_same_polygon():
    assert simple_polygon(SQUARE + [SQUARE[0]]) == simple_polygon(SQUARE)


def test_a_region_names_the_polygon_that_is_degenerate():
    with pytest.raises(ValueError, match=r"^holes\[1\]: the polygon crosses itself"):
        Region(SQUARE, [WINDOW, [(4, 1), (5, 1), (4, 2), (5, 2)]])
    with pytest.raises(ValueError, match=r"^outline: "):
        Region([(0, 0), (1, 0)])


def test_the_start_must_be_on_steel_and_the_goal_a_disc():
    with pytest.raises(ValueError, match=r"start \(2.5, 1.5\) is not on steel"):
        wall(start=(2.5, 1.5))
    wall(start=(2.0, 1.5))            # on the window's edge: the magnet holds there
    with pytest.raises(ValueError, match="radius must be > 0"):
        Goal((1.0, 1.0), 0.0)
    with pytest.raises(ValueError, match="margin must be >= 0"):
        wall(margin=-0.01)
    with pytest.raises(ValueError, match="an end is A or B"):
        Start((1.0, 1.0), "C")
    with pytest.raises(ValueError, match="at least one steel region"):
        Wall([], Start((0, 0)), Goal((1, 1), 0.1))


def test_the_goals_distance_is_zero_inside_its_disc():
    g = Goal((1.0, 1.0), 0.5)
    np.testing.assert_allclose(g.distance([(1.2, 1.0), (3.0, 1.0)]), [0.0, 1.5])
    # the rim is in the disc, whatever the last bit of the distance to the centre: three
    # steps of 0.1 m end at 0.30000000000000004
    g = Goal((0.0, 0.0), 0.3)
    assert 0.1 + 0.1 + 0.1 > 0.3
    np.testing.assert_array_equal(g.distance([(0.1 + 0.1 + 0.1, 0.0), (0.3 + 2e-9, 0.0)]) == 0,
                                  [True, False])


def test_with_start_moves_the_robot_and_checks_it():
    w = wall()
    moved = w.with_start((4.25, 2.5), "B")
    assert moved.start == Start((4.25, 2.5), "B") and moved.regions == w.regions
    with pytest.raises(ValueError, match="not on steel"):
        w.with_start((2.5, 1.5), "A")


def test_a_wall_goes_to_plain_data_and_back_unchanged():
    import json
    wall = Wall((Region(((0, 0), (6, 0), (6, 3), (0, 3)),
                        (((2.5, 0.6), (3.5, 0.6), (3.5, 2.4), (2.5, 2.4)),)),
                 Region(((7, 0), (9, 0), (9, 1), (7, 1)))),
                Start((0.5, 1.5), "B"), Goal((5.5, 1.5), 0.2), 0.05)
    again = Wall.from_dict(json.loads(json.dumps(wall.to_dict())))
    assert again == wall
    points = np.array([[3.0, 1.0], [2.0, 1.0], [8.0, 0.5], [6.5, 0.5]])
    assert again.can_catch(points).tolist() == wall.can_catch(points).tolist() == \
        [False, True, True, False]
