"""UFL terms of the Eulerian two-phase model (seed 003: the granular fluid covered by a passive
light fluid, so that p = 0 at the surface comes for free).

With c ∈ [0, 1] the granular volume fraction (DG0)::

    ρ(c) = c ρ_g + (1 − c) ρ_a                                        "mixture_density"
    σ'   = S D(u),  S = c S_g(u, p) + (1 − c) 2η_a  (arithmetic)      ``MixtureRheology``
                  or 1/S = c/S_g(u, p) + (1 − c)/(2η_a)  (harmonic, ``model.viscosity_average``)
    κ_mix = w(c) κ(p),  w = c (volume), H(c − ½) (sharp), min(1, 2c) (saturated), min(1, c/10⁻⁶) (grains)
                  (``model.yield_weighting``, ``yield_weight``)
    ∂c/∂t + ∇·(c u) = 0                                                "fraction_flux"

The flow terms are those of ``forms.picard`` with ρ(c) and the mixture law. The volume
fraction is advanced explicitly by a finite-volume scheme: for each cell K,
c_K ← c_K − Δt/|K| ∫_∂K F ds, with the upwind flux F = (u·n)⁺ c_K − (u·n)⁻ c_nb across each
facet (outflow only at the boundary: the light fluid enters) and an interface-compression
flux towards the fuller cell, C |u·n| a_f c_donor (1 − c_receiver), a_f the facet's alignment
with the interface normal (``compression_flux``, ``interface_alignment``).
Each flux is single-valued on a facet, so Σ_K |K| c_K changes only by the boundary outflow.

Axisymmetric (``geometry.symmetry``, issue 52): the same terms with the measures 2πr dx and
2πr ds (the caller weights them, ``rheology.coordinates``), D(u) with the hoop rate u_r/r
(the law's ``coordinates``) and ∇·u = ∂_r u_r + u_r/r + ∂_z u_z in the grad-div term.
"""

from __future__ import annotations

import ufl

from dpcollapse.rheology.coordinates import PLANAR
from dpcollapse.rheology.kinematics import regularized_secant


def mixture(c, granular, light):
    """c a_g + (1 − c) a_a: the volume-weighted mixture of a granular and a light quantity."""
    return c * granular + (1.0 - c) * light


#: the averages of the granular and the light viscosity across the interface
#: (``model.viscosity_average``)
VISCOSITY_AVERAGES = ("arithmetic", "harmonic")

#: the harmonic mean's floor on the granular viscosity, relative to the light one: S_g = 0
#: where [p]_+ = 0 without cohesion, and 1/S = c/S_g + … is then S = 0 for c > 0 (the limit)
#: but 0/0 at c = 0, where the floor gives the light fluid's own 2η_a
HARMONIC_FLOOR = 1.0e-12


def harmonic_mixture(c, granular, light):
    """1/(c/a_g + (1 − c)/a_a), written a_a / ((1 − c) + c a_a/max(a_g, f a_a)) with
    f = ``HARMONIC_FLOOR`` (finite where a_g = 0): the harmonic mean of two viscosities,
    the mixture's stresses in series (Gerris' average; Basilisk's is the arithmetic one)."""
    floor = ufl.max_value(granular, HARMONIC_FLOOR * light)
    return light / ((1.0 - c) + c * light / floor)


def _one_of(value: str, allowed: tuple[str, ...], what: str) -> str:
    """``value`` if it is one of ``allowed``, else ValueError naming them."""
    if value not in allowed:
        raise ValueError(f"{what} {value!r}: one of {', '.join(allowed)}")
    return value


def viscosity_mixture(c, granular, light, average: str = "arithmetic"):
    """The mixture of a granular and a light viscosity by ``average`` (``VISCOSITY_AVERAGES``):
    arithmetic c a_g + (1 − c) a_a, harmonic 1/(c/a_g + (1 − c)/a_a)."""
    if _one_of(average, VISCOSITY_AVERAGES, "viscosity average") == "harmonic":
        return harmonic_mixture(c, granular, light)
    return mixture(c, granular, light)


#: how a cell of fraction c carries the grains' yield stress κ(p) (``model.yield_weighting``)
YIELD_WEIGHTINGS = ("volume", "sharp", "saturated", "grains")

