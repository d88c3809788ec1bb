"""The axisymmetric runout law at two resolutions (issue 52; report 2026-12-07-axisymmetric-law).

Usage::

    python studies/benchmarks/axisymmetric/law.py RUN_DIR [RUN_DIR ...] \\
        [--csv docs/figures/column_runout_axisymmetric.csv] \\
        [--png docs/figures/column_runout_axisymmetric.png] \\
        [--planar docs/figures/column_runout_adaptive.csv] \\
        [--previous OLD.csv]

Each RUN_DIR is a ``dpcollapse run configs/column_axi_a*.yaml --set geometry.mesh_size=h
--out RUN_DIR``; ``RUN_DIR.time`` (``/usr/bin/time -f "%U %S %e"``), if present, gives the
CPU seconds. From the last row of diagnostics.csv (a run that is not at rest at its end:
the first row after the kinetic energy's peak below 1e-3 of it, state "settled") and
run.json: (r∞ − r0)/r0 at the project's front (``fronts.py``: the thickness front at
max(3d, ΔX/4), column ``thick_front``) and at the mass front (the furthest node, ``front``),
H_f/r0 (``max_height``), the volume drift (``area`` is the body's volume 2π∫ r dA), the status.

The exponent above a ≈ 2: least squares of ln((r∞ − r0)/r0) on ln a over the runs at rest
with a ≥ 2, per resolution; its standard error from the residuals (n − 2 degrees of
freedom), and the spread between the two resolutions' exponents beside it.

The front read again at other thicknesses (report 2026-12-07-axisymmetric-exponent): a run at
rest leaves its deposit in ``checkpoint.npz`` (the checkpoint of the step it stopped at); its
boundary polygon's thickness front (``scenes.base.thickness_front``, the project's definition)
at the fixed thicknesses ``THRESHOLDS`` (columns ``runout_h<mm>``; NaN for a run read where it
settled or without its checkpoint), so the exponent can be refitted per thickness. Each run
carries its μ_s (tan of ``material.friction_angle``): runs of another friction are another
series. ``--previous`` adds the rows of an earlier CSV whose run directories are gone (a run
of the same name given as RUN_DIR replaces its row); a row without μ_s gets that of the
configs it was run with (0.32 for μ(I), 0.477 for Drucker–Prager: the law report's).

The laboratory's fits, as quoted (the primary papers are closed access; see the report):
Lube et al. 2004, 1.24 a for a ≲ 1.7 and 1.6 a^{1/2} above; Lajeunesse et al. 2004,
1.0 a and 2.0 a^{1/2}, split at a = 3 (the regimes of seed 004). The planar law beside them: the
two-phase model's no-slip columns (``--planar``, thickness front at L0/32).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
from pathlib import Path

import numpy as np
import yaml

#: a from which the power law a^n is fitted ("above a ≈ 2")
FIT_FROM = 2.0
#: fixed front thicknesses h_f [m] at which the deposit is read again (1.5, 3, 6, 12 grains of
#: d = 1.667 mm; 2.5 mm is ΔX/4 at 1 cm, the thinnest the coarse mesh resolves)
THRESHOLDS = (0.0025, 0.005, 0.01, 0.02)
#: μ_s of the rows of an earlier CSV that lack it (the configs of the 2026-12-07 law report)
PREVIOUS_MU_S = {"mu_i": 0.32, "drucker_prager": 0.477}
#: a run not at rest at its end is read at its first row after the kinetic energy's peak
#: with KE below this fraction of the peak ("settled", as runout.py; state "settled")
SETTLED = 1e-3


def lube(a):
    """Lube et al. (2004), cylinders: (r∞ − r0)/r0 = 1.24 a (a ≤ 1.7), 1.6 a^{1/2} above."""
    a = np.asarray(a, dtype=float)
    return np.where(a <= 1.7, 1.24 * a, 1.6 * np.sqrt(a))


def lajeunesse(a):
    """Lajeunesse et al. (2004), cylinders: 1.0 a and 2.0 a^{1/2} (the constants as quoted),
    the regimes split at a = 3 (seed 004: ∝ a for a ≤ 3, ∝ a^{1/2} above)."""
    a = np.asarray(a, dtype=float)
    return np.where(a <= 3.0, a, 2.0 * np.sqrt(a))


def threshold_key(h: float) -> str:
    return f"runout_h{1e3 * h:g}mm"


def deposit_fronts(run: Path, r0: float, step: int, thresholds=THRESHOLDS) -> dict:
    """(r_f(h_f) − r0)/r0 of the deposit in the run's checkpoint at each thickness h_f (the
    outer boundary loop's thickness front); NaN unless the checkpoint is of ``step``."""
    out = {threshold_key(h): math.nan for h in thresholds}
    path = run / "checkpoint.npz"
    if not path.exists():
        return out
    from dpcollapse.geometry.polygon import chain_loops  # (dolfinx: only when there is one)
    from dpcollapse.scenes.base import thickness_front
    with np.load(path, allow_pickle=False) as z:
        if json.loads(str(z["state"])).get("step") != step:
            return out
        x, edges, tags = z["mesh_x"], z["mesh_edges"], z["mesh_edge_tags"]
    points = chain_loops(x[edges], tags)[0].points
    for h in thresholds:
        out[threshold_key(h)] = (thickness_front(points, h) - r0) / r0
    return out


