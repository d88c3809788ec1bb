"""Viscous and plastic dissipation of rigid-collapse snapshots, and how thin the shear zone is (issue 51).

    python studies/benchmarks/rigid_dx_dissipation.py RUN [RUN ...] --times 0.3 0.45 0.55 \
        [--eta 1.0 --friction-angle 25.5]

Reads each run's solution.xdmf snapshots (fields/step_*.h5: the P1 pressure at the vertices,
|D| = √(D:D) per cell, DG0), the snapshot nearest each time, and prints per unit width

- P_visc = ∫ 2η |D|² dA   [W/m]  (the Newtonian part of the drained Drucker–Prager law),
- P_plast = ∫ √2 μ_s [p]_+ |D| dA [W/m]  (κ(p) |D|, the rate-independent part),
- the largest |D| [1/s], and the area [cm²] of the cells above half of it,
- the share of P_visc carried by the cells with |D| above 20 1/s.

The band argument: a shear zone one cell wide carries a velocity jump Δu over h, so its
viscous power 2η(Δu/2h)² h ∝ η Δu²/h grows as h shrinks, while its plastic power
κ Δu/2 does not depend on h; this measures whether the fine runs show that.
"""
import argparse
import math
import re
from pathlib import Path

import h5py
import numpy as np


def snapshots(run):
    """[(t, h5 path, {field name: dataset})] of the run's solution.xdmf, in time order."""
    text = (Path(run) / "solution.xdmf").read_text()
    out = []
    for block in text.split('<Grid Name="step_')[1:]:
        t = float(re.search(r'<Time Value="([^"]+)"', block).group(1))
        paths = re.findall(r">(fields/step_\d+\.h5):([^<]+)<", block)
        names = {key.split("/")[2] if key.startswith("/Function/") else key: key
                 for _, key in paths}
        out.append((t, Path(run) / paths[0][0], names))
    return out


def dissipation(h5path, names, eta, mu_s):
    with h5py.File(h5path, "r") as f:
        x = f["/Mesh/mesh/geometry"][:, :2]
        cells = f["/Mesh/mesh/topology"][:]
        p = f[names["pressure"]][:].ravel()
        rate = f[names["strain_rate"]][:].ravel()
    a, b, c = x[cells[:, 0]], x[cells[:, 1]], x[cells[:, 2]]
    area = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                        - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))
    p_cell = np.maximum(p[cells].mean(axis=1), 0.0)
    visc = 2.0 * eta * rate**2 * area
    plast = math.sqrt(2.0) * mu_s * p_cell * rate * area
    top = rate.max()
    return dict(visc=visc.sum(), plast=plast.sum(), max_rate=top,
                band_area=area[rate > 0.5 * top].sum(),
                fast_share=visc[rate > 20.0].sum() / max(visc.sum(), 1e-300),
                h=math.sqrt(4.0 * np.median(area) / math.sqrt(3.0)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--times", nargs="+", type=float, default=[0.3, 0.45, 0.55])
    ap.add_argument("--eta", type=float, default=1.0)
    ap.add_argument("--friction-angle", type=float, default=25.5)
    args = ap.parse_args()
    mu_s = math.tan(math.radians(args.friction_angle))
    print("run | t [s] | median cell edge [cm] | P_visc [W/m] | P_plast [W/m] | "
          "P_visc/P_plast | max |D| [1/s] | area |D| > max/2 [cm²] | P_visc share |D| > 20")
    for t_want in args.times:
        for run in args.runs:
            t, h5, names = min(snapshots(run), key=lambda s: abs(s[0] - t_want))
            d = dissipation(h5, names, args.eta, mu_s)
            print(f"{Path(run).name} | {t:.3f} | {d['h'] * 100:.2f} | {d['visc']:.2f} | "
                  f"{d['plast']:.2f} | {d['visc'] / d['plast']:.3f} | {d['max_rate']:.1f} | "
                  f"{d['band_area'] * 1e4:.2f} | {d['fast_share']:.2f}")


if __name__ == "__main__":
    main()