#: the floor on c under the granular secant viscosity's w(c)/c (w/c ≤ 2 where w ≠ 0)
FRACTION_FLOOR = 1.0e-12
#: ``grains``: w rises linearly to 1 over c ∈ [0, GRAINS_RAMP]. A step H(c − 10⁻¹²) flipped
#: with round-off (cells of the haze near 10⁻¹² in one summation order and not the other:
#: the erodible bed's layer measures differed by 0.7 % between 1 and 2 ranks); the ramp is
#: continuous, and 10⁻⁶ of a cell's area of grains is no mass that matters.
GRAINS_RAMP = 1.0e-6


def yield_weight(c, weighting: str = "volume"):
    """w(c), the share of the grains' yield stress κ(p) a cell of fraction c carries::

        volume     w = c               the volume average of κ and the light fluid's 0
        sharp      w = H(c − ½)        the grains' own κ where the cell is mostly grains
                                       (the VOF interface c = ½), none elsewhere; H(0) = 1
        saturated  w = min(1, 2c)      continuous: the volume weighting stretched so that a
                                       cell at the interface, c = ½, already has the full κ
        grains     w = min(1, c/10⁻⁶)  the grains' own κ wherever there are grains (from
                                       c = ``GRAINS_RAMP``; a continuous ramp below it)

    Under the volume weighting a cell on a slope θ holds only if c μ_s ≥ tan θ (issue 27);
    under ``sharp`` every cell with c ≥ ½ holds where the grains would, under ``saturated``
    every cell with c ≥ tan θ/(2 μ_s), under ``grains`` every cell with grains."""
    weighting = _one_of(weighting, YIELD_WEIGHTINGS, "yield weighting")
    if weighting == "sharp":
        return ufl.conditional(ufl.ge(c, 0.5), 1.0, 0.0)
    if weighting == "saturated":
        return ufl.min_value(2.0 * c, 1.0)
    if weighting == "grains":
        return ufl.min_value(c / GRAINS_RAMP, 1.0)
    return c


class MixtureRheology:
    """The granular law in the granular phase, a Newtonian fluid η_a in the light phase,
    σ' = S D(u) with S (the secant viscosity of ``rheology.base``) averaged by ``average``::

        arithmetic   S = c S_g(u, p) + (1 − c) 2η_a
        harmonic     1/S = c/S_g(u, p) + (1 − c)/(2η_a)

    (the rate viscosities likewise with η_a). The yield stress of the mixture is
    κ_mix = w(c) κ(p) (``yield_weight``, ``model.yield_weighting``): with the volume weighting
    w = c it is the c-weighted part of c S_g, with another w the granular phase carries it as
    S_g^w = min(w(c)/c · κ(p)/|D|_ε + 2η, 2η_max) in place of S_g, so that (arithmetic)::

        S = w(c) κ(p)/|D|_ε + c 2η + (1 − c) 2η_a        (sharp: w = H(c − ½), no cap)

    It offers the ``Rheology`` protocol to ``forms.picard`` (the law is any Rheology)."""

    rate_dependent = True

    def __init__(self, law, fraction, light_viscosity, average: str = "arithmetic",
                 yield_weighting: str = "volume"):
        self.law, self.c, self.eta_a = law, fraction, light_viscosity
        self.average = _one_of(average, VISCOSITY_AVERAGES, "viscosity average")
        self.yield_weighting = _one_of(yield_weighting, YIELD_WEIGHTINGS, "yield weighting")
        self.cohesion = law.cohesion
        self.viscosity_cap = law.viscosity_cap
        #: the granular law's (``rheology.coordinates``): D(u) and |D| with the hoop rate
        self.coordinates = law.coordinates

    def _mix(self, granular, light):
        return viscosity_mixture(self.c, granular, light, self.average)

    def yield_stress(self, p):
        """κ_mix = w(c) κ(p) [Pa] (volume: c κ(p); sharp: H(c − ½) κ(p))."""
        return yield_weight(self.c, self.yield_weighting) * self.law.yield_stress(p)

    def _granular_secant(self, u, p, epsilon):
        """S_g (volume), else S_g^w = min(w/c · κ(p)/|D|_ε + 2η, 2η_max): the granular secant
        viscosity whose c-weighted part has the yield stress w(c) κ(p)."""
        if self.yield_weighting == "volume":
            return self.law.secant_viscosity(u, p, epsilon)
        share = yield_weight(self.c, self.yield_weighting) / ufl.max_value(self.c, FRACTION_FLOOR)
        return regularized_secant(share * self.law.yield_stress(p), self.law.rate_viscosity(u, p, epsilon),
                                  u, epsilon, self.law.viscosity_cap, self.coordinates)

    def rate_viscosity(self, u, p, epsilon):
        """η_g and η_a averaged (arithmetic: c η_g + (1 − c) η_a) [Pa s]."""
        return self._mix(self.law.rate_viscosity(u, p, epsilon), self.eta_a)

    def capped_rate_viscosity(self, u, p, epsilon):
        return self._mix(self.law.capped_rate_viscosity(u, p, epsilon), self.eta_a)

    def secant_viscosity(self, u, p, epsilon):
        """S of S_g and 2η_a averaged (arithmetic: c S_g(u, p) + (1 − c) 2η_a) [Pa s], S_g
        with the yield stress of the weighting (``_granular_secant``)."""
        return self._mix(self._granular_secant(u, p, epsilon), 2.0 * self.eta_a)

    def deviatoric_stress(self, u, p, epsilon):
        return self.secant_viscosity(u, p, epsilon) * self.coordinates.strain_rate(u)

    def diagnostic_fields(self, u, p, epsilon) -> dict:
        return self.law.diagnostic_fields(u, p, epsilon)

    def well_posed_window(self):
        return self.law.well_posed_window()


