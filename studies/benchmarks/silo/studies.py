"""Tables and plots of the silo studies (issue 28, report 2026-12-03-silo-studies.md).

    python studies/benchmarks/silo/studies.py steady RUN                      # Q while H halves
    python studies/benchmarks/silo/studies.py beverloo COARSE FINE OUT_DIR    # two resolutions
    python studies/benchmarks/silo/studies.py hopper RUNS OUT_DIR             # Q against beta
    python studies/benchmarks/silo/studies.py friction RUNS OUT_DIR [NEWTONIAN_RUN]

RUN: a silo run directory (diagnostics.csv: discharge_rate, fill_height; run.json). COARSE,
FINE, RUNS: a sweep's ``runs`` folder. Q [kg/(m s)] is the flux of c through the orifice for
the whole silo; H the fill height at the side wall.
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import yaml  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from beverloo import cases, fit  # noqa: E402

from dpcollapse.io.diagnostics import read_diagnostics  # noqa: E402


def _series(run: Path):
    d = read_diagnostics(run / "diagnostics.csv")
    return np.array(d["t"]), np.array(d["discharge_rate"]), np.array(d["fill_height"])


def _config(run: Path) -> dict:
    return yaml.safe_load((run / "config.yaml").read_text())


def halving_window(run: Path):
    """Q over the steady window (run.json's start) up to the time H reaches H0/2 (or the
    end): (t0, t1, H at t0, H at t1, mean Q, std/mean, max and min deviation from the mean)."""
    t, q, h = _series(run)
    s = json.loads((run / "run.json").read_text())["summary"]
    t0 = s["discharge_window"][0]
    h0 = h[0]
    below = np.nonzero(h <= 0.5 * h0)[0]
    t1 = t[below[0]] if below.size else t[-1]
    m = (t >= t0) & (t <= t1)
    mean = q[m].mean()
    return (t0, t1, h[m][0], h[m][-1], mean, q[m].std() / mean, q[m].max() / mean - 1,
            q[m].min() / mean - 1)


def steady(run: Path) -> None:
    t0, t1, ha, hb, mean, spread, up, down = halving_window(run)
    print(f"{run}: window t = {t0:.3f}-{t1:.3f} s, H {ha:.4f} -> {hb:.4f} m "
          f"({100 * (1 - hb / ha):.0f} % lower), Q mean {mean:.2f} kg/(m s), std {100 * spread:.2f} %, "
          f"max {100 * up:+.2f} %, min {100 * down:+.2f} %")


def beverloo(coarse: Path, fine: Path, out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(5.5, 4))
    print("| D [m] | Q, 1 cm cells | Q, 5 mm cells | difference |")
    print("| --- | --- | --- | --- |")
    both = {}
    for runs, label, marker in ((coarse, "1 cm cells", "o"), (fine, "5 mm cells", "s")):
        rows = cases(runs)
        D, Q = np.array([r[0] for r in rows]), np.array([r[1] for r in rows])
        rho, d = rows[0][3], rows[0][4]
        C, dC, k, dk = fit(D, Q, rho, d)
        both[label] = dict(zip(D, Q))
        print(f"<!-- {label}: C = {C:.3f} ± {dC:.3f}, k = {k:.2f} ± {dk:.2f} -->", file=sys.stderr)
        ax.loglog(D, Q, marker, mfc="none", label=f"{label}: C = {C:.3f}±{dC:.3f}, k = {k:.1f}±{dk:.1f}")
        Df = np.linspace(D.min() * 0.9, D.max() * 1.1, 50)
        ax.loglog(Df, C * rho * math.sqrt(9.81) * np.clip(Df - k * d, 0, None) ** 1.5, "-", lw=0.8)
    for D in sorted(both["1 cm cells"]):
        a, b = both["1 cm cells"][D], both["5 mm cells"].get(D, float("nan"))
        print(f"| {D:.3f} | {a:.2f} | {b:.2f} | {100 * (b - a) / b:+.2f} % |")
    ax.set_xlabel("orifice width D [m]")
    ax.set_ylabel("steady Q [kg/(m s)]")
    ax.set_title("Beverloo: Q = C ρ √g (D − k d)^{3/2}", fontsize=9)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "beverloo_two_resolutions.png", dpi=120)


def hopper(runs: Path, out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for run in sorted(p.parent for p in runs.rglob("run.json")):
        s = json.loads((run / "run.json").read_text())["summary"]
        beta = _config(run)["geometry"]["hopper_angle"]
        rows.append((beta, s.get("discharge_steady"), s.get("discharge_spread"),
                     s.get("discharge_window"), s.get("area_drift")))
    rows.sort()
    print("| β [°] | steady Q [kg/(m s)] | window [s] | spread | (∫c + out) drift |")
    print("| --- | --- | --- | --- | --- |")
    for beta, q, sp, w, drift in rows:
        print(f"| {beta:g} | {q:.2f} | {w[0]:.3f}–{w[1]:.3f} | {100 * sp:.1f} % | {drift:.1e} |")
    fig, ax = plt.subplots(figsize=(5, 3.6))
    ax.plot([r[0] for r in rows], [r[1] for r in rows], "o-")
    ax.set_xlabel("hopper half-angle β [° from the vertical]")
    ax.set_ylabel("steady Q [kg/(m s)]")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "hopper_angle.png", dpi=120)


def friction(runs: Path, out: Path, newtonian: Path | None) -> None:
    out.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    print("| μ_s | status, t [s] | Q mean [kg/(m s)] | window (H from → to) | std | max, min | Q/√H std |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    found = []
    for run in sorted(p.parent for p in runs.rglob("run.json")):
        mu = math.tan(math.radians(_config(run)["material"]["friction_angle"]))
        found.append((mu, run, f"μ_s = {mu:.1f}"))
    if newtonian is not None:
        found.append((None, newtonian, "Newtonian, η = "
                      f"{_config(newtonian)['material']['viscosity']:g} Pa s"))
    for mu, run, label in sorted(found, key=lambda f: (f[0] is None, f[0] or 0)):
        info = json.loads((run / "run.json").read_text())
        t, q, h = _series(run)
        t0, t1, ha, hb, mean, spread, up, down = halving_window(run)
        m = (t >= t0) & (t <= t1)
        torricelli = q[m] / np.sqrt(h[m])
        print(f"| {label} | {info['status']}, {t[-1]:.3f} | {mean:.2f} | {t0:.3f}–{t1:.3f} s "
              f"({ha:.3f} → {hb:.3f} m) | {100 * spread:.1f} % | {100 * up:+.1f} %, {100 * down:+.1f} % "
              f"| {100 * torricelli.std() / torricelli.mean():.1f} % |")
        style = "k--" if mu is None else "-"
        ax[0].plot(h / h[0], q / q.max(), style, label=label)
        peak = int(np.argmax(q))
        later = np.arange(q.size) >= peak
        torr = q / np.sqrt(h)
        ax[1].plot((h / h[0])[later], (torr / torr[peak])[later], style, label=label)
    ax[0].set_xlabel("H / H0")
    ax[0].set_ylabel("Q / max Q")
    ax[0].invert_xaxis()
    ax[1].set_xlabel("H / H0")
    ax[1].set_ylabel("(Q/√H) / its value at max Q   (Torricelli: 1)")
    ax[1].invert_xaxis()
    ax[0].set_ylim(0, 1.05)
    ax[1].set_ylim(0.6, 1.8)
    for a in ax:
        a.grid(alpha=0.3)
    ax[0].legend(fontsize=7)
    fig.suptitle("hourglass against clepsydra: the silo, D = 3 cm, 1 cm cells", fontsize=9)
    fig.tight_layout()
    fig.savefig(out / "hourglass_clepsydra.png", dpi=120)


def main() -> int:
    cmd, args = sys.argv[1], [Path(a) for a in sys.argv[2:]]
    if cmd == "steady":
        for run in args:
            steady(run)
    elif cmd == "beverloo":
        beverloo(*args)
    elif cmd == "hopper":
        hopper(*args)
    elif cmd == "friction":
        friction(args[0], args[1], args[2] if len(args) > 2 else None)
    else:
        print(__doc__)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
