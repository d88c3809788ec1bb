"""The validated run configuration: a tree of frozen pydantic models built from YAML.

Defaults live only in the model fields below; units are SI, angles are in degrees.
Every failure, from a missing file to a value out of range, raises
:class:`dpcollapse.errors.ConfigError` with one line naming the key path, the value given
and what is allowed, e.g. ``material.density = -3.0: must be > 0 (kg/m^3)``.

Public API: :func:`load_config`, :func:`validate_config`, :func:`with_overrides`,
:func:`config_to_dict`, :func:`save_config` and the :class:`Config` model tree.

The package, one job per module: ``fields`` (field types, the unit-carrying field),
``geometry``, ``material``, ``numerics`` (with ``boundary``), ``models``, ``run`` (initial,
time, output) — the sections —, ``root`` (:class:`Config` and its checks across sections),
``messages`` (a validation error as one line), ``files`` (YAML in and out, overrides).
"""

from __future__ import annotations

from dpcollapse.config.fields import Count, Number, PathStr, _f, _fmt, _Section  # noqa: F401
from dpcollapse.config.files import (  # noqa: F401
                                     MAX_INPUT_BYTES,
                                     config_to_dict,
                                     from_saved,
                                     load_config,
                                     parse_input_yaml,
                                     read_input_text,
                                     save_config,
                                     validate_config,
                                     with_overrides,
)
from dpcollapse.config.geometry import (  # noqa: F401
                                     GEOMETRIES,
                                     ColumnGeometry,
                                     ErodibleGeometry,
                                     GeometryConfig,
                                     LayerGeometry,
                                     SiloGeometry,
                                     TrapezoidGeometry,
)
from dpcollapse.config.material import MATERIALS, DruckerPragerMaterial, MaterialConfig, MuIMaterial  # noqa: F401
from dpcollapse.config.messages import RENAMED  # noqa: F401
from dpcollapse.config.models import (  # noqa: F401
                                     MAX_EXTENT,
                                     MAX_GRID_CELLS,
                                     MEMORY_PER_CELL,
                                     MODELS,
                                     ModelConfig,
                                     SavageHutterModel,
                                     StokesModel,
                                     TwoPhaseModel,
                                     box_cells,
                                     mesh_cells,
)
from dpcollapse.config.numerics import BoundaryConfig, NumericsConfig  # noqa: F401
from dpcollapse.config.root import Config  # noqa: F401
from dpcollapse.config.run import InitialConfig, OutputConfig, TimeConfig  # noqa: F401
from dpcollapse.errors import ConfigError  # noqa: F401

__all__ = [
    "BoundaryConfig",
    "ColumnGeometry",
    "Config",
    "DruckerPragerMaterial",
    "ErodibleGeometry",
    "GeometryConfig",
    "LayerGeometry",
    "MaterialConfig",
    "ModelConfig",
    "MuIMaterial",
    "NumericsConfig",
    "OutputConfig",
    "SavageHutterModel",
    "SiloGeometry",
    "StokesModel",
    "TimeConfig",
    "TrapezoidGeometry",
    "TwoPhaseModel",
    "config_to_dict",
    "from_saved",
    "load_config",
    "save_config",
    "validate_config",
    "with_overrides",
]