def _positive(x):
    return 0.5 * (x + abs(x))


def fraction_flux(c, u, v, n, dS, ds):
    """∫_∂K F v: the upwind flux of c u out of each cell (v the DG0 test function)::

        interior facets  ∫ ((u·n⁺)⁺ c⁺ − (u·n⁺)⁻ c⁻) (v⁺ − v⁻) dS
        boundary         ∫ (u·n)⁺ c v ds            (outflow; the inflow is light fluid)
    """
    un = ufl.dot(u('+'), n('+'))
    flux = _positive(un) * c('+') - _positive(-un) * c('-')
    return flux * (v('+') - v('-')) * dS + _positive(ufl.dot(u, n)) * c * v * ds


def facet_volume_flux(c, u, v, n, dS):
    """∫ (u·n⁺)(c⁻ v⁺ − c⁺ v⁻) dS with c the DG0 trial function: the matrix whose entry
    (K, K') of an interior facet is Φ = ∫_f u·n_K ds, the net volume rate from K into K'
    (and (K', K) its exact negative, from the same kernel): the facet fluxes of the
    geometric interface flux (``models.two_phase.geometric_flux``)."""
    un = ufl.dot(u('+'), n('+'))
    return un * (c('-') * v('+') - c('+') * v('-')) * dS


#: how c crosses the interface (``model.interface_flux``)
INTERFACE_FLUXES = ("compression", "geometric")


def outflow_volume_rate(c, u, n, ds_out):
    """∫_out (u·n)⁺ c ds: the volume of material leaving through the outflow sides per unit
    time and depth [m²/s] (the boundary part of ``fraction_flux`` restricted to them)."""
    return _positive(ufl.dot(u, n)) * c * ds_out


def ambient_pressure(density, body_force, reference, mesh):
    """p_a = ρ_a f·(x − x_ref) [Pa]: the hydrostatic pressure of the light fluid at rest, zero
    at the point x_ref (f the body force per unit mass, pointing down)."""
    x = ufl.SpatialCoordinate(mesh)
    return density * ufl.dot(body_force, x - ufl.as_vector(reference))


def ambient_traction(density, body_force, reference, v, n, ds_out, mesh):
    """−∫_out p_a (v·n) ds with p_a = ρ_a f·(x − x_ref): the traction σ n = −p_a n of the
    light fluid at rest outside an outflow side, zero at the open top's point x_ref (the light
    fluid standing in the vessel is then in equilibrium; the material leaves at p = p_a)."""
    return -ambient_pressure(density, body_force, reference, mesh) * ufl.dot(v, n) * ds_out


#: the pressures the grains' friction may see (``model.grain_pressure``)
GRAIN_PRESSURES = ("effective", "total")


