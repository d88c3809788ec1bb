"""The model of a config: the class in a module under ``dpcollapse/models/`` whose
``method`` is ``numerics.method`` (a new model is a new package here, found without
editing this file). A model class provides ``from_config(tagged, cfg, params)``."""

from __future__ import annotations

import functools
import importlib
import pkgutil

import dpcollapse.models as _package

_SKIP = {"base", "registry"}


@functools.cache
def model_classes() -> dict[str, type]:
    """numerics.method -> model class, from every module of the package and its packages."""
    found = {}
    for info in pkgutil.walk_packages(_package.__path__, prefix=f"{_package.__name__}."):
        if info.ispkg or info.name.rsplit(".", 1)[-1] in _SKIP:
            continue
        module = importlib.import_module(info.name)
        for obj in vars(module).values():
            method = getattr(obj, "method", None)
            if (isinstance(obj, type) and isinstance(method, str) and hasattr(obj, "from_config")
                    and obj.__module__ == module.__name__):
                found[method] = obj
    return found


def model_class(method: str) -> type:
    """The model class of ``numerics.method``."""
    return model_classes()[method]
