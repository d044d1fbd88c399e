"""Shared pytest configuration.

``tests/`` is put on ``sys.path`` so that test modules can import the independent reference
model as ``reference`` (``tests/reference/``), whatever pytest's import mode.
"""
import pathlib
import sys

_TESTS = pathlib.Path(__file__).resolve().parent
if str(_TESTS) not in sys.path:
    sys.path.insert(0, str(_TESTS))
