"""Plots of the column-collapse report (docs/benchmarks/2026-12-01-column.md).

    python studies/benchmarks/column_plots.py front RUN_DIR OUT.png      # front, top height vs t sqrt(g/H0)
    python studies/benchmarks/column_plots.py law SWEEP_DIR OUT.png [T]  # runout law from sweep.csv
                                                              # (T: at t sqrt(g/H0) = T instead of the end)
    python studies/benchmarks/column_plots.py fraction OUT.png RUN_DIR...  # two_phase: c at the last output
    python studies/benchmarks/column_plots.py laws OUT.png T NAME=SWEEP_DIR...  # several sweeps in one plot,
                                                              # fronts at t sqrt(g/H0) = T
                                                              # (T = end: each run's last step);
                                                              # writes the points to OUT.csv
    python studies/benchmarks/column_plots.py table OUT.png LAW.csv      # the same plot from such a table

``law`` also prints the fitted power laws ΔL/L0 = c a^n on a ≤ 3 and a ≥ 3 and
H_f/L0 = c a^n on a ≥ 0.7, per bed condition and mesh size, from the cases at rest or at
their end time (drawn open). With T the fronts and the height are read from each run's
diagnostics.csv at the first step with t sqrt(g/H0) ≥ T (g = 9.81 m/s², the configs' value),
for a model whose deposits keep creeping after the collapse.
"""

from __future__ import annotations

import csv
import json
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

L0_KEY, H0_KEY = "geometry.base_length", "geometry.height"


def front_plot(run_dir: Path, out: Path) -> None:
    cfg = json.loads((run_dir / "run.json").read_text())["config"]
    h0, l0, g = cfg["geometry"]["height"], cfg["geometry"]["base_length"], cfg["material"]["gravity"]
    with (run_dir / "diagnostics.csv").open() as f:
        rows = list(csv.DictReader(f))
    t = np.array([float(r["t"]) for r in rows]) * np.sqrt(g / h0)
    fig, ax = plt.subplots(figsize=(6, 4))
    for key, label in (("front", "mass front"), ("thick_front", "thickness front")):
        ax.plot(t, [(float(r[key]) - l0) / h0 for r in rows], label=f"({label} − L0)/H0")
    ax.plot(t, [float(r["max_height"]) / h0 for r in rows], label="top height / H0")
    ax.set_xlabel("t √(g/H0)")
    model = cfg.get("model", {}).get("name", "stokes")
    ax.set_title(f"column a = {h0 / l0:.3g}, mesh {cfg['geometry']['mesh_size']} m, model {model}")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=120)


def fit(a: np.ndarray, y: np.ndarray) -> tuple[float, float] | None:
    """(prefactor c, exponent n) of y = c a^n by least squares in log-log; None if < 2 points."""
    ok = y > 0
    if ok.sum() < 2:
        return None
    n, logc = np.polyfit(np.log(a[ok]), np.log(y[ok]), 1)
    return float(np.exp(logc)), float(n)


def fit_text(a: np.ndarray, y: np.ndarray, cut: float, above: bool, padding: bool = True) -> str:
    """"a ≥ cut: c a^n (k points)" (or a ≤ cut) of ``fit`` on the aspect ratios on one side
    of ``cut`` (a is rounded to 9 digits by the callers, so the cut is exact)."""
    sel = a >= cut - 1e-9 if above else a <= cut + 1e-9
    p = fit(a[sel], y[sel])
    side = f"a ≥ {cut}" if above else f"a ≤ {cut}"
    side = f"{side:8s}:" if padding else f"{side}:"
    return (
        side
        + " "
        + (f"{p[0]:.2f} a^{p[1]:.2f} ({sel.sum()} points)" if p else f"{sel.sum()} point(s), no fit")
    )


