"""Beverloo fit of the cylindrical silo's sweep (issue 52) and the plots of its report.

    python studies/benchmarks/silo/beverloo_axi.py RUNS_DIR OUT_DIR [SILO_RUN ...]

RUNS_DIR: the sweep's folder (configs/sweeps/beverloo_axi.yaml; each case's run.json and
config.yaml: geometry.orifice_width D, summary.discharge_steady Q [kg/s]). Three fits, each
with one standard deviation from the least-squares covariance (delta method for derived
values):

* the exponent: log Q = log A + n log D (k = 0), n and its uncertainty;
* Beverloo with n = 5/2: Q^(2/5) = (C rho sqrt(g))^(2/5) (D - k d), linear in D: C and k;
* the exponent with k free: Q = A (D - k d)^n by nonlinear least squares (scipy curve_fit).

SILO_RUN: runs (configs/silo_axi.yaml) whose Q(t) is drawn, with the plateau's window.
"""
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.optimize import curve_fit  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from beverloo import cases  # noqa: E402  (the planar sweep's reader: the same run.json keys)

G = 9.81


def power_law(D, Q):
    """n, σ_n, A of log Q = log A + n log D."""
    (n, b), cov = np.polyfit(np.log(D), np.log(Q), 1, cov=True)
    return n, math.sqrt(cov[0, 0]), math.exp(b)


def beverloo(D, Q, rho, d, n=2.5):
    """C, σ_C, k, σ_k of Q = C ρ √g (D − k d)^n with n fixed: Q^(1/n) linear in D."""
    y = Q ** (1.0 / n)
    (s, b), cov = np.polyfit(D, y, 1, cov=True)
    scale = rho * math.sqrt(G)
    C = s ** n / scale
    k = -b / (s * d)
    dC = n * s ** (n - 1) / scale * math.sqrt(cov[0, 0])
    grad = np.array([b / (s * s * d), -1.0 / (s * d)])         # ∂k/∂(s, b)
    return C, dC, k, math.sqrt(grad @ cov @ grad)


def free_exponent(D, Q, d):
    """n, σ_n, k, σ_k, A of Q = A (D − k d)^n (nonlinear least squares in log Q)."""
    def model(D, logA, k, n):
        return logA + n * np.log(np.clip(D - k * d, 1e-12, None))

    p, cov = curve_fit(model, D, np.log(Q), p0=(0.0, 0.0, 2.5))
    err = np.sqrt(np.diag(cov))
    return p[2], err[2], p[1], err[1], math.exp(p[0])


def main():
    runs, out = Path(sys.argv[1]), Path(sys.argv[2])
    out.mkdir(parents=True, exist_ok=True)
    rows = cases(runs)
    D, Q, spread = (np.array([r[i] for r in rows], dtype=float) for i in (0, 1, 2))
    rho, d = rows[0][3], rows[0][4]
    print("| D [m] | steady Q [kg/s] | window [s] | spread | status |")
    print("| --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r[0]:.3f} | {r[1]:.4f} | {r[6][0]:.3f}–{r[6][1]:.3f} | {100 * r[2]:.1f} % | {r[5]} |")
    n, dn, A = power_law(D, Q)
    print(f"power law (k = 0): n = {n:.3f} ± {dn:.3f}")
    C, dC, k, dk = beverloo(D, Q, rho, d)
    print(f"Beverloo n = 5/2: C = {C:.3f} ± {dC:.3f}, k = {k:.2f} ± {dk:.2f} (d = {d:g} m, rho = {rho:g})")
    C0 = float(np.mean(Q / (rho * math.sqrt(G) * D ** 2.5)))
    print(f"C with k = 0, n = 5/2 (mean of Q/(rho sqrt(g) D^5/2)): {C0:.3f}")
    nf, dnf, kf, dkf, Af = free_exponent(D, Q, d)
    print(f"free exponent and k: n = {nf:.3f} ± {dnf:.3f}, k = {kf:.2f} ± {dkf:.2f}")
    small = D <= 0.04
    if small.sum() >= 3:
        ns, dns, _ = power_law(D[small], Q[small])
        print(f"power law over D <= 0.04 m ({small.sum()} points): n = {ns:.3f} ± {dns:.3f}")
    fig, ax = plt.subplots(figsize=(5.5, 4))
    ax.loglog(D, Q, "o", label="steady Q (flux through the orifice)")
    Df = np.linspace(D.min() * 0.9, D.max() * 1.1, 50)
    ax.loglog(Df, A * Df ** n, "-", label=f"Q ∝ D^n (k = 0), n = {n:.3f}±{dn:.3f}")
    ax.loglog(Df, C * rho * math.sqrt(G) * np.clip(Df - k * d, 0, None) ** 2.5, "--",
              label=f"Beverloo 5/2: C = {C:.3f}±{dC:.3f}, k = {k:.2f}±{dk:.2f}")
    ax.loglog(Df, 0.58 * rho * math.sqrt(G) * np.clip(Df - 1.5 * d, 0, None) ** 2.5, ":",
              label="laboratory: C = 0.58, k = 1.5")
    ax.set_xlabel("orifice diameter D [m]")
    ax.set_ylabel("Q [kg/s]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "beverloo_axi.png", dpi=120)
    runs_t = sys.argv[3:]
    if runs_t:
        import csv

        fig, ax = plt.subplots(figsize=(5.5, 4))
        for run in runs_t:
            r = list(csv.DictReader(open(Path(run) / "diagnostics.csv")))
            ax.plot([float(x["t"]) for x in r], [float(x["discharge_rate"]) for x in r],
                    label=Path(run).name)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("Q [kg/s]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(out / "q_axi.png", dpi=120)


if __name__ == "__main__":
    main()
