"""Figures from study datasets (docs/datasets.md).

Every function takes xarray Datasets and returns a :class:`matplotlib.figure.Figure` built with
the object API in the package style (``monkeystudy.mplstyle``); :func:`report_study` draws all
figures a study folder's datasets support and writes them as PNG and PDF.

Each step kind's figures are drawn by its module ``monkeystudy.plotting.kinds.<kind>``
(its ``DRAWINGS``, with each figure's title and caption); the shared figures (maps, per-cycle
plots, the filmstrip and animation) are in :mod:`.maps`, :mod:`.cycles` and :mod:`.gait`. The
figures of every kind, by file name, are the table of :mod:`.report`. Every ``plot_*`` function
of a kind's module is exported here (``tests/plotting/test_plotting_report.py`` checks it).
"""
from .maps import (  # noqa: F401
    plot_error_map, plot_error_surface, plot_refine_convergence, plot_swap_time_map,
)
from .cycles import (  # noqa: F401
    gait_point, plot_error_comparison, plot_error_per_cycle, plot_kinetic_energy,
    plot_pivot_height,
)
from .gait import plot_filmstrip, trajectory, write_animation  # noqa: F401
from .kinds.basin import plot_basin  # noqa: F401
from .kinds.continuation import plot_continuation  # noqa: F401
from .kinds.design import (  # noqa: F401
    plot_design_map, plot_design_multipliers, plot_design_replay, plot_design_screen,
)
from .kinds.hardware_replay import (  # noqa: F401
    plot_held_out, plot_parameters, plot_residuals, plot_swings,
)
from .kinds.floquet import plot_floquet_multipliers  # noqa: F401
from .kinds.route import (  # noqa: F401
    plot_gait_atlas, plot_route_outcomes, plot_route_walks, plot_route_wall,
)
from .kinds.shoot import plot_shoot_convergence  # noqa: F401
from .kinds.stress import plot_stress  # noqa: F401
from .kinds.survival import (  # noqa: F401
    plot_failure_modes, plot_height_drift, plot_mfpt, plot_mfpt_comparison, plot_survival,
)
from .kinds.tick_sweep import plot_tick_sweep  # noqa: F401
from .kinds.work_precision import plot_work_precision  # noqa: F401
from .report import DRAWINGS, ReportError, report_study  # noqa: F401
