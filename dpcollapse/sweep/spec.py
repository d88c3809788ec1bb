"""The sweep file: a base config, the parameters to vary, what to collect; its cases.

A sweep file (YAML; paths relative to its folder)::

    base: ../slope19_mui.yaml          # the config every case starts from
    set: {geometry.mesh_size: 0.01}    # fixed overrides of every case
    grid:                              # product of these lists
      geometry.bed_angle: [10, 19, 22]
      material.rheology: [mu_i, drucker_prager]
    zip:                               # lists of one length, varied together
      time.dt: [1.0e-3, 5.0e-4]
      geometry.mesh_size: [0.02, 0.01]
    cases:                             # explicit override sets (optional ``name``)
      - {boundary.channel_width: 0.1}
      - {boundary.channel_width: null, name: no_walls}
    collect: [area_drift, remeshes]    # run.json summary values added to sweep.csv
    ranks_per_case: 1                  # MPI ranks of each case (launcher below when > 1)
    launcher: mpirun -n {ranks}
    slurm: {time: "01:00:00", partition: null, account: null, ...}

Each of ``grid``, ``zip``, ``cases`` that is given is one factor; the cases are their
product, in file order (grid axes vary slowest to fastest, then zip rows, then cases).
Keys use the ``section.key`` names of ``dpcollapse run --set``; every case's config is
loaded with :func:`dpcollapse.config.load_config` before anything runs, and a bad value is
one line naming the case and the key (:class:`~dpcollapse.errors.ConfigError`, exit 2).
"""

from __future__ import annotations

import hashlib
import itertools
import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from dpcollapse.config import config_to_dict, load_config, parse_input_yaml, read_input_text
from dpcollapse.errors import ConfigError
from dpcollapse.sweep.naming import case_names, is_safe_name, yaml_value

__all__ = ["SUMMARY_KEYS", "Case", "SlurmOptions", "Sweep", "SweepFile", "load_sweep"]

_KEY = re.compile(r"^[A-Za-z_]\w*\.[A-Za-z_]\w*$")

#: Values of run.json's summary that ``collect`` may name (besides the default columns).
SUMMARY_KEYS = (
    "t", "steps", "remeshes", "front", "max_height", "area", "area_drift", "kinetic_energy",
    "min_angle", "min_detJ", "mean_iterations", "max_iterations", "flow_solves",
    "flow_factorizations", "mesh_velocity_factorizations", "krylov_iterations",
    "thick_front", "film_threshold", "landings",
)


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


#: A value of an ``#SBATCH`` option: one word of letters, digits and ``_.:,+=@%/-`` (no
#: space, quote, ``$``, ``#`` or control character: nothing a job script could run).
_SBATCH_VALUE = re.compile(r"^[\w.:,+=@%/-]+$")
#: A further sbatch option (``--qos=short``): a dash first, no space, quote, ``$`` or backslash.
_SBATCH_OPTION = re.compile(r"^-[^\s\"'$`\\#]+$")


def no_control_characters(value: str) -> str:
    """``value`` unchanged, or ValueError when it holds a newline or another control
    character (it would start a new line of a generated script)."""
    if any(ord(c) < 32 or ord(c) == 127 for c in value):
        raise ValueError("must not contain a newline or another control character")
    return value


def check_launcher(value: str) -> str:
    """A launcher prefix: one line, shell words, ``{ranks}`` its only placeholder."""
    import shlex
    import string

    no_control_characters(value)
    try:
        fields = {name for _, name, _, _ in string.Formatter().parse(value) if name is not None}
        value.format(ranks=2)
        shlex.split(value)
    except (ValueError, IndexError, KeyError) as exc:
        raise ValueError(f"not a launcher prefix ({exc}); e.g. 'mpirun -n {{ranks}}'") from None
    unknown = sorted(fields - {"ranks"})
    if unknown:
        raise ValueError(f"unknown placeholder {{{unknown[0]}}}; the only one is {{ranks}}")
    return value


