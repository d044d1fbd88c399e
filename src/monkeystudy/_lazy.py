"""Lazy package exports (PEP 562): a package names what it exports and from which submodule;
the submodule is imported on the first access of one of its names."""
from __future__ import annotations

import importlib
from typing import Any, Callable


def lazy_exports(package: str, namespace: dict,
                 exports: dict[str, tuple[str, ...]]) -> tuple[Callable, Callable, list[str]]:
    """``(__getattr__, __dir__, __all__)`` for ``package`` whose globals are ``namespace``;
    ``exports`` maps a submodule (relative name) to the names it provides.

    No name may be its submodule's: importing a submodule sets it as an attribute of its
    package, which would hide a name of the same spelling (``__getattr__`` only sees missing
    names), so such a name is refused at once.
    """
    module_of = {name: module for module, names in exports.items() for name in names}
    shadowed = sorted(name for name, module in module_of.items() if name == module)
    if shadowed:
        raise ValueError(f"{package}: exported names equal to their submodule's would be "
                         f"hidden by it: {', '.join(shadowed)}")
    names = sorted(module_of)

    def __getattr__(name: str) -> Any:
        if name not in module_of:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f".{module_of[name]}", package), name)
        namespace[name] = value   # later lookups do not come here
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(names))

    return __getattr__, __dir__, names
