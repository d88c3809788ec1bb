"""The geometric (PLIC) interface flux of the volume fraction c (``model.interface_flux:
geometric``), in place of the algebraic compression.

In each mixed cell K (ε < c_K < 1 − ε) the interface is a straight line n·x = s with n the
unit normal out of the grains, n = −∇c̄/|∇c̄| (c̄ the vertex average of c, P1, from the start of
the step: ``fraction._VertexAverage``; a Youngs-type normal), placed so that the granular
part {x ∈ K : n·x ≤ s} has the area c_K a_K (a_K the cell's area) — closed form per triangle
(``plane_constant``). Through an interior facet f of net volume rate Φ_f = ∫_f u·n ds from
the donor D, a sub-step h moves the volume V = |Φ_f| h; the donor region is the strip of D
along f of that share of D, ρ = V/|D| (the triangle cut parallel to f: the part beyond the
cut is D scaled by λ = √(1 − ρ) about the vertex opposite f), and the granular flux is::

    G_f = g_f Φ_f,   g_f = (c_D a_D − A(λD, n_D, s_D)) / (ρ a_D)

with A(T, n, s) the area of T below the line (``area_below``): the granular share of the
swept strip (the strip normal to the facet; the tangential velocity is not traced). A cell
that is not mixed, or whose ∇c̄ vanishes, has g = c_D (the upwind flux).

Bounds: the fluxes are limited by Zalesak's flux-corrected transport towards the upwind
flux L_f = Φ_f⁺ c_i − Φ_f⁻ c_j: F_f = L_f + α_f (G_f − L_f) with α_f ∈ [0, 1] the largest
that keeps every cell within [0, 1] given the upwind update (``limit``). Each facet's flux is
one number for both cells (computed from the same values on either side, exactly negated),
so Σ_K |K| c_K changes only by the boundary's upwind outflow, to round-off.

Under MPI the rows of the owned cells hold every facet of theirs; the ghost cells' c, c̄ and
geometry are local, and the limiter's R± of the ghost cells come by one forward scatter.
"""

from __future__ import annotations

import numpy as np

from dpcollapse import compat
from dpcollapse.models.two_phase.fluxes import local_csr

#: c within this of 0 or 1 is not a mixed cell (no reconstruction: the upwind value)
MIXED = 1.0e-6
#: |∇c̄| below this (1/m) gives no interface normal
FLAT = 1.0e-12