def run_row(run: Path) -> dict:
    """One run's deposit: a, h, bed, status and the measures of its last row."""
    cfg = yaml.safe_load((run / "config.yaml").read_text())
    g = cfg["geometry"]
    r0, h0 = g["base_length"], g["height"]
    info = json.loads((run / "run.json").read_text()) if (run / "run.json").exists() else {}
    rows = list(csv.DictReader((run / "diagnostics.csv").open()))
    first = rows[0]
    status = info.get("status", "unknown")
    last, state = rows[-1], "final"
    if status != "at_rest":     # still creeping at the end: the first settled row instead
        ke = [float(r["kinetic_energy"]) for r in rows]
        peak = max(range(len(ke)), key=ke.__getitem__)
        settled = next((r for r, k in zip(rows[peak:], ke[peak:]) if k < SETTLED * ke[peak]), None)
        if settled is not None:
            last, state = settled, "settled"
    grav = cfg["material"].get("gravity", 9.81)
    friction = cfg["material"].get("friction_angle")
    mu_s = math.tan(math.radians(friction)) if friction is not None else math.nan
    time_file = run.parent / (run.name + ".time")
    cpu = math.nan
    if time_file.exists():
        fields = time_file.read_text().split()
        try:
            cpu = float(fields[-3]) + float(fields[-2])
        except (IndexError, ValueError):      # killed before time wrote its line
            pass
    return {
        "run": run.name,
        "bed": cfg.get("boundary", {}).get("bed_condition", "no_slip"),
        "rheology": cfg["material"]["rheology"],
        "mu_s": mu_s,
        "a": round(h0 / r0, 9),    # 0.3/0.1 is 2.9999999999999996: one key per a
        "mesh_size": g["mesh_size"],
        "status": status,
        "state": state,
        "t": float(last["t"]),
        "scaled_time": float(last["t"]) * math.sqrt(grav / h0),
        "thickness_runout": (float(last["thick_front"]) - r0) / r0,
        "mass_runout": (float(last["front"]) - r0) / r0,
        "height": float(last["max_height"]) / r0,
        "volume_drift": (float(last["area"]) - float(first["area"])) / float(first["area"]),
        "steps": int(float(last["step"])),
        "remeshes": int(float(last["remeshes"])),
        "surgeries": int(float(last.get("surgeries") or 0)),
        "cpu": cpu,
        **(deposit_fronts(run, r0, int(float(last["step"]))) if state == "final"
           else {threshold_key(h): math.nan for h in THRESHOLDS}),
    }


def cone_factor(a: float, runout: float, height: float) -> float:
    """φ = V/(π R² H_f) of the deposit (a cone: 1/3): its volume V = π r0² H0 over the
    cylinder of its front radius R = r0 (1 + runout) and its height H_f = height·r0, i.e.
    φ = a/((1 + runout)² height). The volume ties R to H_f and φ:
    R/r0 = (a/(φ H_f/r0))^{1/2}, so R/r0 ∝ a^{1/2} exactly when H_f/r0 and φ are constant."""
    return a / ((1.0 + runout) ** 2 * height)


def previous_rows(path: Path) -> list[dict]:
    """The rows of an earlier CSV, typed as ``run_row``'s (the columns it lacks NaN; μ_s
    from ``PREVIOUS_MU_S``)."""
    ints = ("steps", "remeshes", "surgeries")
    text = ("run", "bed", "rheology", "status", "state")
    out = []
    for r in csv.DictReader(path.open()):
        row = {k: (v if k in text else int(float(v)) if k in ints else float(v or "nan"))
               for k, v in r.items()}
        row.setdefault("mu_s", PREVIOUS_MU_S.get(row["rheology"], math.nan))
        for h in THRESHOLDS:
            row.setdefault(threshold_key(h), math.nan)
        out.append(row)
    return out


