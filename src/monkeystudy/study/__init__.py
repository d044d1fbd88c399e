"""Studies: YAML files in, netCDF datasets out (``monkeystudy run``).

* :mod:`.schema` - the strict, versioned study schema (pydantic v2).
* :mod:`.loader` - YAML 1.2 with line numbers; errors as ``file:line: key: message``.
* :mod:`.drivers` - the task functions of grid, refine and stability steps (numpy only).
* :mod:`.runner` - blocks, shards, resume, process pool or Dask, :func:`run_grid`.
* :mod:`.datasets` - the netCDF datasets of ``docs/datasets.md``, written atomically.
* :mod:`.command` - ``monkeystudy run`` after loading (exit codes), shared with the service.

The names below are imported on first use (PEP 562), so that importing a light submodule
(:mod:`.provenance` for the service's client) does not load the kernels.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

_EXPORTS = {
    "loader": ("Issue", "LoadedStudy", "StudyError", "load_study", "parse_study"),
    "runner": ("RunFailed", "RunInterrupted", "RunSummary", "plan_study", "run_grid",
               "run_study"),
    "schema": ("Study", "json_schema"),
}
__getattr__, __dir__, __all__ = lazy_exports(__name__, globals(), _EXPORTS)

if TYPE_CHECKING:
    from .loader import Issue, LoadedStudy, StudyError, load_study, parse_study  # noqa: F401
    from .runner import (  # noqa: F401
        RunFailed, RunInterrupted, RunSummary, plan_study, run_grid, run_study,
    )
    from .schema import Study, json_schema  # noqa: F401
