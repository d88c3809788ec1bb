"""The constitutive law named by a config's ``material`` section: a registry of the laws by
their ``name`` (a new law is one module in this package, one class with ``name`` and
``from_material``, added to :data:`LAWS`, and its config keys)."""

from __future__ import annotations

import dataclasses

from dpcollapse.rheology.base import Rheology
from dpcollapse.rheology.drucker_prager import DruckerPrager
from dpcollapse.rheology.mu_i import MuI

#: ``material.rheology`` -> the law's class.
LAWS: dict[str, type] = {law.name: law for law in (DruckerPrager, MuI)}


def law_from_material(m, coordinates=None) -> Rheology:
    """The law of ``material.rheology`` built from ``m`` = ``cfg.material``:
    DruckerPrager(η, μ_s, cohesion) or MuI(μ_s, μ_2, I0, d, ρ_s, cohesion, η_max); in the
    ``coordinates`` given (``rheology.coordinates``: D(u) and |D| with the hoop rate when
    axisymmetric; None: planar)."""
    law = LAWS[m.rheology].from_material(m)
    return law if coordinates is None else dataclasses.replace(law, coordinates=coordinates)