class SlurmOptions(_Strict):
    """``--executor slurm``: the ``#SBATCH`` lines of the job-array script."""

    time: str | None = Field(None, description="--time of each array task, e.g. 02:00:00")
    partition: str | None = Field(None, description="--partition")
    account: str | None = Field(None, description="--account")
    memory_per_cpu: str | None = Field(None, description="--mem-per-cpu, e.g. 4G")
    sbatch: list[str] = Field([], description="further sbatch options, e.g. --qos=short")
    setup: list[str] = Field([], description="shell lines run first (module load, ...)")
    launcher: str = Field("srun -n {ranks}", description="prefix of a case on several ranks")
    python: str | None = Field(None, description="Python of the array tasks "
                               "(default: the one writing the script)")

    @field_validator("time", "partition", "account", "memory_per_cpu")
    @classmethod
    def _one_word(cls, v: str | None) -> str | None:
        if v is not None and not _SBATCH_VALUE.match(v):
            raise ValueError("must be one word of letters, digits and _.:,+=@%/- (no space, "
                             "quote, $ or control character)")
        return v

    @field_validator("sbatch")
    @classmethod
    def _options(cls, v: list[str]) -> list[str]:
        for option in v:
            if not _SBATCH_OPTION.match(option):
                raise ValueError(f"{option!r}: an sbatch option such as --qos=short (a dash "
                                 "first; no space, quote, $, # or control character)")
        return v

    @field_validator("setup")
    @classmethod
    def _lines(cls, v: list[str]) -> list[str]:
        for line in v:
            no_control_characters(line)
        return v

    @field_validator("python")
    @classmethod
    def _python(cls, v: str | None) -> str | None:
        return None if v is None else no_control_characters(v)

    @field_validator("launcher")
    @classmethod
    def _launcher(cls, v: str) -> str:
        return check_launcher(v)


class SweepFile(_Strict):
    """The keys of a sweep file; unknown keys are refused."""

    base: Annotated[str, Field(min_length=1)]
    set: dict[str, Any] = {}
    grid: dict[str, list[Any]] = {}
    zip: dict[str, list[Any]] = {}
    cases: list[dict[str, Any]] = []
    collect: list[str] = []
    ranks_per_case: Annotated[int, Field(ge=1, le=4096, strict=True)] = 1
    launcher: str = "mpirun -n {ranks}"
    slurm: SlurmOptions = SlurmOptions()

    @field_validator("launcher")
    @classmethod
    def _launcher(cls, v: str) -> str:
        return check_launcher(v)

    @field_validator("collect")
    @classmethod
    def _known(cls, v: list[str]) -> list[str]:
        for name in v:
            if name not in SUMMARY_KEYS and not name.startswith("front_"):
                raise ValueError(f"{name!r} is not a run.json summary value; allowed: "
                                 + ", ".join(SUMMARY_KEYS) + " (or front_*)")
        return v


@dataclass(frozen=True)
class Case:
    """One run of the sweep."""

    index: int
    name: str
    params: dict[str, Any]   #: the varied keys and their values
    overrides: tuple[str, ...]   #: ``section.key=value`` items after the base config
    config: dict = field(repr=False)   #: the resolved config (as in run.json)


