"""Beverloo fit of a silo sweep (issue 28) and the plots of the silo report.

    python studies/benchmarks/silo/beverloo.py RUNS_DIR OUT_DIR [SILO_RUN ...]

RUNS_DIR: the sweep's folder (each case's run.json: geometry.orifice_width in its config.yaml,
summary.discharge_steady); the fit Q^(2/3) = (C rho sqrt(g))^(2/3) (D - k d), least squares
with the covariance of the slope and intercept, C and k with one standard deviation (delta
method). SILO_RUN: runs whose Q(t) is drawn against the fill height H(t).
"""
import csv
import json
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import yaml  # noqa: E402


def cases(runs: Path):
    """(D, Q, spread, ρ, d, status, window) of each finished case, sorted by D."""
    out = []
    for run in sorted(p.parent for p in runs.rglob("run.json")):
        info = json.loads((run / "run.json").read_text())
        cfg = yaml.safe_load((run / "config.yaml").read_text())
        s = info.get("summary", {})
        if "discharge_steady" in s:
            out.append((cfg["geometry"]["orifice_width"], s["discharge_steady"],
                        s["discharge_spread"], cfg["material"]["density"],
                        cfg["material"]["grain_diameter"], info["status"],
                        s.get("discharge_window")))
    return sorted(out)


def fit(D, Q, rho, d, g=9.81):
    y = Q ** (2.0 / 3.0)
    (s, b), cov = np.polyfit(D, y, 1, cov=True)
    scale = rho * math.sqrt(g)
    C = s ** 1.5 / scale
    k = -b / (s * d)
    dC = 1.5 * s ** 0.5 / scale * math.sqrt(cov[0, 0])
    grad = np.array([b / (s * s * d), -1.0 / (s * d)])         # ∂k/∂(s, b)
    dk = math.sqrt(grad @ cov @ grad)
    return C, dC, k, dk


def main():
    runs, out = Path(sys.argv[1]), Path(sys.argv[2])
    out.mkdir(parents=True, exist_ok=True)
    rows = cases(runs)
    D, Q, spread = (np.array([r[i] for r in rows]) for i in (0, 1, 2))
    rho, d = rows[0][3], rows[0][4]
    C, dC, k, dk = fit(D, Q, rho, d)
    for r in rows:
        print(f"D = {r[0]:.3f} m  Q = {r[1]:.2f} kg/(m s)  spread {100 * r[2]:.1f} %  {r[5]}")
    print(f"C = {C:.3f} ± {dC:.3f}, k = {k:.2f} ± {dk:.2f}  (d = {d:g} m, rho = {rho:g})")
    fig, ax = plt.subplots(figsize=(5.5, 4))
    ax.loglog(D, Q, "o", label="steady Q (flux through the orifice)")
    Df = np.linspace(D.min() * 0.9, D.max() * 1.1, 50)
    ax.loglog(Df, C * rho * math.sqrt(9.81) * np.clip(Df - k * d, 0, None) ** 1.5, "-",
              label=f"Beverloo C = {C:.2f}±{dC:.2f}, k = {k:.1f}±{dk:.1f}")
    ax.set_xlabel("orifice width D [m]")
    ax.set_ylabel("Q [kg/(m s)]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "beverloo.png", dpi=120)
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for run in sys.argv[3:]:
        r = list(csv.DictReader(open(Path(run) / "diagnostics.csv")))
        H = [float(x["fill_height"]) for x in r]
        q = [float(x["discharge_rate"]) for x in r]
        ax.plot(H, q, label=Path(run).name)
    ax.set_xlabel("fill height H [m]")
    ax.set_ylabel("Q [kg/(m s)]")
    ax.invert_xaxis()
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "q_vs_fill.png", dpi=120)


if __name__ == "__main__":
    main()