def experimental_laws(ax1, ax2) -> None:
    """The experiments' runout bands (1.2–1.8 a for a ≤ 3, 1.9–2.3 a^(2/3) above) on ``ax1`` and
    the deposit height (H_f/L0 = a below 0.7, ∝ a^(1/3) through 0.74 above) on ``ax2``."""
    aa = np.logspace(np.log10(0.4), np.log10(12), 50)
    ax1.fill_between(aa, 1.2 * aa, 1.8 * aa, where=aa <= 3, color="0.85", label="1.2a – 1.8a (a ≤ 3)")
    ax1.fill_between(aa, 1.9 * aa ** (2 / 3), 2.3 * aa ** (2 / 3), where=aa >= 2.8, color="0.7",
                     label="1.9a^(2/3) – 2.3a^(2/3)")
    ax2.plot(aa[aa <= 0.7], aa[aa <= 0.7], "k--", label="H_f/L0 = a")
    ax2.plot(aa[aa >= 0.7], 0.74 * (aa[aa >= 0.7] / 0.74) ** (1 / 3), "k:", label="∝ a^(1/3) (through 0.74)")


def at_scaled_time(sweep_dir: Path, row: dict, scaled_time: float) -> dict:
    """``row`` with front, thick_front and max_height at the first step of its run with
    t √(g/H0) ≥ ``scaled_time`` (the last step if the run ended before; inf: the last step)."""
    h0 = float(row[H0_KEY])
    with (sweep_dir / row["run_dir"] / "diagnostics.csv").open() as f:
        steps = list(csv.DictReader(f))
    t_end = scaled_time / np.sqrt(9.81 / h0)
    pick = next((r for r in steps if float(r["t"]) >= t_end), steps[-1])
    return {**row, **{k: pick[k] for k in ("front", "thick_front", "max_height")}}


def law_plot(sweep_dir: Path, out: Path, scaled_time: float | None = None) -> None:
    with (sweep_dir / "sweep.csv").open() as f:
        # runs that ended at time.end_time without meeting the rest rule are kept (their
        # status is printed and drawn open): the two-phase model's smeared surface cells creep
        rows = [r for r in csv.DictReader(f) if r.get("status") in ("at_rest", "end_time")]
    if scaled_time is not None:
        rows = [at_scaled_time(sweep_dir, r, scaled_time) for r in rows]
    for r in rows:
        print(
            f"a = {float(r[H0_KEY]) / 0.1:5.2f}: {r['status']:8s} ΔL/L0 mass "
            f"{(float(r['front']) - 0.1) / 0.1:.2f}, thickness {(float(r['thick_front']) - 0.1) / 0.1:.2f}, "
            f"H_f/L0 {float(r['max_height']) / 0.1:.3f}"
        )
    l0 = 0.1
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        # keys the sweep does not vary are absent from sweep.csv (one group then)
        groups.setdefault((r.get("boundary.bed_condition", "no_slip"), r.get("geometry.mesh_size", "fixed")),
                          []).append(r)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
    for (bed, h), rs in sorted(groups.items()):
        a = np.round([float(r[H0_KEY]) / l0 for r in rs], 9)   # 0.3/0.1 = 2.9999999999999996
        order = np.argsort(a)
        a = a[order]
        run = np.array([(float(rs[i]["thick_front"]) - l0) / l0 for i in order])
        run_mass = np.array([(float(rs[i]["front"]) - l0) / l0 for i in order])
        hf = np.array([float(rs[i]["max_height"]) / l0 for i in order])
        label = f"{bed}, h = {h} m"
        ax1.loglog(a, run, "o-", label=label + " (thickness front)")
        ax1.loglog(a, run_mass, "x:", label=label + " (mass front)")
        ax2.loglog(a, hf, "o-", label=label)
        ended = np.array([rs[i]["status"] == "end_time" for i in order])
        if ended.any():
            ax1.loglog(a[ended], run[ended], "o", mfc="white", mec="k", label="not at rest at the end time")
            ax2.loglog(a[ended], hf[ended], "o", mfc="white", mec="k", label="not at rest at the end time")
        for name, x, y, cut, above in (
            ("ΔL/L0 thick", a, run, 3.0, False),
            ("ΔL/L0 thick", a, run, 3.0, True),
            ("ΔL/L0 mass", a, run_mass, 3.0, False),
            ("ΔL/L0 mass", a, run_mass, 3.0, True),
            ("H_f/L0", a, hf, 0.7, True),
        ):
            print(f"{bed:8s} h={h:5s} {name:12s} {fit_text(x, y, cut, above)}")
    experimental_laws(ax1, ax2)
    if scaled_time is not None:
        fig.suptitle(f"fronts and height at t √(g/H0) = {scaled_time:g}")
    ax1.set_xlabel("a = H0/L0"), ax1.set_ylabel("ΔL/L0"), ax1.legend(fontsize=6), ax1.grid(alpha=0.3)
    ax2.set_xlabel("a = H0/L0"), ax2.set_ylabel("H_f/L0"), ax2.legend(fontsize=6), ax2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=120)