@dataclass(frozen=True)
class Sweep:
    """A validated sweep file and its cases."""

    path: Path
    base: Path
    spec: SweepFile
    cases: list[Case]
    varied: list[str]   #: the varied keys, in order

    @property
    def fingerprint(self) -> str:
        """Hash of every case's name, overrides and config: changes when any case does."""
        text = json.dumps([[c.name, c.overrides, c.config] for c in self.cases],
                          sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def _error(path: Path, exc: ValidationError) -> ConfigError:
    err = exc.errors()[0]
    key = ".".join(str(p) for p in err["loc"])
    if err["type"] == "extra_forbidden":
        return ConfigError(f"sweep file {path}: {key}: unknown key; allowed: "
                           + ", ".join(SweepFile.model_fields if len(err["loc"]) == 1
                                       else SlurmOptions.model_fields))
    value = err.get("input")
    shown = yaml_value(value) if isinstance(value, (int, float, str, bool, type(None))) else ""
    what = err["msg"].removeprefix("Value error, ")
    return ConfigError(f"sweep file {path}: {key}{' = ' + shown if shown else ''}: {what}")


def _check_key(path: Path, where: str, key: str) -> None:
    if not _KEY.match(key):
        raise ConfigError(f"sweep file {path}: {where}: {key!r}: must be section.key "
                          "(as in --set)")
    if key == "output.directory":
        raise ConfigError(f"sweep file {path}: {where}: output.directory: set by the sweep "
                          "(one run directory per case); not allowed")


def _factors(path: Path, spec: SweepFile) -> list[list[tuple[dict, str | None]]]:
    """The factors of the product: each a list of (params, explicit name)."""
    factors: list[list[tuple[dict, str | None]]] = []
    seen: dict[str, str] = {k: "set" for k in spec.set}
    for k in spec.set:
        _check_key(path, "set", k)

    def claim(key: str, where: str) -> None:
        _check_key(path, where, key)
        if key in seen and seen[key] != where:
            raise ConfigError(f"sweep file {path}: {key}: given in both {seen[key]} and {where}")
        seen[key] = where

    for key, values in spec.grid.items():
        claim(key, "grid")
        if not values:
            raise ConfigError(f"sweep file {path}: grid.{key}: empty list; give at least one value")
        factors.append([({key: v}, None) for v in values])
    if spec.zip:
        lengths = {k: len(v) for k, v in spec.zip.items()}
        for key in spec.zip:
            claim(key, "zip")
        if len(set(lengths.values())) != 1 or 0 in lengths.values():
            raise ConfigError(f"sweep file {path}: zip: lists must have one length, at least 1; "
                              "got " + ", ".join(f"{k}: {n}" for k, n in lengths.items()))
        n = next(iter(lengths.values()))
        factors.append([({k: spec.zip[k][i] for k in spec.zip}, None) for i in range(n)])
    if spec.cases:
        rows = []
        for i, item in enumerate(spec.cases):
            item = dict(item)
            name = item.pop("name", None)
            if name is not None and not (isinstance(name, str) and is_safe_name(name)):
                raise ConfigError(f"sweep file {path}: cases[{i}].name = {name!r}: must be a "
                                  "directory name of letters, digits and ._+=- (at most 96)")
            for key in item:
                claim(key, "cases")
            rows.append((item, name))
        factors.append(rows)
    return factors


def _refuse_varied_overrides(path: Path, spec: SweepFile, extra: tuple[str, ...]) -> None:
    """A ``--set`` of a key the sweep varies (its grid, zip or cases) would be overridden by
    each case's own value, silently: ConfigError naming the key (issue 47)."""
    where = {**{k: "grid" for k in spec.grid}, **{k: "zip" for k in spec.zip or {}},
             **{k: "cases" for item in spec.cases or [] for k in dict(item) if k != "name"}}
    for item in extra:
        key = str(item).split("=", 1)[0].strip()
        if key in where:
            raise ConfigError(f"--set {key}: varied by the sweep file {path} (its {where[key]}: "
                              "each case sets its own value); remove the --set, or change the "
                              f"{where[key]} in the sweep file")


def load_sweep(path: str | Path, extra: tuple[str, ...] = ()) -> Sweep:
    """Read and validate a sweep file; ``extra`` are ``section.key=value`` overrides given
    on the command line for every case (after the file's ``set``). Raises ConfigError."""
    path = Path(path)
    # the config loader's rules: a regular file of at most 1 MB, a key twice refused
    data = parse_input_yaml(read_input_text(path, "sweep file"), path, "sweep file")
    if not isinstance(data, dict):
        raise ConfigError(f"sweep file {path}: must be a mapping with at least 'base'")
    try:
        spec = SweepFile.model_validate(data)
    except ValidationError as exc:
        raise _error(path, exc) from None
    base = Path(spec.base)
    base = (base if base.is_absolute() else path.parent / base).resolve()
    if not base.is_file():
        raise ConfigError(f"sweep file {path}: base = {spec.base}: file not found ({base})")
    fixed = [f"{k}={yaml_value(v)}" for k, v in spec.set.items()] + list(extra)
    combos = list(itertools.product(*_factors(path, spec)))
    params = [{k: v for p, _ in combo for k, v in p.items()} for combo in combos]
    _refuse_varied_overrides(path, spec, extra)
    names = case_names([{k: v for p, n in combo for k, v in ({"name": n} if n else p).items()}
                        for combo in combos])
    folded: dict[str, int] = {}
    for i, name in enumerate(names):
        if name.lower() in folded:
            raise ConfigError(f"sweep file {path}: cases {folded[name.lower()]} and {i} have the "
                              f"same name {name!r} (the same parameters, or the same name)")
        folded[name.lower()] = i
    try:
        load_config(base, fixed)
    except ConfigError as exc:
        raise ConfigError(f"sweep file {path}: base {base.name} with set: {exc}") from None
    cases = []
    for i, (name, p) in enumerate(zip(names, params)):
        overrides = tuple(fixed + [f"{k}={yaml_value(v)}" for k, v in p.items()])
        try:
            cfg = load_config(base, overrides)
        except ConfigError as exc:
            raise ConfigError(f"case {name}: {exc}") from None
        cases.append(Case(i, name, p, overrides, json.loads(json.dumps(config_to_dict(cfg)))))
    varied = list(dict.fromkeys(k for p in params for k in p))
    return Sweep(path, base, spec, cases, varied)