def series(row: dict) -> str:
    """The law and its friction: "mu_i μ_s=0.32", "drucker_prager μ_s=0.477"."""
    return f"{row['rheology']} μ_s={row['mu_s']:.3g}"


def usable(row: dict) -> bool:
    """A deposit to compare: at rest, or read where it settled (not a failed run's last row)."""
    return row["status"] == "at_rest" or row["state"] == "settled"


def power_fit(a, y) -> tuple[float, float, float]:
    """(prefactor, exponent, standard error of the exponent) of y = c a^n by least squares
    in logs; the error NaN for two points."""
    x, z = np.log(np.asarray(a, float)), np.log(np.asarray(y, float))
    A = np.vstack([x, np.ones_like(x)]).T
    (n, lnc), res, *_ = np.linalg.lstsq(A, z, rcond=None)
    dof = len(x) - 2
    if dof <= 0:
        return math.exp(lnc), float(n), math.nan
    s2 = float(np.sum((z - A @ np.array([n, lnc])) ** 2)) / dof
    return math.exp(lnc), float(n), math.sqrt(s2 / float(np.sum((x - x.mean()) ** 2)))


def planar_law(path: Path, sweep: str = "no slip, L0/32") -> tuple[np.ndarray, np.ndarray]:
    rows = [r for r in csv.DictReader(path.open()) if r["sweep"] == sweep]
    return (np.array([float(r["a"]) for r in rows]),
            np.array([float(r["thickness_front"]) for r in rows]))


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("runs", nargs="+", type=Path)
    p.add_argument("--csv", type=Path)
    p.add_argument("--png", type=Path)
    p.add_argument("--planar", type=Path)
    p.add_argument("--previous", type=Path)
    args = p.parse_args(argv)
    new = [run_row(r) for r in args.runs]
    names = {r["run"] for r in new}
    old = [r for r in previous_rows(args.previous) if r["run"] not in names] if args.previous else []
    keys = list(new[0])
    rows = sorted(([{k: r.get(k, math.nan) for k in keys} for r in old]) + new,
                  key=lambda r: (r["rheology"], r["mu_s"], r["bed"], r["mesh_size"], r["a"]))
    for r in rows:
        r["cone_factor"] = cone_factor(r["a"], r["thickness_runout"], r["height"])
    keys.append("cone_factor")
    print("| " + " | ".join(keys) + " | Lube |")
    print("| --- " * (len(keys) + 1) + "|")
    for r in rows:
        cells = [f"{v:.3g}" if isinstance(v, float) else str(v) for v in r.values()]
        print("| " + " | ".join(cells) + f" | {float(lube(r['a'])):.2f} |")
    if args.csv:
        with args.csv.open("w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=keys)
            w.writeheader()
            for r in rows:
                w.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in r.items()})
    # the two resolutions side by side: per (law, μ_s, bed, a) the coarser and the finer run
    by_a = {}
    for r in rows:
        if usable(r):     # a failed run (exit 3, 4) is listed, not compared
            by_a.setdefault((series(r), r["bed"], r["a"]), []).append(r)
    levels = {}
    print()
    for (law, bed, a), rs in sorted(by_a.items()):
        rs = sorted(rs, key=lambda r: -r["mesh_size"])
        for name, r in zip(("coarse", "fine") if len(rs) == 2 else ("coarse",), rs):
            levels.setdefault((law, bed, name), []).append(r)
        if len(rs) == 2:
            c, f = rs
            for key in ("thickness_runout", "height", "mass_runout"):
                print(f"{law}, {bed}, a = {a:g}: {key} {c[key]:.3f} (h = {c['mesh_size']:g}) vs "
                      f"{f[key]:.3f} (h = {f['mesh_size']:g}): "
                      f"{100 * (c[key] - f[key]) / f[key]:+.1f} %")
    # the exponent above a ≈ 2, per level (coarse: the coarser run of each a; fine: the finer)
    print()
    for (law, bed, name), rs in levels.items():
        rest = [r for r in rs if r["a"] >= FIT_FROM]
        for key in ("thickness_runout", "mass_runout", "height", "cone_factor",
                    *map(threshold_key, THRESHOLDS)):
            have = [r for r in rest if np.isfinite(r[key])]
            if len(have) >= 2 and (not key.startswith("runout_h") or have == rest):
                c, n, se = power_fit([r["a"] for r in have], [r[key] for r in have])
                fitted = ", ".join(f"{r['a']:g} ({1e3 * r['mesh_size']:g} mm)" for r in have)
                print(f"{law}, {bed}, {name}, {key}: {c:.3f} a^{n:.3f} ± {se:.3f} (a = {fitted})")
    if args.png:
        plot(rows, args.png, args.planar)