LAW_COLUMNS = ("sweep", "a", "min_cell", "mass_front", "thickness_front", "max_height", "status",
               "scaled_time", "area_drift", "wall_time")


def law_points(name: str, sweep_dir: Path, scaled_time: float) -> list[dict]:
    """One row of LAW_COLUMNS per run of a sweep that ended at rest or at its end time: the
    fronts ΔL/L0 (mass: c > ½ or the mesh; thickness) and H_f/L0 at t √(g/H0) = ``scaled_time``
    (inf: the last step), the scaled time of the run's end, its area drift and wall time."""
    l0 = 0.1
    with (sweep_dir / "sweep.csv").open() as f:
        rows = [r for r in csv.DictReader(f) if r.get("status") in ("at_rest", "end_time")]
    points = []
    for r in rows:
        picked = at_scaled_time(sweep_dir, r, scaled_time)
        run_json = json.loads((sweep_dir / r["run_dir"] / "run.json").read_text())
        summ, cfg = run_json["summary"], run_json["config"]
        points.append({
            "sweep": name, "a": f"{float(r[H0_KEY]) / l0:.9g}",
            # the fine cells of an adaptive box, else the mesh size
            "min_cell": cfg.get("model", {}).get("min_cell") or cfg["geometry"]["mesh_size"],
            "mass_front": f"{(float(picked['front']) - l0) / l0:.4f}",
            "thickness_front": f"{(float(picked['thick_front']) - l0) / l0:.4f}",
            "max_height": f"{float(picked['max_height']) / l0:.4f}", "status": r["status"],
            "scaled_time": f"{summ['t'] * np.sqrt(9.81 / float(r[H0_KEY])):.2f}",
            "area_drift": f"{summ['area_drift']:.1e}", "wall_time": r.get("wall_time") or ""})
    return points


def read_law_table(path: Path) -> dict[str, list[dict]]:
    """The law points of a table written by ``laws`` (or transcribed from a report), by sweep."""
    with path.open() as f:
        rows = list(csv.DictReader(f))
    missing = set(LAW_COLUMNS) - set(rows[0] if rows else ())
    if missing:
        sys.exit(f"{path}: columns {sorted(missing)} missing (needs {', '.join(LAW_COLUMNS)})")
    table: dict[str, list[dict]] = {}
    for r in rows:
        table.setdefault(r["sweep"], []).append(r)
    return table


