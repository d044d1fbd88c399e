"""Studies: YAML files in, netCDF datasets out (``monkeystudy run``).

* :mod:`.models`, :mod:`.schema` - the strict, versioned study schema (pydantic v2).
* :mod:`.loader` - YAML 1.2 with line numbers; errors as ``file:line: key: message``.
* :mod:`.steps` - the step kinds, one module each (model, checks, tasks, dataset, figures),
  in a registry the layers above iterate over.
* :mod:`.spec` - the study resolved into the plain values every task receives.
* :mod:`.plan` - which steps and blocks a run has to do (resume, ``--dry-run``).
* :mod:`.runner` - the run loop over the pool (:mod:`.pool`: processes or Dask), shards
  (:mod:`.blocks`), :func:`run_grid`.
* :mod:`.datasets` - the netCDF layer of ``docs/datasets.md``: atomic files, labelled
  variables.
* :mod:`.command` - ``monkeystudy run`` after loading (exit codes), shared with the service.

The names below are imported on first use (PEP 562), so that importing a light submodule
(:mod:`.provenance` for the service's client) does not load the kernels.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

_EXPORTS = {
    "loader": ("Issue", "LoadedStudy", "StudyError", "load_study", "parse_study"),
    "errors": ("RunFailed", "RunInterrupted"),
    "plan": ("plan_study",),
    "runner": ("RunSummary", "run_grid", "run_study"),
    "schema": ("Study", "json_schema"),
}
__getattr__, __dir__, __all__ = lazy_exports(__name__, globals(), _EXPORTS)

if TYPE_CHECKING:
    from .loader import Issue, LoadedStudy, StudyError, load_study, parse_study  # noqa: F401
    from .errors import RunFailed, RunInterrupted  # noqa: F401
    from .plan import plan_study  # noqa: F401
    from .runner import RunSummary, run_grid, run_study  # noqa: F401
    from .schema import Study, json_schema  # noqa: F401