def plot(rows, png: Path, planar: Path | None) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13.0, 5.4), width_ratios=(1.25, 1))
    aa = np.geomspace(0.3, 14, 200)
    ax.plot(aa, lube(aa), "k-", lw=1, label="Lube et al. 2004: 1.24a, 1.6a$^{1/2}$ (cylinders)")
    ax.plot(aa, lajeunesse(aa), "k--", lw=1,
            label="Lajeunesse et al. 2004: a, 2.0a$^{1/2}$ (cylinders)")
    for r in filter(usable, rows):
        law = "μ(I)" if r["rheology"] == "mu_i" else "Drucker–Prager"
        standard = abs(r["mu_s"] - PREVIOUS_MU_S.get(r["rheology"], math.nan)) < 1e-3
        if r["rheology"] == "mu_i":
            color = "C0" if r["bed"] == "no_slip" else "C2"
            marker = "o" if r["bed"] == "no_slip" else "^"
        else:
            color = "C7" if r["bed"] == "no_slip" else "C1"
            marker = "D" if r["bed"] == "no_slip" else "s"
        if not standard:    # another friction: the same marker, small, a colour per μ_s
            color = "C4" if r["rheology"] == "mu_i" else ("C9" if r["mu_s"] < 0.4 else "k")
        fine = r["mesh_size"] < 0.0099
        style = dict(color=color, mfc=color if fine else "none", ms=4.5 if fine or not standard else 8)
        if r["a"] >= 1:     # the cone factor where H_f has saturated (a = 0.5: the top unmoved)
            bx.plot(r["a"], r["cone_factor"], marker, **style)
        ax.plot(r["a"], r["thickness_runout"], marker, **style,
                label=f"cylinder, {law}" + ("" if standard else f" μ_s = {r['mu_s']:.2f}")
                      + f", {r['bed'].replace('_', ' ')} bed, "
                      f"{'fine (5 / 7.5 mm)' if fine else 'h = 1 cm'}")
    if planar is not None and planar.exists():
        a, y = planar_law(planar)
        ax.plot(a, y, "x:", color="C3", label="planar column (two-phase, no slip, L0/32)")
        ax.plot(aa, np.where(aa <= 1.8, 1.2 * aa, np.where(aa >= 2.8, 1.9 * aa ** (2 / 3), np.nan)),
                "-", color="C3", lw=0.8, alpha=0.6, label="Lube et al. 2005 (planar): 1.2a, 1.9a$^{2/3}$")
    handles, labels = ax.get_legend_handles_labels()
    unique = dict(zip(labels, handles))
    ax.legend(unique.values(), unique.keys(), fontsize=6, loc="upper left")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("aspect ratio a = H0/r0 (planar: H0/L0)")
    ax.set_ylabel("runout (r∞ − r0)/r0 at the thickness front")
    ax.set_title("(a) Cylindrical columns (moving mesh) against the laboratory", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    # (b) the deposit's shape: φ = V/(π R² H_f); the laboratory's fits read with H_f/r0 = 0.74
    ab = np.geomspace(1.71, 12, 100)   # above the linear regimes
    bx.plot(ab, cone_factor(ab, lube(ab), 0.74), "k-", lw=1,
            label="Lube et al.'s fit with H$_f$/r0 = 0.74")
    ab = np.geomspace(3.01, 12, 100)
    bx.plot(ab, cone_factor(ab, lajeunesse(ab), 0.74), "k--", lw=1,
            label="Lajeunesse et al.'s fit with H$_f$/r0 = 0.74")
    bx.axhline(1 / 3, color="0.6", lw=0.8, ls=":", label="a cone (1/3)")
    bx.set_xscale("log")
    bx.set_yscale("log")
    bx.set_xlabel("aspect ratio a = H0/r0")
    bx.set_ylabel("cone factor φ = V/(π R² H$_f$) at the thickness front")
    bx.set_title("(b) The deposit's shape: R/r0 = (a/(φ H$_f$/r0))$^{1/2}$", fontsize=10)
    bx.legend(fontsize=7, loc="lower left")
    bx.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(png, dpi=120)


if __name__ == "__main__":
    main()
