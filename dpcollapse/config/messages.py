"""A pydantic validation error as one line: the key path, the value given, what is allowed."""

from __future__ import annotations

from collections.abc import Sequence
from difflib import get_close_matches

import annotated_types as at
from pydantic import (
    BaseModel,
    ValidationError,
)

from dpcollapse.config.fields import _fmt
from dpcollapse.config.geometry import GEOMETRIES
from dpcollapse.config.material import MATERIALS
from dpcollapse.config.models import MODELS
from dpcollapse.config.root import Config
from dpcollapse.errors import ConfigError

_TYPE_TEXT = {
    "dp_number": "must be a number",
    "float_type": "must be a number",
    "float_parsing": "must be a number",
    "dp_integer": "must be an integer",
    "int_type": "must be an integer",
    "int_parsing": "must be an integer",
    "int_from_float": "must be an integer",
    "bool_type": "must be true or false",
    "bool_parsing": "must be true or false",
    "dp_path": "must be a non-empty path",
    "path_type": "must be a path",
    "model_type": "must be a mapping of keys",
    "model_attributes_type": "must be a mapping of keys",
    "finite_number": "must be a finite number",
}
_RANGE_TYPES = {"greater_than", "greater_than_equal", "less_than", "less_than_equal"}




#: Keys that were renamed: (section, old key) -> the new "section.key". A config that uses
#: the old name is refused with a message naming the new one.
RENAMED: dict[tuple[str, str], str] = {}

#: Sections whose value is one of several classes told apart by a tag (the tag appears in
#: pydantic's error locations after the section name).
_UNIONS: dict[str, dict[str, type[BaseModel]]] = {"geometry": GEOMETRIES, "material": MATERIALS,
                                                  "model": MODELS}
#: the tag key of each union section
_UNION_TAGS = {"geometry": "shape", "material": "rheology", "model": "name"}


def _walk(loc: Sequence[str]) -> tuple[list[str], type[BaseModel] | None]:
    """(the key path without union tags, the model class of the last section on it)."""
    model: type[BaseModel] | None = Config
    clean: list[str] = []
    parts = list(loc)
    while parts:
        part = parts.pop(0)
        clean.append(part)
        if model is None:
            continue
        variants = _UNIONS.get(part) if model is Config else None
        if variants is not None:
            model = variants.get(parts.pop(0)) if parts and parts[0] in variants else None
            continue
        field = model.model_fields.get(part)
        ann = getattr(field, "annotation", None)
        model = ann if isinstance(ann, type) and issubclass(ann, BaseModel) else None
    return clean, model


def _model_at(loc: Sequence[str]) -> type[BaseModel] | None:
    """The model class found by walking ``loc`` down from Config (None if not a section)."""
    return _walk(loc)[1]


def _allowed_range(model: type[BaseModel], key: str) -> str:
    """'must be in (0, 90] degrees' / 'must be > 0 (kg/m^3)' from the field's constraints."""
    field = model.model_fields[key]
    unit = (field.json_schema_extra or {}).get("unit", "")  # type: ignore[union-attr]
    lo = hi = None
    for m in field.metadata:
        if isinstance(m, (at.Gt, at.Ge)):
            lo = ("(" if isinstance(m, at.Gt) else "[", getattr(m, "gt", getattr(m, "ge", None)))
        if isinstance(m, (at.Lt, at.Le)):
            hi = (")" if isinstance(m, at.Lt) else "]", getattr(m, "lt", getattr(m, "le", None)))
    if lo and hi:
        unit = "degrees" if unit == "deg" else unit
        return f"must be in {lo[0]}{lo[1]:g}, {hi[1]:g}{hi[0]} {unit}".rstrip()
    op, bound = ((">" if lo[0] == "(" else ">=", lo[1]) if lo else
                 ("<" if hi[0] == ")" else "<=", hi[1]))  # type: ignore[index]
    unit = "degrees" if unit == "deg" else unit
    return f"must be {op} {bound:g}" + (f" ({unit})" if unit else "")


def _from_validation_error(exc: ValidationError) -> ConfigError:
    """The first pydantic error as one line: key path, value given, what is allowed."""
    err = exc.errors()[0]
    raw = [str(p) for p in err["loc"]]
    loc, _ = _walk(raw)
    key = ".".join(loc)
    kind = err["type"]
    if kind == "extra_forbidden":
        if tuple(loc) in RENAMED:
            return ConfigError(f"{key}: renamed; use {RENAMED[tuple(loc)]}")
        parent = _model_at(raw[:-1])
        names = list(parent.model_fields) if parent else []
        tag = _UNION_TAGS.get(loc[0])
        others = [name for name, cls in _UNIONS.get(loc[0], {}).items()
                  if len(loc) == 2 and loc[-1] in cls.model_fields and cls is not parent]
        if tag and others:
            return ConfigError(f"{key}: unknown key; it belongs to {loc[0]}.{tag} = "
                               f"{' or '.join(others)}")
        close = get_close_matches(loc[-1], names, n=1)
        hint = f"did you mean '{close[0]}'?" if close else "allowed: " + ", ".join(names)
        what = "unknown section" if len(loc) == 1 else "unknown key"
        return ConfigError(f"{key}: {what}; {hint}")
    if kind == "union_tag_invalid":
        ctx = err.get("ctx", {})
        return ConfigError(f"{key}.{_UNION_TAGS.get(key, 'shape')} = {_fmt(ctx.get('tag'))}: must be one of "
                           f"{ctx.get('expected_tags', '?')}")
    value = _fmt(err.get("input"))
    parent = _model_at(raw[:-1])
    if kind in _RANGE_TYPES and len(loc) == 2 and parent is not None:
        text = _allowed_range(parent, loc[-1])
    elif kind == "literal_error":
        text = "must be one of " + str(err.get("ctx", {}).get("expected", "?"))
    else:
        text = _TYPE_TEXT.get(kind, err["msg"])
    return ConfigError(f"{key} = {value}: {text}".replace("\n", " "))