def grain_pressure(p, density, body_force, reference, mesh, kind: str = "total"):
    """The pressure the grains' friction sees (``model.grain_pressure``) [Pa]::

        effective   p − p_a,  p_a = ρ_a f·(x − x_ref)     (Terzaghi: the contact pressure)
        total       p

    p is the mixture's total pressure, zero at the open top. Below a column of light fluid
    of height h_a it holds the light fluid's weight ρ_a g h_a as well, which is not carried by
    grain contacts: counted in κ(p) = √2 μ [p]_+ it is a cohesion that grows with the box's
    height and with ρ_a (measured: +2.6–3.0 % deposit height at ρ_a = 15 kg/m³), and it is
    what holds the cut cells of a heap's flank below the friction angle (with ``effective``
    they settle at up to 1.9 mm/s). x_ref is the domain's highest point (``highest_point``)."""
    kind = _one_of(kind, GRAIN_PRESSURES, "grain pressure")
    if kind == "total":
        return p
    return p - ambient_pressure(density, body_force, reference, mesh)


#: the point of a cut cell whose pressure its grains' friction sees (``model.cut_cell_pressure``)
CUT_CELL_PRESSURES = ("pointwise", "centroid")


def cut_cell_pressure(p, c, centroid, mesh, kind: str = "pointwise"):
    """The pressure the grains' yield stress and μ(I) see in a cell the interface cuts
    (0 < c < 1) [Pa] (the walls' friction reads p at the wall: ``forms.picard``'s ``p_walls``)::

        pointwise   p(x)                              at every quadrature point
        centroid    p(x_K) = p(x) + ∇p·(x_K − x)       (p ∈ P1: its value at the centroid x_K,
                                                       the cell average)

    Full and empty cells keep p(x). ``centroid`` is a DG0 vector field of the cells'
    centroids (None with ``pointwise``). Why: the continuous P1 pressure cannot bend inside a
    cell, so in a cut cell at a heap's surface the part of the cell above the grains has
    p − p_a ≤ 0 and [·]_+ = 0, no yield stress, while the cell carries the grains' weight;
    at the centroid the grains of the cell feel their depth (measured on the static heap:
    docs/benchmarks/2026-12-04-cut-cell-pressure.md)."""
    kind = _one_of(kind, CUT_CELL_PRESSURES, "cut-cell pressure")
    if kind == "pointwise":
        return p
    at_centroid = p + ufl.dot(ufl.grad(p), centroid - ufl.SpatialCoordinate(mesh))
    cut = ufl.And(ufl.gt(c, 0.0), ufl.lt(c, 1.0))
    return ufl.conditional(cut, at_centroid, p)


def interface_alignment(gradient, n):
    """|ĝ·n⁺| on an interior facet, ĝ = avg(∇c̄)/|avg(∇c̄)| the interface normal from the
    gradient of c̄ (the volume fraction averaged to the vertices, P1): 1 on a facet parallel
    to the interface, 0 on a facet across it (along a layer), 0 where c̄ is flat."""
    g = ufl.avg(gradient)
    size = ufl.sqrt(ufl.dot(g, g))
    return ufl.conditional(ufl.gt(size, 1e-12), abs(ufl.dot(g, n('+'))) / (size + 1e-300), 0.0)


#: where the interface compression acts (``model.compression_direction``)
COMPRESSION_DIRECTIONS = ("facet", "normal", "layer_normal", "skip_layers")


def layer_alignment(gradient, layer_normal, thin, n, direction: str = "layer_normal"):
    """The facet alignment a_f in and out of thin layers (``models.two_phase.layer_normal``:
    ``layer_normal`` n_h the DG0 normal (−h', 1)/√(1 + h'²) of the layer's height function h,
    ``thin`` the DG0 indicator of a layer thinner than two cells)::

        layer        a = |n_h·n⁺|   on a facet of a thin layer's cell (either side),
                     |ĝ·n⁺|         elsewhere (``interface_alignment``, ĝ from ∇c̄)
        skip_layers  a = 0          on a facet of a thin layer's cell,  |ĝ·n⁺| elsewhere

    ``layer_normal``: across the layer the full compression, along it only its slope's share
    |h'|/√(1 + h'²) (a tongue lying on the bed is not pulled back along itself);
    ``skip_layers``: no compression at all in the layer (plain upwind there)."""
    _one_of(direction, ("layer_normal", "skip_layers"), "compression direction")
    normal = interface_alignment(gradient, n)
    in_layer = ufl.gt(ufl.avg(thin), 0.25)   # thin ∈ {0, 1}: avg ≥ ½ if either cell is
    if direction == "skip_layers":
        return ufl.conditional(in_layer, 0.0, normal)
    return ufl.conditional(in_layer, abs(ufl.dot(ufl.avg(layer_normal), n('+'))), normal)


