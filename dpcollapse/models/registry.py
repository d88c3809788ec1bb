"""The model of a config, found without editing this file:

- ``model_factory(cfg)``: what the time loop drives (``loop.ModelFactory``) — the class
  whose ``model_name`` is ``model.name``, in a module under ``dpcollapse/models/`` (a new
  model is a new package here); it provides ``from_config(cfg)``;
- ``model_class(method, nonlinear_solver)``: the 2D flow class whose ``method`` is
  ``numerics.method`` and whose ``nonlinear_solver`` is ``numerics.nonlinear_solver`` (None:
  the method's only one); it provides ``from_config(tagged, cfg, params)``.

A class is found by what it declares in its own body: a subclass that inherits ``method``
(the two-phase model's flow of the mixture, a ``RegularizedFlow``) is not a method's class."""

from __future__ import annotations

import functools
import importlib
import pkgutil

import dpcollapse.models as _package

_SKIP = {"base", "registry"}


def _package_modules() -> list[str]:
    """Every module of the package and its packages, but ``base`` and ``registry``."""
    return [info.name for info in pkgutil.walk_packages(_package.__path__, prefix=f"{_package.__name__}.")
            if not info.ispkg and info.name.rsplit(".", 1)[-1] not in _SKIP]


def _classes_by(attribute: str, modules, every: bool = False) -> list[tuple[str, type]]:
    """(value of ``attribute`` (a str), the class declaring it in its own body, with
    ``from_config``) for the classes of ``modules``."""
    found = []
    for name in modules:
        module = importlib.import_module(name)
        for obj in vars(module).values():
            key = vars(obj).get(attribute) if isinstance(obj, type) else None
            if (isinstance(key, str) and hasattr(obj, "from_config")
                    and obj.__module__ == module.__name__):
                found.append((key, obj))
    return found


@functools.cache
def flow_classes() -> dict[tuple[str, str | None], type]:
    """(numerics.method, numerics.nonlinear_solver or None) -> the 2D flow class, from every
    module of the package and its packages."""
    found = {}
    for method, cls in _classes_by("method", _package_modules(), every=True):
        found[(method, getattr(cls, "nonlinear_solver", None))] = cls
    return found


def model_classes() -> dict[str, type]:
    """numerics.method -> the method's class with the default nonlinear solver (Picard, or
    the method's only one)."""
    return {method: model_class(method) for method, _ in flow_classes()}


@functools.cache
def model_factories() -> dict[str, type]:
    """model.name -> factory class (``model_name`` and ``from_config``)."""
    return dict(_classes_by("model_name", _package_modules()))


def model_factory(cfg):
    """The factory of ``model.name`` built from the config."""
    return model_factories()[cfg.model.name].from_config(cfg)


def model_class(method: str, nonlinear_solver: str = "picard") -> type:
    """The 2D flow class of ``numerics.method`` solved by ``numerics.nonlinear_solver``."""
    classes = flow_classes()
    return classes.get((method, nonlinear_solver)) or classes[(method, None)]
