"""Reading, overriding, validating and writing configurations (YAML, bounded input)."""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml
from pydantic import (
    ValidationError,
)

from dpcollapse.config.fields import _fmt
from dpcollapse.config.material import MATERIALS, _rheology_of
from dpcollapse.config.messages import _UNION_TAGS, _UNIONS, _from_validation_error
from dpcollapse.config.root import Config
from dpcollapse.config.time_scheme import choose_time_scheme, describe_choice
from dpcollapse.errors import ConfigError


def validate_config(data: Any, base_dir: str | Path | None = None) -> Config:
    """Validate a nested mapping into a Config; ``base_dir`` resolves a relative mesh_file.

    Empty sections (``geometry:`` with nothing under it) count as all defaults.
    """
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"config top level = {_fmt(data)}: must be a mapping of sections")
    data = {k: ({} if v is None else v) for k, v in data.items()}
    context = {"base_dir": Path(base_dir) if base_dir is not None else Path.cwd()}
    try:
        return Config.model_validate(data, context=context)
    except ValidationError as exc:
        raise _from_validation_error(exc) from None


#: Union sections whose kind an override may switch (``--set material.rheology=mu_i`` on a
#: Drucker–Prager file, a sweep over the law): -> the function that reads the current kind.
_SWITCHABLE = {"material": _rheology_of}


def _switch_kind(data: dict[str, Any], section: str, kind: Any, overridden: set) -> None:
    """An override gives ``section`` another kind: keep the keys the new kind has, drop the
    old kind's own (e.g. material.viscosity of drucker_prager for mu_i; logged, not silent).
    A key set by an override is kept: the new kind then refuses it with one line."""
    new = _UNIONS[section].get(kind) if isinstance(kind, str) else None
    if new is None or kind == _SWITCHABLE[section](data[section]):
        return
    dropped = [k for k in data[section]
               if k not in new.model_fields and (section, k) not in overridden]
    for k in dropped:
        del data[section][k]
    if dropped:
        logging.getLogger("dpcollapse").info(
            "%s.%s = %s: %s not used by it, dropped", section, _UNION_TAGS[section], kind,
            ", ".join(f"{section}.{k}" for k in dropped))


def _apply_overrides(data: dict[str, Any], overrides: Sequence[str]) -> dict[str, Any]:
    """Set ``section.key=value`` items (value parsed as YAML) into a copy of ``data``; an
    item that switches a section's kind (``_SWITCHABLE``) drops the old kind's own keys."""
    data = {k: (dict(v) if isinstance(v, dict) else v) for k, v in data.items()}
    overridden: set[tuple[str, str]] = set()
    for item in overrides:
        path, sep, raw = item.partition("=")
        parts = path.strip().split(".")
        if not sep or len(parts) != 2 or not all(p.isidentifier() for p in parts):
            raise ConfigError(f"--set {item!r}: must be of the form section.key=value")
        try:
            value = yaml.safe_load(raw)
        except yaml.YAMLError:
            raise ConfigError(f"--set {item!r}: value is not valid YAML") from None
        section, key = parts
        if data.get(section) is None:
            data[section] = {}
        if not isinstance(data[section], dict):
            raise ConfigError(f"{section} = {_fmt(data[section])}: must be a mapping of keys")
        if section in _SWITCHABLE and key == _UNION_TAGS[section]:
            _switch_kind(data, section, value, overridden)
        data[section][key] = value
        overridden.add((section, key))
    return data


#: Largest config or sweep file read [bytes]: a config is a few kB; a larger file (a
#: 50 MB list) would take minutes to parse.
MAX_INPUT_BYTES = 1_000_000


def read_input_text(path: Path, what: str = "config file") -> str:
    """The text of a config or sweep file: a regular file (not a FIFO or a device such as
    /dev/zero, which would block or never end) of at most MAX_INPUT_BYTES, checked before
    reading; every failure is one line (ConfigError)."""
    import stat

    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise ConfigError(f"{what} {path}: not found") from None
    except OSError as exc:
        raise ConfigError(f"{what} {path}: cannot be read ({exc.strerror})") from None
    if stat.S_ISDIR(info.st_mode):
        raise ConfigError(f"{what} {path}: is a directory, not a file")
    if not stat.S_ISREG(info.st_mode):
        raise ConfigError(f"{what} {path}: not a regular file (a pipe or a device); "
                          "give a YAML file")
    if info.st_size > MAX_INPUT_BYTES:
        raise ConfigError(f"{what} {path}: {info.st_size} bytes, more than the "
                          f"{MAX_INPUT_BYTES} a {what.split()[0]} may have")
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_INPUT_BYTES + 1)   # the file may have grown since the stat
    except OSError as exc:
        raise ConfigError(f"{what} {path}: cannot be read ({exc.strerror})") from None
    if len(data) > MAX_INPUT_BYTES:
        raise ConfigError(f"{what} {path}: more than {MAX_INPUT_BYTES} bytes")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise ConfigError(f"{what} {path}: cannot be read (not UTF-8 text)") from None


