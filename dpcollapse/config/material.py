"""``material``: one section class per constitutive law (dpcollapse/rheology/), told apart
by ``rheology``."""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import (
    Discriminator,
    Tag,
    model_validator,
)

from dpcollapse.config.fields import Number, _f, _fmt, _Section
from dpcollapse.errors import ConfigError


class _Material(_Section):
    """Granular material: what every law has. One class per law (``rheology``, the tag)."""

    rheology: str
    density: Number = _f(1550.0, "kg/m^3", "Bulk density rho", gt=0)
    friction_angle: Number = _f(
        25.5, "deg", "Internal friction angle; mu_s = tan (0: drucker_prager without cohesion is a "
        "Newtonian fluid of viscosity eta)", ge=0, lt=90)
    gravity: Number = _f(9.81, "m/s^2", "Magnitude g of gravity", gt=0, le=1000)
    cohesion: Number = _f(0.0, "Pa", "Cohesion kappa0: yield stress kappa0 + mu_s p in shear", ge=0)

    @property
    def mu_s(self) -> float:
        """Internal friction coefficient tan(friction_angle) [-]."""
        return math.tan(math.radians(self.friction_angle))


class DruckerPragerMaterial(_Material):
    """Drucker–Prager: the yield stress κ(p) = √2 (κ0 + μ_s [p]_+) and a Newtonian part η."""

    rheology: Literal["drucker_prager"] = _f(
        "drucker_prager", "", "drucker_prager (constant viscosity) or mu_i (rate-dependent)")
    viscosity: Number = _f(1.0, "Pa s", "Newtonian viscosity eta", ge=0)

    @model_validator(mode="after")
    def _newtonian_limit(self) -> DruckerPragerMaterial:
        """friction_angle = cohesion = 0 is a Newtonian fluid: some stress must remain."""
        if self.friction_angle == 0 and self.cohesion == 0 and self.viscosity == 0:
            raise ConfigError("material.viscosity = 0: must be > 0 when material.friction_angle "
                              "and material.cohesion are 0 (a fluid without any stress)")
        return self


class MuIMaterial(_Material):
    """μ(I): μ = μ_s + (μ_2 − μ_s)/(I0/I + 1), I = d γ̇ / √(p/ρ_s) (seed 004)."""

    rheology: Literal["mu_i"] = _f(
        "mu_i", "", "drucker_prager (constant viscosity) or mu_i (rate-dependent)")
    friction_angle_2: Number = _f(
        31.0, "deg", "Friction angle at large I; mu_2 = tan (must exceed friction_angle)",
        gt=0, lt=90)
    inertial_number_I0: Number = _f(0.4, "", "I0 of mu(I) = mu_s + (mu_2 - mu_s)/(I0/I + 1)", gt=0)
    grain_diameter: Number = _f(7.0e-4, "m", "Grain diameter d", gt=0)
    grain_density: Number = _f(2500.0, "kg/m^3", "Grain density rho_s in I = d gamma_dot/sqrt(p/rho_s)", gt=0)
    viscosity_cap: Number | None = _f(
        None, "Pa s", "Cap eta_max on the effective viscosity (null: none)", gt=0)

    @property
    def mu_2(self) -> float:
        """mu_2 = tan(friction_angle_2) [-]."""
        return math.tan(math.radians(self.friction_angle_2))

    @model_validator(mode="after")
    def _mu_order(self) -> MuIMaterial:
        if self.friction_angle == 0:
            raise ConfigError(
                "material.friction_angle = 0: must be in (0, 90) degrees for mu_i "
                "(0 only with drucker_prager: a Newtonian fluid)")
        if self.friction_angle_2 <= self.friction_angle:
            raise ConfigError(
                f"material.friction_angle_2 = {_fmt(self.friction_angle_2)}: must be > "
                f"material.friction_angle = {_fmt(self.friction_angle)} degrees for mu_i")
        return self


def _rheology_of(value: Any) -> str:
    """The material class of a mapping or model: its ``rheology``, drucker_prager when absent."""
    if isinstance(value, dict):
        return value.get("rheology", "drucker_prager")
    return getattr(value, "rheology", "drucker_prager")


MaterialConfig = Annotated[
    Annotated[DruckerPragerMaterial, Tag("drucker_prager")] | Annotated[MuIMaterial, Tag("mu_i")],
    Discriminator(_rheology_of),
]
#: material.rheology -> its config class (the law itself: dpcollapse.rheology.choice.LAWS)
MATERIALS: dict[str, type[_Material]] = {"drucker_prager": DruckerPragerMaterial, "mu_i": MuIMaterial}
