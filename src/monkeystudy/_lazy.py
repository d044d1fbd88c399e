"""Lazy package exports (PEP 562): a package names what it exports and from which submodule;
the submodule is imported on the first access of one of its names."""
from __future__ import annotations

import importlib
import sys
import types
from typing import Any, Callable


def lazy_exports(package: str, namespace: dict,
                 exports: dict[str, tuple[str, ...]]) -> tuple[Callable, Callable, list[str]]:
    """``(__getattr__, __dir__, __all__)`` for ``package`` whose globals are ``namespace``;
    ``exports`` maps a submodule (relative name) to the names it provides.

    A name equal to its submodule's (``monkeystudy.simulate``, the function in
    ``simulate.py``) would be shadowed by the submodule itself: importing a submodule sets it
    as an attribute of its package, and ``__getattr__`` only sees missing names. Those names
    become properties of the package's module class instead, which win over both (as the eager
    ``from .simulate import simulate`` did)."""
    module_of = {name: module for module, names in exports.items() for name in names}
    names = sorted(module_of)

    def load(name: str) -> Any:
        return getattr(importlib.import_module(f".{module_of[name]}", package), name)

    def __getattr__(name: str) -> Any:
        if name not in module_of:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = load(name)
        namespace[name] = value   # later lookups do not come here
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(names))

    shadowed = [name for name, module in module_of.items() if name == module]
    if shadowed:
        def exported(name: str) -> property:
            # the setter drops the import system's "package.simulate = <submodule>"
            return property(lambda self: load(name), lambda self, value: None,
                            doc=f"{package}.{name}")
        module = sys.modules[package]
        module.__class__ = type(f"{package}.<package>", (types.ModuleType,),
                                {name: exported(name) for name in shadowed})
    return __getattr__, __dir__, names
