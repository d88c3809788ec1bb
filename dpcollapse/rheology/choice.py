"""The constitutive law named by a config's ``material`` section."""

from __future__ import annotations

from dpcollapse.rheology.base import Rheology
from dpcollapse.rheology.drucker_prager import DruckerPrager
from dpcollapse.rheology.mu_i import MuI


def law_from_material(m) -> Rheology:
    """DruckerPrager(η, μ_s, cohesion) for ``material.rheology: drucker_prager``, or
    MuI(μ_s, μ_2, I0, d, ρ_s, cohesion, η_max) for ``mu_i``; ``m`` is ``cfg.material``."""
    if m.rheology == "mu_i":
        return MuI(mu_s=m.mu_s, mu_2=m.mu_2, I0=m.inertial_number_I0, grain_diameter=m.grain_diameter,
                   grain_density=m.grain_density, cohesion=m.cohesion, viscosity_cap=m.viscosity_cap)
    return DruckerPrager(m.viscosity, m.mu_s, m.cohesion)
