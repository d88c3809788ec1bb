"""A method that brings its time scheme (issue 48): the time keys a config file wrote for
its own method yield to a method chosen on the command line.

``time.scheme: bdf2`` and the error-controlled step ``time.tolerance`` (which needs BDF2's
error estimate) exist for the 2D regularized model only (``supports_bdf2``). A config file
written for it (``configs/rigid.yaml``: bdf2, tolerance 3e-4) would refuse ``--set
numerics.method=augmented_lagrangian`` until both keys were changed by hand. The rule: when
``--set`` changes the model or the method (``model.name``, ``numerics.method``) to one
without BDF2, each of ``time.scheme`` / ``time.tolerance`` that the command line did *not*
set and that the new method cannot use becomes the first-order scheme with fixed steps of
``time.dt`` (``bdf1``, ``null``). A time key set by ``--set``, or a file that names the
method and bdf2 together, is the user's explicit choice and is refused as before (one line).
The choice is said in one log line (``files.load_config``) and in run.json
(``time_scheme_chosen``).
"""

from __future__ import annotations

from typing import Any

from dpcollapse.config.fields import _fmt
from dpcollapse.errors import ConfigError

#: the keys that choose the model or the 2D method
METHOD_KEYS = (("model", "name"), ("numerics", "method"))


def supports_bdf2(model_name: Any, method: Any) -> bool:
    """Whether ``time.scheme: bdf2`` (and so ``time.tolerance``) is available: the 2D
    regularized model (Picard or Newton) only."""
    return model_name == "stokes" and method == "regularized"


def choose_time_scheme(data: dict, overridden: set[tuple[str, str]]) -> tuple[dict, dict | None]:
    """(``data`` with the time keys the method brings, the choice for run.json or None when
    nothing changed). ``overridden``: the (section, key) pairs set by ``--set``."""
    changed = [key for key in METHOD_KEYS if key in overridden]
    model = data.get("model") if isinstance(data.get("model"), dict) else {}
    numerics = data.get("numerics") if isinstance(data.get("numerics"), dict) else {}
    time = data.get("time") if isinstance(data.get("time"), dict) else None
    if not changed or time is None:
        return data, None
    if supports_bdf2(model.get("name", "stokes"), numerics.get("method", "regularized")):
        return data, None
    tolerance = _number(time.get("tolerance"))
    if ("time", "tolerance") in overridden and tolerance is not None:
        # set explicitly for a method without an error estimate: the refusal names the method
        # (time.tolerance's own check would advise bdf2, which this method refuses)
        raise ConfigError(f"time.tolerance = {_fmt(tolerance)}: the error-controlled step needs "
                          f"BDF2's error estimate, which {_method(data, changed)} has not; must "
                          "be null with it")
    new = {"scheme": "bdf1", "tolerance": None}
    replaced = {f"time.{key}": time[key] for key, value in new.items()
                if key in time and time[key] != value and ("time", key) not in overridden}
    if not replaced:
        return data, None
    data = {**data, "time": {**time, **{k.split(".")[1]: new[k.split(".")[1]] for k in replaced}}}
    what = _method(data, changed)
    chosen = {"scheme": data["time"].get("scheme", "bdf1"),
              "tolerance": data["time"].get("tolerance"),
              "replaced": replaced,
              "reason": f"{what} (set with --set) has no BDF2 and no error estimate; the "
                        "config file's time keys were written for its own method"}
    return data, chosen


def _number(value: Any) -> float | None:
    """``value`` as a number (YAML reads 1e-3 as a string), None if it is none (null or not
    a number: the schema's own check names it)."""
    try:
        return None if value is None or isinstance(value, bool) else float(value)
    except (TypeError, ValueError):
        return None


def _method(data: dict, changed: list[tuple[str, str]]) -> str:
    """The method keys set with --set, as the user wrote them ("numerics.method = 'x'")."""
    return ", ".join(f"{s}.{k} = {_fmt(data[s][k])}" for s, k in changed)


def describe_choice(chosen: dict, dt: float) -> str:
    """The log line of a choice (``choose_time_scheme``)."""
    swaps = ", ".join(f"{key} {_fmt(old)} -> {_fmt(chosen[key.split('.')[1]])}"
                      for key, old in chosen["replaced"].items())
    step = (f"fixed steps of time.dt = {dt:g} s" if chosen["tolerance"] is None
            else f"time.tolerance {_fmt(chosen['tolerance'])}")
    return (f"time scheme chosen: {swaps} ({step}): {chosen['reason']}; --set time.scheme "
            "and time.tolerance to choose otherwise")
