"""The rigid collapse's power budget from its snapshots: where the released energy goes, per mesh (issue 51).

    python studies/benchmarks/rigid_energy_budget.py RUN [RUN ...] --times 0.3 0.4 0.5 0.6 \
        [--eta 1.0 --friction-angle 25.5 --bed-friction-angle 25.5 --wall-friction-angle 10.2 \
         --density 1550 --gravity 9.81 --epsilon 1e-6]

Reads each run's solution.xdmf snapshots (fields/step_*.h5: P1 pressure and velocity at the
vertices, |D| per cell at its midpoint, DG0) — no solver is imported. For the snapshot nearest
each time it prints, per unit width [W/m]:

- the release rate −dE_p/dt, E_p = ∫ ρ g y dA (exact on the triangles; the derivative by the
  central difference over the neighbouring snapshots, a few steps apart),
- dE_k/dt, E_k = ∫ ½ ρ |u|² dA (the vertex velocities, linear on each cell: exact for P1),
- P_plast = ∫ √2 μ_s [p]_+ |D| dA and P_visc = ∫ 2η |D|² dA (``rigid_dx_dissipation``),
- the bed's friction power P_bed = ∫_bed μ_b N |u_x| ds, with N = [p]_+ (``N = p``) and with
  N = [p − σ'_nn]_+ (the model's, ``forms.friction.normal_pressure``), σ'_nn = S D_nn,
  S = 2η + κ(p)/√(|D|² + ε²), κ = √2 μ_s [p]_+, with D the rate of the cell on the edge
  from the vertex velocities (a P1 gradient: the P2 field's is not in the snapshot, whose
  |D| at the midpoint is not used here so that |σ'_nn| ≤ μ_s p + 2η|D| holds as in the model);
- the same on the left wall x = 0 (μ_l, |u_y|),
- the residual −dE_p/dt − dE_k/dt − (P_plast + P_visc + P_bed + P_wall): how well the budget
  closes with these approximations (a check of the reading, not a result);
- ⟨σ'_nn⟩/⟨p⟩ on the sliding bed: the bed's mean deviatoric normal stress against the pressure.

The bed is the boundary edges at y = 0 (bed_angle 0), the wall those at x = 0.
"""
import argparse
import math
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from rigid_dx_dissipation import dissipation, snapshots  # noqa: E402


def read(h5path, names):
    """(x [n, 2], cells [m, 3], p [n], u [n, 2], |D| [m]) of a snapshot."""
    with h5py.File(h5path, "r") as f:
        x = f["/Mesh/mesh/geometry"][:, :2]
        cells = f["/Mesh/mesh/topology"][:]
        p = f[names["pressure"]][:].ravel()
        u = f[names["velocity"]][:][:, :2]
        rate = f[names["strain_rate"]][:].ravel()
    return x, cells, p, u, rate


def cell_areas(x, cells):
    a, b, c = x[cells[:, 0]], x[cells[:, 1]], x[cells[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))


def linear_gradients(x, cells, u):
    """∇u per cell of the linear interpolant of the vertex velocities: [m, 2, 2], G[i, j] = ∂u_i/∂x_j."""
    a, b, c = x[cells[:, 0]], x[cells[:, 1]], x[cells[:, 2]]
    J = np.stack([b - a, c - a], axis=2)            # columns: edge vectors, [m, 2, 2]
    dU = np.stack([u[cells[:, 1]] - u[cells[:, 0]], u[cells[:, 2]] - u[cells[:, 0]]], axis=2)
    return dU @ np.linalg.inv(J)


def potential_energy(x, cells, rho, g):
    """∫ ρ g y dA [J/m]."""
    area = np.abs(cell_areas(x, cells))
    return rho * g * np.sum(area * x[cells][:, :, 1].mean(axis=1))


def kinetic_energy(x, cells, u, rho):
    """∫ ½ ρ |u|² dA of the linear interpolant [J/m] (exact: ∫ of a product of two linears)."""
    area = np.abs(cell_areas(x, cells))
    total = 0.0
    for i in range(2):
        v = u[cells][:, :, i]
        total += np.sum(area / 12.0 * (np.sum(v**2, axis=1) + np.sum(v, axis=1) ** 2))
    return 0.5 * rho * total


def boundary_edges(x, cells, on_line):
    """[(vertex a, vertex b, cell)] of the boundary edges with both ends on_line(x)."""
    local = [(0, 1), (1, 2), (2, 0)]
    edges = np.concatenate([np.sort(cells[:, list(e)], axis=1) for e in local])
    owner = np.tile(np.arange(len(cells)), 3)
    uniq, index, count = np.unique(edges, axis=0, return_index=True, return_counts=True)
    out = []
    for (va, vb), i in zip(uniq[count == 1], index[count == 1]):
        if on_line(x[va]) and on_line(x[vb]):
            out.append((va, vb, owner[i]))
    return out


