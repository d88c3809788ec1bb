"""Run-directory names of sweep cases: readable (``bed_angle=19__rheology=mu_i``),
filesystem-safe (letters, digits and ``._+=-``), collision-free (a short hash is appended
where two names would coincide, also ignoring case, or a name is too long)."""

from __future__ import annotations

import hashlib
import re
from collections.abc import Mapping, Sequence
from typing import Any

import yaml

#: Longest name kept as is; longer ones are cut and get a hash.
MAX_LENGTH = 96
_UNSAFE = re.compile(r"[^A-Za-z0-9._+-]")
_SAFE_NAME = re.compile(rf"^[A-Za-z0-9][A-Za-z0-9._+=-]{{0,{MAX_LENGTH - 1}}}$")


def yaml_value(value: Any) -> str:
    """``value`` as YAML text that reads back as the same value (for ``--set key=TEXT``)."""
    text = yaml.safe_dump(value, default_flow_style=True, width=10**6).strip()
    if text.endswith("\n..."):
        text = text[: -len("\n...")]
    elif text.endswith("..."):
        text = text[:-3].strip()
    return text


def is_safe_name(name: str) -> bool:
    """True for a name usable as a directory on every common filesystem."""
    return bool(_SAFE_NAME.match(name)) and name not in (".", "..")


def short_keys(keys: Sequence[str]) -> dict[str, str]:
    """``section.key`` -> ``key``, unless two sections share a key: then the full name."""
    last = [k.rpartition(".")[2] for k in keys]
    return {k: (s if last.count(s) == 1 else k) for k, s in zip(keys, last)}


def _digest(params: Mapping[str, Any]) -> str:
    text = "\n".join(f"{k}={yaml_value(v)}" for k, v in params.items())
    return hashlib.sha256(text.encode()).hexdigest()[:8]


#: A key of this name in a parameter set is a name given in the sweep file: shown bare.
NAME = "name"


def base_name(params: Mapping[str, Any], short: Mapping[str, str]) -> str:
    """``key=value`` items joined by ``__``, unsafe characters as ``_``; "base" if empty."""
    parts = [str(v) if k == NAME else f"{short[k]}={_UNSAFE.sub('_', yaml_value(v))}"
             for k, v in params.items()]
    return "__".join(parts) or "base"


def case_names(param_sets: Sequence[Mapping[str, Any]]) -> list[str]:
    """One unique, safe name per parameter set (a ``name`` item is used as it is)."""
    keys: list[str] = []
    for params in param_sets:
        keys += [k for k in params if k not in keys and k != NAME]
    short = short_keys(keys)
    names = [base_name(p, short) for p in param_sets]
    folded = [n.lower() for n in names]
    out = []
    for name, params in zip(names, param_sets):
        if folded.count(name.lower()) > 1 or len(name) > MAX_LENGTH - 10:
            name = f"{name[: MAX_LENGTH - 10]}-h{_digest(params)}"
        out.append(name)
    return out
