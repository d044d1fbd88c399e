"""Figures from study datasets (docs/datasets.md).

Every function takes xarray Datasets and returns a :class:`matplotlib.figure.Figure` built with
the object API in the package style (``monkeystudy.mplstyle``); :func:`report_study` draws all
figures a study folder's datasets support and writes them as PNG and PDF.
"""
from .maps import plot_error_map, plot_error_surface, plot_refine_convergence  # noqa: F401
from .cycles import (  # noqa: F401
    gait_point, plot_error_comparison, plot_error_per_cycle, plot_kinetic_energy,
    plot_pivot_height,
)
from .gait import plot_filmstrip, trajectory, write_animation  # noqa: F401
from .report import ReportError, report_study  # noqa: F401