def _alignment(gradient, n, layer):
    """a_f: |ĝ·n⁺| (``interface_alignment``), or with ``layer`` = (n_h, thin, direction) the
    thin layers' (``layer_alignment``)."""
    if layer is None:
        return interface_alignment(gradient, n)
    normal, thin, direction = layer
    return layer_alignment(gradient, normal, thin, n, direction)


#: the speed of the interface compression on a facet (``model.compression_speed``)
COMPRESSION_SPEEDS = ("facet", "full")


def compression_speed(u, n, kind: str = "facet"):
    """The compression's speed on an interior facet: |u·n⁺| (``facet``: interFoam's
    |φ_f|/|S_f|, the flow's own flux through the facet) or |u| (``full``: the compression
    velocity C |u| n̂ written with the whole speed, so that it also acts across an interface
    the flow runs along, the top of a layer sheared along the bed)."""
    if _one_of(kind, COMPRESSION_SPEEDS, "compression speed") == "full":
        return ufl.sqrt(ufl.dot(u('+'), u('+')))
    return abs(ufl.dot(u('+'), n('+')))


def compression_flux(c, u, v, n, dS, coefficient, gradient=None, layer=None, speed="facet"):
    """∫ C |u·n| a φ (v⁺ − v⁻) dS, the interface compression: across a facet the flux from the
    emptier cell to the fuller one, φ = c⁺ (1 − c⁻) when c⁻ > c⁺, −c⁻ (1 − c⁺) when c⁺ > c⁻
    (a donor gives at most what it holds, a receiver takes at most its room). a = 1
    (``model.compression_direction: facet``: across every facet with a jump of c), or with
    ``gradient`` = ∇c̄ the facet's alignment with the interface normal (``normal``:
    ``interface_alignment``; OpenFOAM's compression velocity along ∇c, not along a layer; with
    ``layer`` = (n_h, thin, direction) in a thin layer ``layer_alignment``)."""
    un = compression_speed(u, n, speed)
    if gradient is not None:
        un = un * _alignment(gradient, n, layer)
    phi = ufl.conditional(ufl.gt(c('-'), c('+')), c('+') * (1.0 - c('-')),
                          -c('-') * (1.0 - c('+')))
    return coefficient * un * phi * (v('+') - v('-')) * dS


def compression_weights(c, u, v, n, dS, gradient=None, layer=None, speed="facet"):
    """∫ |u·n| a (c⁻ v⁺ − c⁺ v⁻) dS with c the DG0 trial function: the matrix whose entry of
    a facet's cells (K⁺, K⁻) is +∫_f |u·n| a ds and of (K⁻, K⁺) its negative — the weight of
    ``compression_flux`` on that facet (a as there) and, by its sign, the facet's orientation
    (which cell is '+'), so the flux can be evaluated cell pair by cell pair without
    reassembly. (A facet of weight 0 — a = 0 — carries no compression either way.)"""
    un = compression_speed(u, n, speed)
    if gradient is not None:
        un = un * _alignment(gradient, n, layer)
    return un * (c('-') * v('+') - c('+') * v('-')) * dS


def outflow_rate(u, v, n, dS, ds, coefficient, speed="facet"):
    """∫_∂K ((u·n)⁺ + C s) v, s = |u·n| (or |u|, ``compression_speed``): the largest rate at
    which a cell can empty, times |K| (sub-step Δt ≤ Co |K| / this keeps c ≥ 0)."""
    s = compression_speed(u, n, speed)
    rate_plus = _positive(ufl.dot(u('+'), n('+'))) + coefficient * s
    rate_minus = _positive(ufl.dot(u('-'), n('-'))) + coefficient * s
    return (rate_plus * v('+') + rate_minus * v('-')) * dS + _positive(ufl.dot(u, n)) * v * ds


def grad_div(coefficient, secant_viscosity, u, v, dx, coordinates=PLANAR):
    """γ ∫ S (∇·u)(∇·v) dx: the grad-div term (Olshanskii & Reusken 2004) with the local secant
    viscosity S of the mixture as its scale. It vanishes for an exactly divergence-free u; on
    Taylor–Hood P2/P1 it pulls the cellwise divergence ∫_K ∇·u, which the volume fraction's
    fluxes see, towards zero, in the stiff granular phase as much as in the light fluid.
    (``coordinates``: ∇·u of ``rheology.coordinates``; dx the caller's, weighted or not.)"""
    div = coordinates.divergence
    return coefficient * secant_viscosity * div(u) * div(v) * dx


