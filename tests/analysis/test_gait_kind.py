"""Which kind of horizontal gait a start gives: the swap on the first swing, or later."""
from __future__ import annotations

import pytest

from monkeystudy import evaluate_horizontal_gait
from monkeystudy.analysis.gait_kind import gait_kind_text, vertical_passes_before_swap


@pytest.mark.parametrize("start, passes", [
    ((0.902, 10.935), 0),      # the 2009 study's gait: the swap ends its first swing
    ((1.0, 12.0), 0),
    ((0.85, 10.85), 1),        # just below it the swap comes on the backswing, at ~1.27 s
    ((0.3, 11.3), 1),
    ((0.3, 10.0), -1),         # never swaps
])
def test_vertical_passes_before_swap(start, passes):
    assert vertical_passes_before_swap(*start, tick=0.001) == passes
    g = evaluate_horizontal_gait(*start, tick=0.001)
    if passes == 0:
        assert g.t_switch < 0.45
    elif passes > 0:
        assert g.t_switch > 1.2                # a whole swing later


def test_gait_kind_in_words():
    assert gait_kind_text(0) == "swaps on the first swing"
    assert "2 times" in gait_kind_text(2) and "not a first-swing gait" in gait_kind_text(2)
    assert gait_kind_text(-1) == "never swaps"