def wall_power(x, cells, p, u, edges, normal, mu_wall, mu_s, eta, eps):
    """(P with N = [p]_+, P with N = [p − σ'_nn]_+, ∫ σ'_nn ds on sliding edges, ∫ p ds on them)
    along ``edges``; the slip is the tangential velocity (normal (nx, ny) outward)."""
    grad = linear_gradients(x, cells, u)
    n = np.asarray(normal, dtype=float)
    t = np.array([-n[1], n[0]])
    p_only = full = s_nn = p_int = 0.0
    for va, vb, c in edges:
        G = grad[c]
        D = 0.5 * (G + G.T)
        d_nn = n @ D @ n
        length = np.linalg.norm(x[vb] - x[va])
        for v in (va, vb):   # trapezoid rule along the edge
            kappa = math.sqrt(2.0) * mu_s * max(p[v], 0.0)
            secant = 2.0 * eta + kappa / math.sqrt(np.sum(D * D) + eps**2)
            sigma_nn = secant * d_nn
            slip = abs(u[v] @ t)
            p_only += 0.5 * length * mu_wall * max(p[v], 0.0) * slip
            full += 0.5 * length * mu_wall * max(p[v] - sigma_nn, 0.0) * slip
            if slip > 1e-3:
                s_nn += 0.5 * length * sigma_nn
                p_int += 0.5 * length * p[v]
    return p_only, full, s_nn, p_int


def budget(run, t_want, a):
    snaps = snapshots(run)
    i = min(range(len(snaps)), key=lambda k: abs(snaps[k][0] - t_want))
    i = min(max(i, 1), len(snaps) - 2)
    (t0, h0, n0), (t, h5, names), (t1, h1, n1) = snaps[i - 1], snaps[i], snaps[i + 1]
    rho, g = a.density, a.gravity
    energies = []
    for path, nm in ((h0, n0), (h1, n1)):
        x, cells, _, u, _ = read(path, nm)
        energies.append((potential_energy(x, cells, rho, g), kinetic_energy(x, cells, u, rho)))
    release = -(energies[1][0] - energies[0][0]) / (t1 - t0)
    dkin = (energies[1][1] - energies[0][1]) / (t1 - t0)
    mu_s = math.tan(math.radians(a.friction_angle))
    d = dissipation(h5, names, a.eta, mu_s)
    x, cells, p, u, rate = read(h5, names)
    bed = boundary_edges(x, cells, lambda v: abs(v[1]) < 1e-9)
    wall = boundary_edges(x, cells, lambda v: abs(v[0]) < 1e-9)
    mu_b = math.tan(math.radians(a.bed_friction_angle))
    mu_l = math.tan(math.radians(a.wall_friction_angle))
    bed_p, bed_full, bed_snn, bed_pint = wall_power(x, cells, p, u, bed, (0.0, -1.0),
                                                    mu_b, mu_s, a.eta, a.epsilon)
    wall_p, wall_full, _, _ = wall_power(x, cells, p, u, wall, (-1.0, 0.0),
                                         mu_l, mu_s, a.eta, a.epsilon)
    residual = release - dkin - (d["plast"] + d["visc"] + bed_full + wall_full)
    return dict(t=t, release=release, dkin=dkin, plast=d["plast"], visc=d["visc"], bed_p=bed_p,
                bed=bed_full, wall_p=wall_p, wall=wall_full, residual=residual,
                snn_ratio=bed_snn / bed_pint if bed_pint > 0 else math.nan,
                h=d["h"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--times", nargs="+", type=float, default=[0.3, 0.4, 0.5, 0.6])
    ap.add_argument("--eta", type=float, default=1.0)
    ap.add_argument("--friction-angle", type=float, default=25.5)
    ap.add_argument("--bed-friction-angle", type=float, default=25.5)
    ap.add_argument("--wall-friction-angle", type=float, default=10.2)
    ap.add_argument("--density", type=float, default=1550.0)
    ap.add_argument("--gravity", type=float, default=9.81)
    ap.add_argument("--epsilon", type=float, default=1e-6)
    args = ap.parse_args()
    print("run | t [s] | −dE_p/dt | dE_k/dt | P_plast | P_visc | P_bed (N = p) | P_bed | "
          "P_wall (N = p) | P_wall | residual [W/m] | ⟨σ'_nn⟩/⟨p⟩ on the sliding bed")
    for t_want in args.times:
        for run in args.runs:
            b = budget(run, t_want, args)
            print(f"{Path(run).name} | {b['t']:.3f} | {b['release']:.2f} | {b['dkin']:+.2f} | "
                  f"{b['plast']:.2f} | {b['visc']:.2f} | {b['bed_p']:.2f} | {b['bed']:.2f} | "
                  f"{b['wall_p']:.2f} | {b['wall']:.2f} | {b['residual']:+.2f} | "
                  f"{b['snn_ratio']:+.3f}")


if __name__ == "__main__":
    main()
