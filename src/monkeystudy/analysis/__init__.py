"""Gait analysis on top of the simulation API, by topic.

* :mod:`.sections` - Poincare sections and return maps of any sequence gait (the horizontal
  gait's open-loop replay and state-based search controller by name).
* :mod:`.multipliers` - Floquet multipliers by finite differences, fixed points by Newton.
* :mod:`.variational` - the same Jacobians by variational equations with saltation matrices.
* :mod:`.shooting` - exact fixed points of a gait's cycle (Gauss-Newton; the grazing border).
* :mod:`.search` - Nelder-Mead refinement of a gait start (the study's fminsearch).
* :mod:`.continuation` - gait families in a robot or motor parameter, with bifurcations.
* :mod:`.replay` - many cycles: a gait's own controller or its open-loop replay, basins.
* :mod:`.stress` - numerical stress scenarios (energy drift, long runs, extreme parameters).
* :mod:`.precision` - run time against error for every integrator, and scipy's.
* :mod:`.route` - a route over a wall (:mod:`monkeystudy.wall`) from an atlas of gaits (A*).

Everything asks the one simulation path (:mod:`monkeystudy.simulation`) for what it needs. The
names below are importable from this package directly (loaded on first use); the modules of
the package import each other by their own names.
"""
from __future__ import annotations

from .._lazy import lazy_exports

_EXPORTS = {
    "sections": ("TIGHT", "CycleCatches", "bar_catch_rows", "check_cycle_frame", "check_mirror_links",
                 "cycle_catches", "cycle_full_map", "cycle_map_error", "cycle_return_map",
                 "cycle_section_state", "full_map_gait", "has_bar_catches",
                 "open_loop_return_map", "rows_on_start_end", "search_return_map",
                 "section_state"),
    "multipliers": ("FixedPointResult", "FloquetResult", "floquet", "jacobian_fd",
                "solve_fixed_point", "sorted_eigs"),
    "variational": ("sequence_variational_jacobian", "variational_jacobian"),
    "shooting": ("GrazingResult", "ShootResult", "free_end_after", "shoot_cycle",
                 "shoot_grazing", "shoot_horizontal"),
    "search": ("refine_gait",),
    "continuation": ("Branch", "CycleBranch", "continue_cycle", "continue_grazing",
                     "mirror_robot", "two_step_cycle", "with_parameter"),
    "replay": ("SequenceCycles", "motorless", "open_loop_gait", "sequence_basin",
               "sequence_cycles"),
    "precision": ("work_precision",),
    "route": ("AtlasGait", "NoRoute", "Route", "Transition", "plan_route", "replan",
              "route_graph", "step_failure"),
}
__getattr__, __dir__, __all__ = lazy_exports(__name__, globals(), _EXPORTS)