def laws_plot(out: Path, scaled_time: float, table: dict[str, list[dict]]) -> None:
    """The fronts ΔL/L0 (mass: solid, thickness: dotted) and the top height H_f/L0 of several
    sweeps (e.g. two mesh levels, two bed conditions), one line each, from rows of LAW_COLUMNS;
    prints a markdown table row per run and the fits."""
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
    print("| sweep | a | ΔX [m] | ΔL/L0 mass | ΔL/L0 thickness | H_f/L0 | end, T | area drift | wall [s] |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for (name, rows), marker in zip(table.items(), "osD^v"):
        rows = sorted(rows, key=lambda r: float(r["a"]))
        a = np.round([float(r["a"]) for r in rows], 9)   # 0.3/0.1 = 2.9999999999999996
        run = np.array([float(r["mass_front"]) for r in rows])
        thick = np.array([float(r["thickness_front"]) for r in rows])
        hf = np.array([float(r["max_height"]) for r in rows])
        rested = np.array([r["status"] == "at_rest" for r in rows])
        for k, r in enumerate(rows):
            end = "at rest" if r["status"] == "at_rest" else "end time"
            wall = f"{float(r['wall_time']):.0f}" if r["wall_time"] else "–"
            print(f"| {name} | {a[k]:g} | {r['min_cell']} | {run[k]:.2f} | {thick[k]:.2f} | {hf[k]:.3f} "
                  f"| {end}, {float(r['scaled_time']):.1f} | {float(r['area_drift']):.1e} | {wall} |")
        line = ax1.loglog(a, run, marker + "-", label=name + " (mass front)")[0]
        ax1.loglog(a, thick, marker + ":", color=line.get_color(), label=name + " (thickness front)")
        ax2.loglog(a, hf, marker + "-", color=line.get_color(), label=name)
        if (~rested).any():
            ax1.loglog(a[~rested], run[~rested], marker, mfc="white", mec=line.get_color())
            ax2.loglog(a[~rested], hf[~rested], marker, mfc="white", mec=line.get_color())
        for label, y, cut, above in (("ΔL/L0 mass", run, 3.0, False), ("ΔL/L0 mass", run, 3.0, True),
                                     ("ΔL/L0 thickness", thick, 3.0, False),
                                     ("ΔL/L0 thickness", thick, 3.0, True), ("H_f/L0", hf, 0.7, True)):
            print(f"{name}: {label} {fit_text(a, y, cut, above, padding=False)}")
    experimental_laws(ax1, ax2)
    when = "the end of each run" if np.isinf(scaled_time) else f"t √(g/H0) = {scaled_time:g}"
    fig.suptitle(f"fronts (mass: solid, thickness: dotted) and top height at {when} "
                 "(open: the run did not meet the rest rule by its end)")
    ax1.set_xlabel("a = H0/L0"), ax1.set_ylabel("ΔL/L0"), ax1.legend(fontsize=6)
    ax2.set_xlabel("a = H0/L0"), ax2.set_ylabel("H_f/L0"), ax2.legend(fontsize=7)
    ax1.grid(alpha=0.3), ax2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=120)


def fraction_plot(out: Path, run_dirs: list[Path]) -> None:
    """The granular volume fraction c (model two_phase) of each run at its last output."""
    from dpcollapse.plot import read_cell_field, read_series

    fig, axes = plt.subplots(len(run_dirs), 1, figsize=(8, 2.2 * len(run_dirs)), squeeze=False)
    for ax, run_dir in zip(axes[:, 0], run_dirs):
        cfg = json.loads((run_dir / "run.json").read_text())["config"]
        t, c = read_cell_field(run_dir, "volume_fraction")[-1]
        _, x, cells = read_series(run_dir)[-1]
        im = ax.tripcolor(x[:, 0], x[:, 1], cells, facecolors=c, vmin=0, vmax=1, cmap="viridis")
        g = cfg["geometry"]
        ax.set_title(f"a = {g['height'] / g['base_length']:.3g}, mesh {g['mesh_size']} m, "
                     f"t = {t:.3f} s", fontsize=9)
        ax.set_aspect("equal")
        fig.colorbar(im, ax=ax, label="c")
    fig.tight_layout()
    fig.savefig(out, dpi=120)


if __name__ == "__main__":
    kind = sys.argv[1]
    if kind == "fraction":
        fraction_plot(Path(sys.argv[2]), [Path(a) for a in sys.argv[3:]])
    elif kind == "laws":
        out, when = Path(sys.argv[2]), math.inf if sys.argv[3] == "end" else float(sys.argv[3])
        points = {}
        for arg in sys.argv[4:]:
            name, sweep_dir = arg.split("=", 1)
            points[name] = law_points(name, Path(sweep_dir), when)
        with out.with_suffix(".csv").open("w", newline="") as f:   # the points beside the plot
            writer = csv.DictWriter(f, fieldnames=LAW_COLUMNS)
            writer.writeheader()
            writer.writerows(r for rows in points.values() for r in rows)
        laws_plot(out, when, points)
    elif kind == "table":
        laws_plot(Path(sys.argv[2]), math.inf, read_law_table(Path(sys.argv[3])))
    else:
        src, dst = Path(sys.argv[2]), Path(sys.argv[3])
        if kind == "front":
            front_plot(src, dst)
        else:
            law_plot(src, dst, float(sys.argv[4]) if len(sys.argv) > 4 else None)
