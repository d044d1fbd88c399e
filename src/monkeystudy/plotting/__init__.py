"""Figures from study datasets (docs/datasets.md).

Every function takes xarray Datasets and returns a :class:`matplotlib.figure.Figure` built with
the object API in the package style (``monkeystudy.mplstyle``); :func:`report_study` draws all
figures a study folder's datasets support and writes them as PNG and PDF.

Each step kind's figures are drawn by its module ``monkeystudy.plotting.kinds.<kind>``
(its ``DRAWINGS``); the shared figures (maps, per-cycle plots, the filmstrip and animation)
are in :mod:`.maps`, :mod:`.cycles` and :mod:`.gait`. Figures of the analysis steps (file
``figures/<step>_<suffix>``): shoot ``_newton``
(:func:`plot_shoot_convergence`), floquet ``_multipliers`` (:func:`plot_floquet_multipliers`),
tick_sweep ``_error_growth`` (:func:`plot_tick_sweep`), basin ``_cycles_map``
(:func:`plot_basin`), continuation ``_branch`` (:func:`plot_continuation`), work_precision
``_work_precision`` (:func:`plot_work_precision`); of the stress step: ``_stress``
(:func:`plot_stress`).
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
from .kinds.floquet import plot_floquet_multipliers  # noqa: F401
from .kinds.shoot import plot_shoot_convergence  # noqa: F401
from .kinds.stress import plot_stress  # noqa: F401
from .kinds.tick_sweep import plot_tick_sweep  # noqa: F401
from .kinds.work_precision import plot_work_precision  # noqa: F401
from .report import DRAWINGS, ReportError, report_study  # noqa: F401