def skew_convection(rho, u_iter, u, v, n, dx, ds_open):
    """The convection of the variable-density mixture in skew-symmetric form, linearized at uᵏ::

        ½ ∫ ρ [((uᵏ·∇) u)·v − ((uᵏ·∇) v)·u] dx + ½ ∫_open ρ [uᵏ·n]₊ u·v ds

    It equals ∫ ρ (uᵏ·∇)u·v + ½ ∫ ∇·(ρ uᵏ) u·v (+ the backflow-stabilized open side), whose
    added half vanishes when ∂ρ/∂t + ∇·(ρu) = 0. With v = u the volume part is zero for any ρ
    (jumps of the DG0 ρ(c) across facets, ∇·uᵏ ≠ 0 in a cell), so convection neither creates
    nor destroys kinetic energy inside; on the open side only the outflow takes it away
    (where the light fluid enters, the traction-free side would feed ½ ρ |u·n| |u|² in:
    backflow stabilization, Moghadam et al. 2011)."""
    un = ufl.dot(u_iter, n)
    volume = 0.5 * rho * (ufl.inner(ufl.grad(u) * u_iter, v) - ufl.inner(ufl.grad(v) * u_iter, u)) * dx
    return volume + 0.5 * rho * _positive(un) * ufl.inner(u, v) * ds_open


#: the densities of the time derivative (``model.inertia``)
INERTIAS = ("velocity", "energy", "mean")


def previous_momentum(rho, rho_previous, dt, u_old, v, dx, kind: str = "velocity"):
    """The explicit half of the time derivative, its implicit half ∫ ρ(cⁿ) u^{n+1}/Δt · v::

        velocity   ∫ ρ(cⁿ) uⁿ/Δt · v               ρⁿ (u^{n+1} − uⁿ)/Δt
        energy     ∫ √(ρ(cⁿ) ρ(cⁿ⁻¹)) uⁿ/Δt · v     (ρⁿ u^{n+1} − √(ρⁿ ρⁿ⁻¹) uⁿ)/Δt
        mean       ∫ ½(ρ(cⁿ) + ρ(cⁿ⁻¹)) uⁿ/Δt · v   (ρⁿ u^{n+1} − ½(ρⁿ + ρⁿ⁻¹) uⁿ)/Δt

    ``energy`` is Guermond & Quartapelle's (2000) σ(σu)_t with σ = √ρ, = ρ u_t + ½ (∂ρ/∂t) u.
    The skew-symmetric convection (``skew_convection``) is ρ (u·∇)u + ½ ∇·(ρu) u, and with
    ∂ρ/∂t + ∇·(ρu) = 0 its added half is −½ (∂ρ/∂t) u: under ``velocity`` it stays in the
    equation as a force ½ (∂ρ/∂t) u, along u where the grains arrive (a front running into
    the light fluid: ∂ρ/∂t ~ [ρ] |u|/ΔX, a one-cell tongue driven the harder the finer the
    cells). ``energy`` cancels it, and tested with u^{n+1} the two halves give
    ½ ρⁿ|u^{n+1}|² − ½ ρⁿ⁻¹|uⁿ|² + ½ |σⁿu^{n+1} − σⁿ⁻¹uⁿ|²: the kinetic energy
    ½ ∫ ρ(cⁿ⁻¹)|uⁿ|² of the previous step telescopes, whatever c's transport does.
    ``mean`` is ρⁿ (u^{n+1} − uⁿ)/Δt + ½ ((ρⁿ − ρⁿ⁻¹)/Δt) uⁿ: the force ½ (∂ρ/∂t) u that the
    skew convection's ½ ∇·(ρu) u balances, linear in the step's change of ρ for any ratio
    ρⁿ/ρⁿ⁻¹. ``energy``'s ρⁿ − √(ρⁿ ρⁿ⁻¹) is that only while ρⁿ/ρⁿ⁻¹ ≈ 1: in a cell the
    front enters it is up to ρⁿ (the whole momentum of the grains arriving, against the
    skew convection's half), a drag on the front that grows with the step (the cells
    filling in fewer steps)."""
    kind = _one_of(kind, INERTIAS, "inertia")
    if kind == "mean":
        return 0.5 * (rho + rho_previous) / dt * ufl.inner(u_old, v) * dx
    weight = rho if kind == "velocity" else ufl.sqrt(rho * rho_previous)
    return weight / dt * ufl.inner(u_old, v) * dx
