"""Field types of the configuration schema: numbers, counts and paths as a user writes them,
a field with its SI unit (``_f``), the frozen section base, a value as the user would write it."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
)
from pydantic_core import PydanticCustomError


def _as_number(v: Any) -> Any:
    """Accept int/float and numeric strings (YAML 1.1 reads ``1e-3`` as a string); no bools."""
    if isinstance(v, bool) or not isinstance(v, (int, float, str)):
        raise PydanticCustomError("dp_number", "must be a number")
    if isinstance(v, str):
        try:
            return float(v)
        except ValueError:
            raise PydanticCustomError("dp_number", "must be a number") from None
    return v


def _as_integer(v: Any) -> Any:
    """Refuse bools, which pydantic would otherwise take as 0/1."""
    if isinstance(v, bool):
        raise PydanticCustomError("dp_integer", "must be an integer")
    return v


def _as_path(v: Any) -> Any:
    """Refuse empty strings and non-strings as paths."""
    if isinstance(v, Path):
        return v
    if not isinstance(v, str) or not v.strip():
        raise PydanticCustomError("dp_path", "must be a non-empty path")
    return v


Number = Annotated[float, BeforeValidator(_as_number)]
Count = Annotated[int, BeforeValidator(_as_integer)]
PathStr = Annotated[Path, BeforeValidator(_as_path)]


def _f(default: Any, unit: str, doc: str, **constraints: Any) -> Any:
    """A field with its SI unit kept in the schema (for error messages) and the description."""
    desc = f"{doc} [{unit}]" if unit else doc
    if "gt" in constraints or "ge" in constraints or "lt" in constraints or "le" in constraints:
        constraints.setdefault("allow_inf_nan", False)
    return Field(default, description=desc, json_schema_extra={"unit": unit}, **constraints)


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)




def _fmt(value: Any) -> str:
    """A value as the user would write it in YAML, one line, not too long."""
    if value is None:
        text = "null"
    elif isinstance(value, bool):
        text = "true" if value else "false"
    else:
        text = repr(value) if not isinstance(value, Path) else str(value)
    return text if len(text) <= 60 else text[:57] + "..."
