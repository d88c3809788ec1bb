"""The kinetic energy the light fluid and the grains carry in a two-phase run, at one time.

    python studies/benchmarks/two_phase/light_energy.py T RHO_A RUN [RUN ...]

From the output nearest time T (fields/step_*.h5: the velocity at the vertices, c per cell):
per cell the mean of |u|² over its vertices, E_a = ½ ρ_a ∫ (1 − c) |u|², E_g = ½ ρ_g ∫ c |u|²
(ρ_g from the run's config.yaml), the largest and the mean light-fluid speed (cells with
c < 0.01). A physical light fluid displaced by the grains carries ~ρ_a/ρ_g of their energy.
"""

import glob
import sys

import h5py
import numpy as np
import yaml
from yield_weighting_heap import field


def nearest(run, when):
    best = None
    for name in sorted(glob.glob(f"{run}/fields/step_*.h5")):
        with h5py.File(name) as f:
            t, _ = field(f, "volume_fraction")
        if best is None or abs(t - when) < abs(best[0] - when):
            best = (t, name)
    return best


def energies(run, when, rho_a):
    rho_g = yaml.safe_load(open(f"{run}/config.yaml"))["material"]["density"]
    t, name = nearest(run, when)
    with h5py.File(name) as f:
        x = f["Mesh/mesh/geometry"][:]
        cells = f["Mesh/mesh/topology"][:]
        _, c = field(f, "volume_fraction")
        _, u = field(f, "velocity")
    c = c[:, 0]
    c = c[cells].mean(axis=1) if len(c) == len(x) else c
    p = x[cells][:, :, :2]
    area = 0.5 * np.abs((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                        - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
    u2 = (u[cells][:, :, :2] ** 2).sum(axis=2).mean(axis=1)
    light = 0.5 * rho_a * ((1 - c) * u2 * area).sum()
    grains = 0.5 * rho_g * (c * u2 * area).sum()
    air = c < 0.01
    mean = np.sqrt((u2 * (1 - c) * area).sum() / ((1 - c) * area).sum())
    print(f"{run}: t = {t:.3f} s, light fluid {light:.3f} J/m ({100 * light / grains:.1f} % of the "
          f"grains' {grains:.3f} J/m), light-fluid speed max {np.sqrt(u2[air].max()):.1f} m/s, "
          f"mean {mean:.2f} m/s")


if __name__ == "__main__":
    when, rho_a = float(sys.argv[1]), float(sys.argv[2])
    for run in sys.argv[3:]:
        energies(run, when, rho_a)
