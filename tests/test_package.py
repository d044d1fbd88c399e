"""The package's lazy exports: the public names resolve as the eager imports did, and the light
entry points do not load numba."""
from __future__ import annotations

import subprocess
import sys



def _fresh(code: str) -> str:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, timeout=120).stdout.strip()


def test_every_export_resolves_to_its_object():
    from monkeystudy import controllers, robot, simulate as simulate_fn  # noqa: F401
    import monkeystudy.simulate  # noqa: F401  (the submodule sets itself on the package)
    assert callable(monkeystudy.simulate) and monkeystudy.simulate.__name__ == "simulate"
    assert sys.modules["monkeystudy.simulate"].simulate is monkeystudy.simulate
    for name in monkeystudy.__all__:
        assert getattr(monkeystudy, name) is not None
        assert name in dir(monkeystudy)
    assert monkeystudy.Robot is robot.Robot and monkeystudy.OpenLoop is controllers.OpenLoop


def test_the_function_wins_over_its_submodule_in_a_fresh_process():
    out = _fresh("import monkeystudy.study.runner\n"       # imports monkeystudy.simulate first
                 "from monkeystudy import simulate\n"
                 "print(type(simulate).__name__)")
    assert out == "function"


def test_light_entry_points_do_not_import_numba():
    out = _fresh("import sys, monkeystudy, monkeystudy.cli, monkeystudy.__main__, "
                 "monkeystudy.service, monkeystudy.study, monkeystudy.study.provenance\n"
                 "print(sorted(m for m in ('numba', 'numpy', 'xarray', 'click') "
                 "if m in sys.modules))")
    assert out == "['click']"     # the cli module needs click; nothing heavy