def parse_input_yaml(text: str, path: Path, what: str = "config file") -> Any:
    """Parse a config or sweep file's YAML: a key twice in one mapping refused, every
    failure one line (ConfigError)."""
    try:
        return yaml.load(text, Loader=_UniqueKeyLoader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or "invalid YAML"
        raise ConfigError(f"{what} {path}: YAML syntax error{where}: {problem}") from None
    except RecursionError:
        raise ConfigError(f"{what} {path}: nested too deeply") from None


def _read_yaml(path: Path) -> Any:
    """The parsed YAML document at ``path``; every failure is one line."""
    text = read_input_text(path)
    try:
        return parse_input_yaml(text, path)
    except ConfigError as exc:
        if str(exc).endswith("nested too deeply"):
            raise ConfigError(f"{exc} (a config has two levels: section and key)") from None
        raise


class _UniqueKeyLoader(yaml.SafeLoader):
    """SafeLoader that refuses a key given twice in one mapping (PyYAML keeps the last)."""

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {key!r} appears twice in one mapping", key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


def load_config(path: str | Path | None, overrides: Sequence[str] = ()) -> Config:
    """Read a YAML config (None: all defaults), apply ``--set section.key=value`` overrides,
    validate, and return the frozen Config. Raises ConfigError (one line) on any problem."""
    if path is None:
        data, base = None, Path.cwd()
    else:
        path = Path(path)
        data, base = _read_yaml(path), path.parent
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"config file {path}: top level must be a mapping of sections, "
                          f"got {type(data).__name__}")
    data = _apply_overrides(data, overrides)
    # a method chosen on the command line brings its time scheme (config.time_scheme)
    overridden = {tuple(item.partition("=")[0].strip().split(".")) for item in overrides}
    data, chosen = choose_time_scheme(data, overridden)
    cfg = validate_config(data, base_dir=base)
    if chosen is not None:
        cfg.set_time_scheme_chosen(chosen)
        logging.getLogger("dpcollapse").info(describe_choice(chosen, cfg.time.dt))
    return cfg


def with_overrides(cfg: Config, overrides: Sequence[str]) -> Config:
    """A new Config: ``cfg`` with ``section.key=value`` overrides applied and re-validated."""
    return validate_config(_apply_overrides(config_to_dict(cfg), overrides))


#: keys whose default has changed since they were added: the value a program older than the
#: key ran with (a saved config without the key ran with it, not with today's default; the
#: ``model`` keys are the two-phase model's, the ``numerics`` ones any model's)
LEGACY_DEFAULTS = {
    ("model", "yield_weighting"): "volume",       # default grains since 2026-12-04
    ("model", "grain_pressure"): "total",         # default effective since 2026-12-05
    ("model", "cut_cell_pressure"): "pointwise",  # default centroid since 2026-12-05
    ("model", "inertia"): "velocity",             # default energy 2026-12-05 (noon), mean since
    #                                               2026-12-07: a config saved since 12-05 has the key
    ("model", "compression_direction"): "facet",  # default normal since 2026-12-05 (evening)
    ("model", "open_top"): "traction_free",       # default hydrostatic since 2026-12-07
    ("numerics", "remesh_film_trim_face"): "vertical",  # default repose since 2026-12-07
}


def from_saved(data: Any) -> Any:
    """A config this program wrote (config.yaml, run.json's "config"), perhaps by a version
    of before 2026-12-04, whose single material class wrote every law's keys: those of
    another law than its ``rheology`` are dropped (they had no effect). A two-phase config
    without a key of ``LEGACY_DEFAULTS`` gets the value its program ran with, as does any
    config without one of its ``numerics`` keys. Other data as is."""
    if not isinstance(data, dict):
        return data
    numerics = data.get("numerics")
    if isinstance(numerics, dict):
        missing = {key: value for (section, key), value in LEGACY_DEFAULTS.items()
                   if section == "numerics" and key not in numerics}
        if missing:
            data = {**data, "numerics": {**numerics, **missing}}
    model = data.get("model")
    if isinstance(model, dict) and model.get("name") == "two_phase":
        missing = {key: value for (section, key), value in LEGACY_DEFAULTS.items()
                   if section == "model" and key not in model}
        if missing:
            data = {**data, "model": {**model, **missing}}
    material = data.get("material")
    law = MATERIALS.get(_rheology_of(material)) if isinstance(material, dict) else None
    if law is None:
        return data
    return {**data, "material": {k: v for k, v in material.items() if k in law.model_fields}}


def config_to_dict(cfg: Config) -> dict[str, Any]:
    """Plain nested dict of the config (YAML- and JSON-able; paths as strings)."""
    return cfg.model_dump(mode="json")


def save_config(cfg: Config, path: str | Path) -> Path:
    """Write the resolved config as YAML (parents created); returns the path written."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = yaml.safe_dump(config_to_dict(cfg), sort_keys=False, default_flow_style=False)
    path.write_text("# dpcollapse resolved configuration\n" + text, encoding="utf-8")
    return path
