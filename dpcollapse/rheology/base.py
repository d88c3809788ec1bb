r"""What a constitutive law provides to the solvers: the :class:`Rheology` protocol.

Every law of this package writes its deviatoric stress as a yield part and a rate part,
with the project's norm |D| = √(D:D) and |D|_ε = √(|D|² + ε²)::

    σ' = κ(p) D/|D|_ε + 2 η(|D|, p) D,     capped:  σ' = min(S, 2 η_max) D

where S = κ(p)/|D|_ε + 2η is the *secant viscosity*, the coefficient of D(v) in the
Picard linearization. The regularized solver uses ``secant_viscosity`` and
``deviatoric_stress``; the augmented Lagrangian solver splits the law into its yield
stress κ(p) and its (capped) rate viscosity η, which it holds fixed within a step
(constant when ``rate_dependent`` is False). Diagnostics that only some laws have (μ(I)'s
inertial number and its well-posed window) come through ``diagnostic_fields`` and
``well_posed_window`` so that callers never ask which law they hold.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable


@runtime_checkable
class Rheology(Protocol):
    """A viscoplastic law σ' = κ(p) D/|D|_ε + 2η D, with an optional cap on S."""

    #: κ0 [Pa]: the yield stress in simple shear at p = 0.
    cohesion: float
    #: η_max [Pa s] or None: the secant viscosity S is capped at 2 η_max when given.
    viscosity_cap: float | None
    #: False when η is a constant (Drucker–Prager): rate_viscosity is then a float.
    rate_dependent: bool
    #: Its ``material.rheology`` (``rheology.choice.LAWS``).
    name: str
    #: The grain size the law carries [m] (0 when none): films thinner than a few of it are
    #: not flowing material (the thickness front).
    grain_scale: float
    #: ``rheology.coordinates``: planar or axisymmetric (D(u) and |D| with the hoop rate u_r/r)
    coordinates: object

    def yield_stress(self, p):
        """κ(p) [Pa] as UFL (Frobenius convention: √2 times the simple-shear yield stress)."""

    def rate_viscosity(self, u, p, epsilon):
        """η(|D(u)|_ε, p) [Pa s], uncapped (a float when ``rate_dependent`` is False)."""

    def capped_rate_viscosity(self, u, p, epsilon):
        """min(η, η_max) [Pa s] (η when there is no cap): the augmented Lagrangian's η."""

    def secant_viscosity(self, u, p, epsilon):
        """S = min(κ(p)/|D(u)|_ε + 2η, 2η_max) [Pa s]: σ' = S D in the Picard linearization."""

    def deviatoric_stress(self, u, p, epsilon):
        """σ'(u, p) = S(u, p) D(u) [Pa]."""

    def diagnostic_fields(self, u, p, epsilon) -> dict:
        """Extra cell fields worth writing, name -> UFL scalar (empty when none)."""

    def describe(self) -> str:
        """One line of the law's own parameters for ``dpcollapse check`` ("" when none)."""

    def well_posed_window(self) -> tuple[float, float] | None:
        """(I_min, I_max): the inertial numbers where the law is linearly well posed; None
        when the notion does not apply. A law returning a window exports the field
        ``inertial_number`` in ``diagnostic_fields``."""
