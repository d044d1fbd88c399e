"""The package's lazy exports: the public names resolve as the eager imports did, and the light
entry points do not load numba."""
from __future__ import annotations

import subprocess
import sys

import pytest


def _fresh(code: str) -> str:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, timeout=120).stdout.strip()


def test_every_export_resolves_to_its_object():
    from monkeystudy import controllers, robot, simulate as simulate_fn  # noqa: F401
    import monkeystudy.simulation  # noqa: F401
    assert callable(monkeystudy.simulate) and monkeystudy.simulate.__name__ == "simulate"
    assert monkeystudy.simulation.simulate is monkeystudy.simulate is simulate_fn
    for name in monkeystudy.__all__:
        assert getattr(monkeystudy, name) is not None
        assert name in dir(monkeystudy)
    assert monkeystudy.Robot is robot.Robot and monkeystudy.OpenLoop is controllers.OpenLoop


def test_an_export_is_the_function_whichever_module_loaded_first():
    """No exported name is its submodule's (the submodule, set on the package when imported,
    would hide it): ``simulate`` lives in ``simulation``, ``floquet`` in ``multipliers``."""
    out = _fresh("import monkeystudy.study.runner, monkeystudy.study.steps\n"   # load both
                 "from monkeystudy import simulate\n"
                 "from monkeystudy.analysis import floquet\n"
                 "print(type(simulate).__name__, type(floquet).__name__)")
    assert out == "function function"


def test_an_export_named_as_its_submodule_is_refused():
    from monkeystudy._lazy import lazy_exports
    with pytest.raises(ValueError, match="simulate"):
        lazy_exports("monkeystudy", {}, {"simulate": ("simulate", "run_controller")})


def test_light_entry_points_do_not_import_numba():
    out = _fresh("import sys, monkeystudy, monkeystudy.cli, monkeystudy.__main__, "
                 "monkeystudy.service, monkeystudy.study, monkeystudy.study.provenance\n"
                 "print(sorted(m for m in ('numba', 'numpy', 'xarray', 'click') "
                 "if m in sys.modules))")
    assert out == "['click']"     # the cli module needs click; nothing heavy
