"""The atlas step draws no figure of its own: a route step that plans with it draws its gaits
(the route's ``atlas`` figure, :func:`monkeystudy.plotting.kinds.route.plot_gait_atlas`:
each gait's spectral radius and MFPT against its rise per step)."""
from __future__ import annotations

#: how the atlas step's figures are drawn: none
DRAWINGS: dict = {}