def _sorted_projections(p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    p = np.sort(p, axis=1)
    return p[:, 0], p[:, 1], p[:, 2]


def area_fraction_below(p: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The share of a triangle with vertex projections p (N, 3) onto a unit normal n that
    lies in n·x ≤ s (N,): piecewise quadratic in s::

        (s − p₁)²/((p₂ − p₁)(p₃ − p₁))         p₁ ≤ s ≤ p₂
        1 − (p₃ − s)²/((p₃ − p₁)(p₃ − p₂))     p₂ ≤ s ≤ p₃      (p₁ ≤ p₂ ≤ p₃ sorted)
    """
    p1, p2, p3 = _sorted_projections(p)
    span = np.maximum(p3 - p1, 1e-300)
    low = (s - p1) ** 2 / np.maximum((p2 - p1) * span, 1e-300)
    high = 1.0 - (p3 - s) ** 2 / np.maximum((p3 - p2) * span, 1e-300)
    share = np.where(s <= p2, low, high)
    return np.clip(np.where(s <= p1, 0.0, np.where(s >= p3, 1.0, share)), 0.0, 1.0)


def plane_constant(p: np.ndarray, c: np.ndarray) -> np.ndarray:
    """s such that the share ``c`` of the triangle (projections p (N, 3)) lies in n·x ≤ s:
    the inverse of ``area_fraction_below``::

        s = p₁ + √(c (p₂ − p₁)(p₃ − p₁))          c ≤ c* = (p₂ − p₁)/(p₃ − p₁)
        s = p₃ − √((1 − c)(p₃ − p₁)(p₃ − p₂))     c ≥ c*
    """
    p1, p2, p3 = _sorted_projections(p)
    c = np.clip(c, 0.0, 1.0)
    span = p3 - p1
    knee = (p2 - p1) / np.maximum(span, 1e-300)
    low = p1 + np.sqrt(c * (p2 - p1) * span)
    high = p3 - np.sqrt((1.0 - c) * span * (p3 - p2))
    return np.where(c <= knee, low, high)


def interface_normals(points: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n (N, 2), has_normal (N,)): the unit normal −∇c̄/|∇c̄| of each triangle from its
    vertex ``points`` (N, 3, 2) and the P1 values c̄ there (N, 3); False where |∇c̄| ≤ FLAT."""
    d1, d2 = points[:, 1] - points[:, 0], points[:, 2] - points[:, 0]
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    v1, v2 = values[:, 1] - values[:, 0], values[:, 2] - values[:, 0]
    gx = (v1 * d2[:, 1] - v2 * d1[:, 1]) / det
    gy = (v2 * d1[:, 0] - v1 * d2[:, 0]) / det
    size = np.hypot(gx, gy)
    ok = size > FLAT
    safe = np.where(ok, size, 1.0)
    return np.stack([-gx / safe, -gy / safe], axis=1), ok


def strip_fraction(triangles, apex, normal, s, c, rho, mixed):
    """g: the granular share of the strip of each donor triangle (N, 3, 2) along the facet
    opposite ``apex`` (N, 2) that holds the share ``rho`` (N,) of the cell, for the interface
    n·x = s of ``normal`` (N, 2), ``s`` (N,); c (N,) where not ``mixed`` (N,)."""
    lam = np.sqrt(np.clip(1.0 - rho, 0.0, 1.0))
    p = np.einsum("nkd,nd->nk", triangles, normal)
    pa = np.einsum("nd,nd->n", apex, normal)[:, None]
    far = area_fraction_below(pa + lam[:, None] * (p - pa), s) * lam ** 2   # share of K
    whole = area_fraction_below(p, s)                                       # = c (rebuilt)
    g = (whole - far) / np.maximum(rho, 1e-300)
    g = np.clip(g, 0.0, 1.0)
    return np.where(mixed & (rho > 0), g, c)


def limit(low_flux, high_flux, rows, columns, c_low, capacity, n_owned, ratio_of):
    """Zalesak's limiter on the pair fluxes (rates, i = rows → j = columns) given the upwind
    update c_low of the owned cells and their capacity |K|/h: α_ij the largest in [0, 1]
    with c in [0, 1]. ``ratio_of(r_plus, r_minus)`` brings the owned cells' R± to every local
    cell (ghost update); returns L + α (G − L)."""
    anti = high_flux - low_flux
    gain = np.bincount(rows, weights=np.maximum(-anti, 0.0), minlength=n_owned)
    loss = np.bincount(rows, weights=np.maximum(anti, 0.0), minlength=n_owned)
    room = np.maximum(1.0 - c_low, 0.0) * capacity
    held = np.maximum(c_low, 0.0) * capacity
    r_plus = np.where(gain > room, room / np.maximum(gain, 1e-300), 1.0)
    r_minus = np.where(loss > held, held / np.maximum(loss, 1e-300), 1.0)
    r_plus, r_minus = ratio_of(r_plus, r_minus)
    alpha = np.where(anti > 0.0, np.minimum(r_minus[rows], r_plus[columns]),
                     np.minimum(r_plus[rows], r_minus[columns]))
    return low_flux + alpha * anti


class GeometricFluxes:
    """The net facet fluxes Φ_ij of one step's velocity (``assemble``) and the sub-step's
    residual ∫_∂K F ds of the owned cells with the geometric, limited fluxes (``residual``).

    ``triangles`` (local cells incl. ghosts, in dof order, (N, 3, 2)), ``nodes`` their vertex
    ids (N, 3), ``volume`` |K| of every local cell (weighted by 2πr if axisymmetric),
    ``scatter(values)``: owned values → every local cell's."""

    def __init__(self, net_form, index_map, triangles, nodes, volume, scatter):
        self._form = net_form
        self._mat = compat.create_matrix(net_form)
        self.index_map = index_map
        self._n = index_map.size_local
        self._n_local = self._n + index_map.num_ghosts
        self.triangles, self.nodes, self.volume = triangles, nodes, volume
        d1, d2 = triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
        self.area = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
        self._scatter = scatter
        self.normal = np.zeros((self._n_local, 2))
        self.has_normal = np.zeros(self._n_local, dtype=bool)
        self.reconstruct = True     # False: g = c everywhere (the upwind flux, for checks)
        self._pairs = None

    def assemble(self) -> None:
        """Φ_ij for the current velocity (once per step) and each pair's apexes."""
        indptr, columns, values = local_csr(self._mat, self._form, self.index_map)
        rows = np.repeat(np.arange(self._n), np.diff(indptr))
        off = rows != columns
        rows, columns, flux = rows[off], columns[off], values[off]
        self._pairs = (rows, columns, flux, self._apex(rows, columns), self._apex(columns, rows))

    def _apex(self, cells, others) -> np.ndarray:
        """The vertex of each of ``cells`` not shared with the facet neighbour in ``others``."""
        mine, theirs = self.nodes[cells], self.nodes[others]
        alone = ~(mine[:, :, None] == theirs[:, None, :]).any(axis=2)       # (P, 3)
        k = np.argmax(alone, axis=1)
        return self.triangles[cells, k]

    def set_normals(self, vertex_points: np.ndarray, vertex_values: np.ndarray) -> None:
        """The interface normals of every local cell from c̄ at its vertices."""
        self.normal, self.has_normal = interface_normals(vertex_points, vertex_values)

    def _share(self, donor, apex, c, s, mixed, moved):
        """g of the pairs whose ``donor`` is mixed (c elsewhere: the upwind value)."""
        g = c[donor]
        at = np.nonzero(mixed[donor])[0]
        if len(at):
            d = donor[at]
            rho = np.clip(moved[at] / self.volume[d], 0.0, 1.0)
            g[at] = strip_fraction(self.triangles[d], apex[at], self.normal[d], s[d], c[d], rho,
                                   np.ones(len(at), dtype=bool))
        return g

    def high_order(self, c: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
        """(L, G) of the pairs: the upwind and the geometric flux rates i → j."""
        rows, columns, flux, apex_i, apex_j = self._pairs
        plus, minus = np.maximum(flux, 0.0), np.maximum(-flux, 0.0)
        low = plus * c[rows] - minus * c[columns]
        if not self.reconstruct:
            return low, low
        mixed = (c > MIXED) & (c < 1.0 - MIXED) & self.has_normal
        cut = np.nonzero(mixed)[0]
        s = np.zeros(len(c))
        p = np.einsum("nkd,nd->nk", self.triangles[cut], self.normal[cut])
        s[cut] = plane_constant(p, c[cut])
        moved = np.abs(flux) * h
        g_i = self._share(rows, apex_i, c, s, mixed, moved)
        g_j = self._share(columns, apex_j, c, s, mixed, moved)
        return low, plus * g_i - minus * g_j

    def residual(self, c: np.ndarray, h: float, boundary: np.ndarray) -> np.ndarray:
        """∫_∂K F ds of the owned cells for the local values c (owned and ghosts) over a
        sub-step h; ``boundary`` the owned cells' ∫_∂Ω (u·n)⁺ ds (upwind outflow c_K)."""
        rows, columns = self._pairs[0], self._pairs[1]
        n = self._n
        low, high = self.high_order(c, h)
        out_low = np.bincount(rows, weights=low, minlength=n) + boundary * c[:n]
        capacity = self.volume[:n] / h
        c_low = c[:n] - out_low / capacity
        flux = limit(low, high, rows, columns, c_low, capacity, n, self._scatter)
        return np.bincount(rows, weights=flux, minlength=n) + boundary * c[:n]

    def destroy(self) -> None:
        self._mat.destroy()
