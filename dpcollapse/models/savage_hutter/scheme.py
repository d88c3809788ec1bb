"""One explicit finite-volume step of the Savage–Hutter equations with well-balanced friction.

Conservative variables U = (h, q = h ū) on cells of width Δx, flux and sources (x along the bed
inclined at θ, SI units)::

    F(U) = (q, α q²/h + K g cosθ h²/2),    S = (0, g h sinθ − g cosθ h μ_eff sign(ū))

K is the earth-pressure coefficient: 1 (hydrostatic, isotropic pressure: ``Physics.earth_pressure``
None) or Savage & Hutter's K_act/pass per cell (``earth_pressure``: active where the cell
stretches or rests, passive where it is compressed); each side of a face uses its own cell's K
(the conservative form ∂x(K g cosθ h²/2), equal to Savage & Hutter's K g cosθ h ∂x h wherever K
is uniform).
Fluxes: HLL with the wave speeds λ± = α ū ± √(α(α−1) ū² + K g cosθ h) (eigenvalues of ∂F/∂U),
s_L = min(λ−_L, λ−_R, 0), s_R = max(λ+_L, λ+_R, 0), and the dry-bed speeds ū_L + 2 c_L (right
cell dry) / ū_R − 2 c_R (left cell dry), c = √(K g cosθ h). With s_L ≤ ū ≤ s_R the update of h is
a combination of h_{i−1}, h_i, h_{i+1} with non-negative coefficients when
Δt ≤ Δx / a_i, a_i = s_R(ū_i − s_L)/(s_R − s_L)|_{i+½} + (−s_L)(s_R − ū_i)/(s_R − s_L)|_{i−½}:
``interface_terms`` returns that bound (dt_max), so h ≥ 0 (up to round-off, clipped) at any front.

Gravity along the slope is split between the two half cells of each interface, so that the
update of cell i reads, with λ = Δt/Δx::

    h_i* = h_i − λ (F^h_{i+½} − F^h_{i−½})
    q_i* = q_i − λ (G^L_{i+½} − G^R_{i−½})
    G^L = F^q − g sinθ h_L Δx/2,   G^R = F^q + g sinθ h_R Δx/2          (a moving interface)

Shape factor at the front. With α > 1 the model's front is singular: in ∂t ū + ū ∂x ū + … the
term (α − 1) ū² ∂x h / h blows up where h → 0, and the steady front of seed 003 has an
"unphysical exponential precursor". An explicit upwind scheme turns this into a precursor whose
cells each move α times faster than the one behind (a cell filled from upwind receives momentum
flux / mass flux = α ū): measured 990 m/s within 0.01 s for a 0.4 m column with α = 5/4. The
momentum flux is therefore a(h) q²/h with a = α for h ≥ h_α and a = 1 + (α − 1) h/h_α below
(h_α = ``alpha_depth``, 1 mm by default), so the growth factors of successive thinner cells have
a convergent product; flows thicker than h_α see the full α. Its wave speeds: a ū ±
√(α(α−1) ū² + g cosθ h) for h ≥ h_α, a ū ± √((a² − 1) ū² + g cosθ h) below.

Well balance (friction in the reconstruction). Between two cells at rest (q = 0) the HLL flux
still diffuses mass, −c (h_R − h_L)/2 with c the larger sound speed: that is how a plain split
creeps. So a face whose two cells are at rest passes no mass and carries the central thrust
(p_L + p_R)/2, p = K g cosθ h²/2 (the HLL value at rest with symmetric speeds); if the force
beats friction the cells get a velocity first, and mass moves at the next step. Such a face is
moreover *locked* when its surface step obeys

    |h_R − h_L − Δx tanθ| ≤ μ_static Δx,   μ_static = min over the two cells of μ_b(Ī=0) + μ_w h/w

(with an earth pressure: (K_R h_R² − K_L h_L²)/(h_L + h_R) in place of h_R − h_L, i.e. K Δh
for a uniform K), i.e. when the net force of pressure and gravity on its two half cells,
−(p_R − p_L) + g sinθ h̄ Δx = −g cosθ h̄ (Δh − Δx tanθ) at K = 1 with h̄ = (h_L + h_R)/2, is within the
static friction μ_static g cosθ h̄ Δx of those half
cells. At a wall the mirror cell is not material: the wall reacts to any push into it, so a wall
face at rest is locked unless the pull away from the wall exceeds friction (right wall:
h_R − h_L − Δx tanθ ≤ μ_static Δx, left wall: ≥ −μ_static Δx, with the mirrored h). A locked
face returns each side its own hydrostatic thrust::

    F^h = 0,   G^L = p_L = K_L g cosθ h_L²/2,   G^R = p_R = K_R g cosθ h_R²/2

A cell whose two faces are locked is *held*: both faces return its own thrust, so h* = h and
q* = 0 bit for bit. A cell with only one locked face feels the full force of both faces (its
half cells' pressure and gravity) and the whole cell's friction decides below. (Returning the
at-rest thrust through one face only would let the friction of that half cell count twice.)

This is hydrostatic reconstruction on the "apparent topography" of friction: the friction
flattens the apparent surface across the face, so the reconstructed depths on both sides are
equal and the HLL flux of two equal states at rest, with the reconstruction's source correction,
is exactly this. The pair test lets a thin, partly filled edge cell lean on its neighbour (a
cell-by-cell test would push it off), and the implicit friction below decides for every cell
that is not held. Any state with every ū = 0 in which each face is locked or each non-held
cell's force is within its friction is an exact fixed point: a heap whose surface slope is within
the friction keeps its shape and ū = 0 to round-off, forever.

Friction of moving cells (and of cells at rest next to a moving interface) is then applied
implicitly in the speed (``friction.implicit_speed``)::

    h^{n+1} = h*,   |ū^{n+1}| = max(0, v),  v + Δt g cosθ μ_eff(h^{n+1}, v) = |q*|/h^{n+1},
    sign ū^{n+1} = sign q*

which stops a cell exactly (q^{n+1} = 0, not a small number) when its momentum after the fluxes
and gravity, |q*| (so the flux imbalance is part of the driving force), is within the largest
friction impulse Δt g cosθ μ_static h^{n+1}; friction never reverses the flow.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

__all__ = ["InterfaceTerms", "Physics", "extend_with_ghosts", "friction_step", "interface_terms",
           "limited_faces", "transport", "update"]

BOUNDARY_KINDS = ("wall", "open")
POSITIVITY_MARGIN = 0.95


@dataclass(frozen=True)
class Physics:
    """Parameters the step needs.

    g [m/s²]; theta [rad] the bed slope (x down the slope for θ > 0); alpha the shape factor α
    (1 plug flow, 5/4 Bagnold profile); basal a ``friction`` law; side_wall a
    ``SideWallFriction`` or None; h_dry [m]: thinner cells carry no momentum (ū = 0);
    alpha_depth: h_α [m], the thickness below which the shape factor tapers linearly to 1
    (see the module docstring); well_balanced: no mass between cells at rest, friction locking
    (False gives the plain split ū ← max(|ū| − μ g cosθ Δt, 0) sign ū after the HLL fluxes, kept
    only to show that it creeps); earth_pressure: an ``earth_pressure.EarthPressure`` (K per cell)
    or None (K = 1, hydrostatic)."""

    g: float
    theta: float
    alpha: float
    basal: object
    side_wall: object = None
    h_dry: float = 1e-10
    well_balanced: bool = True  # False: the plain split, for comparison only
    alpha_depth: float = 1e-3   # h_α [m]: below it the shape factor tapers to 1
    earth_pressure: object = None  # EarthPressure, or None: K = 1

    def shape_factor(self, h):
        """a(h) = α for h ≥ h_α, 1 + (α − 1) h/h_α below (the momentum flux is a q²/h)."""
        if self.alpha == 1.0:
            return 1.0
        return 1.0 + (self.alpha - 1.0) * np.minimum(h / self.alpha_depth, 1.0)

    @property
    def g_cos(self) -> float:
        """g cosθ [m/s²]: the normal gravity (pressure and friction)."""
        return self.g * math.cos(self.theta)

    @property
    def g_sin(self) -> float:
        """g sinθ [m/s²]: the driving gravity along the slope."""
        return self.g * math.sin(self.theta)

    def static_friction(self, h):
        """μ_static(h) = μ_b(Ī = 0) + μ_w h/w [-]: the largest friction coefficient at rest."""
        mu = self.basal.static(h)
        if self.side_wall is not None:
            mu = mu + self.side_wall.coefficient(h)
        return mu


class InterfaceTerms(NamedTuple):
    """Per-interface quantities of one step (N + 1 interfaces for N cells)."""

    mass_flux: np.ndarray     # F^h [m²/s]
    left_flux: np.ndarray     # G^L [m³/s²]: momentum flux seen by the left cell
    right_flux: np.ndarray    # G^R [m³/s²]: momentum flux seen by the right cell
    locked: np.ndarray        # bool: interface held by friction
    dt_max: float             # [s] largest Δt allowed by the CFL number and positivity of h
    dt_hard: float            # [s] the same with CFL = 1: beyond it h may turn negative or the
    #                           scheme become unstable (a Runge–Kutta stage must respect it)


def extend_with_ghosts(h, q, left: str, right: str):
    """(h, q) with one ghost cell on each side: "wall" mirrors (h, −q) (reflective wall or
    symmetry plane), "open" copies (h, q) (zero-gradient outflow)."""
    he = np.empty(h.size + 2)
    qe = np.empty(q.size + 2)
    he[1:-1] = h
    qe[1:-1] = q
    he[0], he[-1] = h[0], h[-1]
    qe[0] = -q[0] if left == "wall" else q[0]
    qe[-1] = -q[-1] if right == "wall" else q[-1]
    return he, qe


def velocity(h, q, h_dry):
    """ū = q/h where h > h_dry, else 0 [m/s]."""
    wet = h > h_dry
    return np.where(wet, q / np.where(wet, h, 1.0), 0.0)


def limited_faces(v):
    """(v⁻, v⁺): values at the left and right faces of every cell of the ghost-extended array v,
    v^± = v_i ± σ_i/2, with the monotonized-central slope
    σ_i = minmod(2 (v_i − v_{i−1}), (v_{i+1} − v_{i−1})/2, 2 (v_{i+1} − v_i)) (σ = 0 in the
    ghost cells and at extrema). Face values stay between neighbouring cell values (h⁻, h⁺ ≥ 0).
    (MC rather than minmod: measured lower errors on both verification cases, docs.)"""
    back = v[1:-1] - v[:-2]
    ahead = v[2:] - v[1:-1]
    centred = 0.5 * (back + ahead)
    size = np.minimum(np.minimum(2.0 * np.abs(back), 2.0 * np.abs(ahead)), np.abs(centred))
    slope = np.zeros_like(v)
    slope[1:-1] = np.where(back * ahead > 0.0, np.copysign(size, centred), 0.0)
    return v - 0.5 * slope, v + 0.5 * slope


def interface_terms(h, q, phys: Physics, dx: float, cfl: float, left: str,
                    right: str, order: int = 1) -> InterfaceTerms:
    """HLL fluxes, gravity split, friction locking and the admissible Δt for state (h, q).

    order 1: the interface states are the cell values; order 2: MUSCL, MC-limited h and ū
    at the faces, q = h ū there (the locking test and the gravity split use the cell values,
    so the rest states are the same as at order 1)."""
    he, qe = extend_with_ghosts(h, q, left, right)
    ue = velocity(he, qe, phys.h_dry)
    g_cos, alpha = phys.g_cos, phys.alpha
    # K of each (ghost-extended) cell; 1.0 (a scalar: the K = 1 arithmetic unchanged bit for bit)
    k = (phys.earth_pressure.cell_coefficients(ue, he > phys.h_dry)
         if phys.earth_pressure is not None else None)
    kl, kr = (k[:-1], k[1:]) if k is not None else (1.0, 1.0)
    if order == 1:
        hl, hr = he[:-1], he[1:]
        ql, qr = qe[:-1], qe[1:]
        ul, ur = ue[:-1], ue[1:]
    else:
        h_minus, h_plus = limited_faces(he)
        u_minus, u_plus = limited_faces(ue)
        hl, hr = h_plus[:-1], h_minus[1:]
        ul = np.where(hl > phys.h_dry, u_plus[:-1], 0.0)
        ur = np.where(hr > phys.h_dry, u_minus[1:], 0.0)
        ql, qr = hl * ul, hr * ur

    def speeds(hf, uf, af, kf):
        c2 = g_cos * kf * hf
        if alpha == 1.0:
            spread = np.sqrt(c2)
        else:  # thick: α(α−1); tapered (h < h_α, F = a q²/h with a = 1 + (α−1) h/h_α): a² − 1
            spread = np.sqrt(np.where(hf >= phys.alpha_depth, alpha * (alpha - 1.0),
                                      af * af - 1.0) * uf * uf + c2)
        return af * uf - spread, af * uf + spread

    a_l, a_r = phys.shape_factor(hl), phys.shape_factor(hr)
    lm_l, lp_l = speeds(hl, ul, a_l, kl)
    lm_r, lp_r = speeds(hr, ur, a_r, kr)
    s_l = np.minimum(np.minimum(lm_l, lm_r), 0.0)
    s_r = np.maximum(np.maximum(lp_l, lp_r), 0.0)
    dry_r = hr <= phys.h_dry
    dry_l = hl <= phys.h_dry
    if dry_r.any() or dry_l.any():
        s_r = np.where(dry_r, np.maximum(s_r, ul + 2.0 * np.sqrt(g_cos * kl * hl)), s_r)
        s_l = np.where(dry_l, np.minimum(s_l, ur - 2.0 * np.sqrt(g_cos * kr * hr)), s_l)
    width = s_r - s_l
    inv_width = 1.0 / np.where(width > 0.0, width, 1.0)
    k_face = 0.5 * (kl + kr) if k is not None else 1.0
    flux_l = a_l * ql * ul + 0.5 * g_cos * k_face * hl * hl
    flux_r = a_r * qr * ur + 0.5 * g_cos * k_face * hr * hr
    prod = s_l * s_r
    mass_flux = (s_r * ql - s_l * qr + prod * (hr - hl)) * inv_width
    mom_flux = (s_r * flux_l - s_l * flux_r + prod * (qr - ql)) * inv_width
    face_pressure = 0.25 * g_cos * (hl * hl + hr * hr)    # hydrostatic (K = 1), face states
    pressure = 0.5 * g_cos * (k if k is not None else 1.0) * he * he
    hl, hr = he[:-1], he[1:]          # cell values from here on
    ql, qr = qe[:-1], qe[1:]

    # Friction locking (module docstring).
    mu_static = phys.static_friction(he)
    mu_face = np.minimum(mu_static[:-1], mu_static[1:])
    if k is None:
        drive = hr - hl - dx * math.tan(phys.theta)
    else:   # (p_R − p_L)/(g cosθ h̄) − Δx tanθ: K Δh − Δx tanθ for a uniform K
        h_sum = hl + hr
        drive = ((kr * hr * hr - kl * hl * hl) / np.where(h_sum > 0.0, h_sum, 1.0)
                 - dx * math.tan(phys.theta))
    at_rest = (ql == 0.0) & (qr == 0.0)
    if not phys.well_balanced:
        at_rest[:] = False
    locked = at_rest & (np.abs(drive) <= mu_face * dx)
    # A wall reacts to any push into it: only a pull away from it needs friction.
    if left == "wall":
        locked[0] = at_rest[0] and drive[0] >= -mu_face[0] * dx
    if right == "wall":
        locked[-1] = at_rest[-1] and drive[-1] <= mu_face[-1] * dx
    # Between two cells at rest the HLL flux would still diffuse mass, −c (h_R − h_L)/2: no mass
    # crosses such a face and it carries the central thrust (p_L + p_R)/2 (the HLL value at rest
    # with symmetric speeds); if the force beats friction the cells move first, then mass.
    # Earth pressure, non-conservative as Savage & Hutter's −K g cosθ h ∂x h: the HLL flux carries
    # the faces' mean K, and each side sees its own cell's K times the hydrostatic face pressure
    # P̄ = g cosθ (h_L² + h_R²)/4, so a jump of K between cells exerts no force of its own.
    if k is None:
        mom_flux = np.where(at_rest, 0.5 * (pressure[:-1] + pressure[1:]), mom_flux)
        to_left = to_right = mom_flux
    else:
        cell_mean = 0.25 * g_cos * (hl * hl + hr * hr)
        face_pressure = np.where(at_rest, cell_mean, face_pressure)
        mom_flux = np.where(at_rest, k_face * cell_mean, mom_flux)
        to_left = mom_flux + (kl - k_face) * face_pressure
        to_right = mom_flux + (kr - k_face) * face_pressure

    # A cell is held when both its faces are locked; only then do its faces return the at-rest
    # thrust. A cell with one locked face feels the full force (both faces' unlocked terms) and
    # the whole cell's friction decides (no friction counted twice).
    held = np.zeros(he.size, dtype=bool)
    held[1:-1] = locked[:-1] & locked[1:]
    half_gravity = 0.5 * phys.g_sin * dx
    left_flux = np.where(held[:-1], pressure[:-1], to_left - half_gravity * hl)
    right_flux = np.where(held[1:], pressure[1:], to_right + half_gravity * hr)
    mass_flux[at_rest] = 0.0
    if left == "wall":
        mass_flux[0] = 0.0
    if right == "wall":
        mass_flux[-1] = 0.0

    # Δt: CFL on the fastest wave, and positivity of h (coefficients of h_i ≥ 0).
    fastest = max(float(np.max(s_r)), float(-np.min(s_l)))
    out_right = np.where(at_rest, 0.0, s_r * (ul - s_l) * inv_width)[1:]   # face i+½ of cell i
    out_left = np.where(at_rest, 0.0, -s_l * (s_r - ur) * inv_width)[:-1]  # face i−½ of cell i
    if order == 1:   # h_i^{n+1} = (1 − λ(a⁺ + a⁻)) h_i + …
        outflow_rate = float(np.max(out_right + out_left))
    else:            # h_i = (h_i⁻ + h_i⁺)/2: each half needs λ a^± ≤ 1/2
        outflow_rate = 2.0 * float(max(np.max(out_right), np.max(out_left)))
    dt_cfl = dx / fastest if fastest > 0.0 else math.inf
    dt_pos = dx / outflow_rate if outflow_rate > 0.0 else math.inf
    # Order 2: a margin on the positivity bound, so that Heun's second stage (a slightly
    # different state) rarely has to cut Δt and redo the first.
    margin = 1.0 if order == 1 else POSITIVITY_MARGIN
    return InterfaceTerms(mass_flux, left_flux, right_flux, locked,
                          min(cfl * dt_cfl, margin * dt_pos), min(dt_cfl, dt_pos))


def transport(h, q, terms: InterfaceTerms, dx: float, dt: float):
    """(h*, q*): the conservative update with gravity, before friction (module docstring).

    h* is clipped at 0 (round-off of a cell emptied by the step)."""
    ratio = dt / dx
    h_new = h - ratio * (terms.mass_flux[1:] - terms.mass_flux[:-1])
    np.maximum(h_new, 0.0, out=h_new)
    q_star = q - ratio * (terms.left_flux[1:] - terms.right_flux[:-1])
    return h_new, q_star


def friction_step(h_new, q_star, phys: Physics, dt: float):
    """q^{n+1} from q* by the implicit friction over Δt (0 where h^{n+1} ≤ h_dry)."""
    wet = h_new > phys.h_dry
    h_safe = np.where(wet, h_new, 1.0)
    speed_pred = np.abs(q_star) / h_safe
    extra = phys.side_wall.coefficient(h_safe) if phys.side_wall is not None else 0.0
    speed = phys.basal.implicit_speed(speed_pred, h_safe, dt * phys.g_cos, extra)
    return np.where(wet, np.copysign(speed, q_star) * h_new, 0.0)


def update(h, q, terms: InterfaceTerms, phys: Physics, dx: float, dt: float):
    """(h^{n+1}, q^{n+1}) = transport then implicit friction (one forward-Euler step)."""
    h_new, q_star = transport(h, q, terms, dx, dt)
    return h_new, friction_step(h_new, q_star, phys, dt)
