"""Studies: YAML files in, netCDF datasets out (``monkeystudy run``).

* :mod:`.schema` - the strict, versioned study schema (pydantic v2).
* :mod:`.loader` - YAML 1.2 with line numbers; errors as ``file:line: key: message``.
* :mod:`.drivers` - the task functions of grid, refine and stability steps (numpy only).
* :mod:`.runner` - blocks, shards, resume, process pool or Dask, :func:`run_grid`.
* :mod:`.datasets` - the netCDF datasets of ``docs/datasets.md``, written atomically.
"""
from .loader import Issue, LoadedStudy, StudyError, load_study, parse_study
from .runner import RunFailed, RunInterrupted, RunSummary, plan_study, run_grid, run_study
from .schema import Study, json_schema

__all__ = [
    "Issue", "LoadedStudy", "RunFailed", "RunInterrupted", "RunSummary", "Study",
    "StudyError", "json_schema", "load_study", "parse_study", "plan_study", "run_grid",
    "run_study",
]
