"""The column family's runout law on the moving mesh (issue 49), beside the two-phase law.

Report: docs/benchmarks/2026-12-07-column-family-moving-mesh.md.

    python studies/benchmarks/column_family_moving.py commands [--cells 16,32] [--beds no_slip,coulomb]
        [--a 0.5,3]
    python studies/benchmarks/column_family_moving.py table OUT.csv RUN_DIR...   (OUT.csv's other rows kept)
    python studies/benchmarks/column_family_moving.py figure OUT.png MOVING.csv TWO_PHASE.csv
    python studies/benchmarks/column_family_moving.py commands --rheology drucker_prager [...]
    python studies/benchmarks/column_family_moving.py figure-dp OUT.png DP.csv LADDER.csv
    python studies/benchmarks/column_family_moving.py fronts H1,H2,... RUN_DIR...   (x_f - L0 at h [m])
    python studies/benchmarks/column_family_moving.py deposits OUT.png RUN_DIR...   (last meshes' h(x))

``commands`` prints one ``dpcollapse run`` line per case (a, bed, cells L0/n), each under
``/usr/bin/time`` (CPU seconds into RUN_DIR.time) and ``nice``/``timeout``; the run
directories are named ``a{a}_{bed}_{n}``. The cases: the half column [0, L0] x [0, H0],
L0 = 0.1 m, of ``configs/column_a{0.5,1.42,6.26,10}.yaml`` (μ(I) of seed 004: μ_s 0.32,
μ_2 0.60, I0 0.4; d of the discrete column of the same a, d = H0/30, H0/65, H0/135, and
for a = 3 and 10, which the seeds' discrete runs do not have, d = sqrt(H0 L0 / 2911): the
a = 6.26 column's grain count), a = 3 from ``column_a6.26.yaml`` with H0 and d set; the
Coulomb bed μ_b = 0.6 (30.9638°), that of the moving-mesh reports and
``configs/sweeps/column_runout.yaml``.

``table`` reads each run directory (run.json, diagnostics.csv, the last mesh of
solution.xdmf, RUN_DIR.time) into one row: ΔL/L0 of the mass front (largest x), of the
thickness front at the run's ``film_threshold`` (max(3 d, ΔX/4)) and at the common
h_f = 6 mm (3 × 2 mm: the two-phase law's stated thickness, its d = 2 mm), all by
``dpcollapse.fronts.profile_front`` on the last mesh's exact thickness profile; H_f/L0; the
run's steps, iterations, steps at the iteration cap, area drift, remeshes, landings,
surgeries, CPU seconds. ``figure`` draws the moving-mesh law (thickness front at 6 mm, and at
the run's own 3 d) beside the two-phase law of ``docs/figures/column_runout_adaptive.csv``
and the experimental bands, one panel per bed, and H_f/L0.

``--rheology drucker_prager`` (report 2026-12-07-column-family-drucker-prager.md): the same
columns and beds with the Drucker–Prager material of the ladder's columns (``configs/column.yaml``:
μ = tan 25.5°, η = 1 Pa s), no grain size, so the film trim is ``numerics.remesh_film_trim``'s
δ = 0.2 ΔX alone and the run's ``film_threshold`` is ΔX/4; run directories under
``runs/dpfam``. ``figure-dp`` draws that family (thickness front at ΔX/4 and at 6 mm, H_f/L0)
beside the ladder's Drucker–Prager columns (``docs/figures/ladder.csv``: the two-phase rung's
c > ½ front and the 2D rung's front, L0 = 0.07 m, Coulomb bed tan 25.5°) and the bands.

``deposits`` draws the last mesh's thickness profile h(x) of each run, one panel per column
(rheology, a, bed), a line per resolution, with the thickness front at the run's
``film_threshold`` marked (report 2026-12-07-column-family-closure.md).
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

from dpcollapse.fronts import profile_front
from dpcollapse.plot import read_series

L0 = 0.1                       # [m]
GRAIN_COUNT = 2911.34          # H0 L0 / d² of the a = 6.26 discrete column (135 × 21.57 grains)
COMMON_THICKNESS = 6.0e-3      # [m] 3 × 2 mm, the two-phase law's stated thickness
COULOMB = {"boundary.bed_condition": "coulomb", "boundary.bed_friction_angle": 30.9638}
#: the ladder's Drucker–Prager columns' material (configs/column.yaml); no grain size, so no
#: trim in grains (refused without one): the trim is numerics.remesh_film_trim × ΔX alone
DRUCKER_PRAGER = {"material.rheology": "drucker_prager", "material.friction_angle": 25.5,
                  "numerics.remesh_film_trim_grains": 0}

#: a → (config, overrides): the family's cases on the no-slip bed at the config's cells
FAMILY = {
    0.5: ("configs/column_a0.5.yaml", {}),
    1.42: ("configs/column_a1.42.yaml", {}),
    3.0: ("configs/column_a6.26.yaml",
          {"geometry.height": 0.3, "material.grain_diameter": round(math.sqrt(0.3 * L0 / GRAIN_COUNT), 9)}),
    6.26: ("configs/column_a6.26.yaml", {}),
    10.0: ("configs/column_a10.yaml", {}),
}

COLUMNS = ("bed", "a", "cells", "mesh_size", "grain_diameter", "status", "t_end", "steps",
           "iterations", "max_step_iterations", "capped_steps", "mass_front", "thickness_front",
           "film_threshold", "front_6mm", "max_height", "area_drift", "remeshes", "landings",
           "surgeries", "cpu_s", "cpu_per_step_s")


def commands(cells: list[int], beds: list[str], aspect: list[float], out: str = "runs/fam",
             cap_s: int = 6000, rheology: str = "mu_i") -> list[str]:
    lines = []
    for a in aspect:
        config, sets = FAMILY[a]
        if rheology == "drucker_prager":
            sets = {**{k: v for k, v in sets.items() if not k.startswith("material.grain")},
                    **DRUCKER_PRAGER}
        for bed in beds:
            for n in cells:
                name = f"a{a:g}_{'ns' if bed == 'no_slip' else 'co'}_{n}"
                every = {**sets, **(COULOMB if bed == "coulomb" else {}),
                         "geometry.mesh_size": round(L0 / n, 9), "time.checkpoint_every": 20}
                opts = " ".join(f"--set {k}={v}" for k, v in every.items())
                lines.append(f"/usr/bin/time -f '%U %S %e' -o {out}/{name}.time timeout -s INT {cap_s} "
                             f"nice -n 10 dpcollapse run {config} --quiet --out {out}/{name} {opts}")
    return lines


def mesh_thickness_profile(x: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(abscissae, h) of the mesh's vertical thickness h(x) = ∫ 1_Ω dy, exact (piecewise linear
    between vertex abscissae): each abscissa twice, its left then its right limit, so that
    ``profile_front`` through the points is the crossing of the exact profile (steps
    included). h is summed over the boundary edges, oriented by their CCW triangle (edges
    running right lie under the mass, running left over it), as ``scenes.base.vertical_thickness``
    does on a polygon; an overhang counts its material only."""
    tri = cells.copy()
    p = x[tri]
    ccw = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - \
          (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]) > 0
    tri[~ccw] = tri[~ccw][:, [0, 2, 1]]
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    key = np.sort(edges, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    bnd = edges[counts[inverse.ravel()] == 1]
    a, b = x[bnd[:, 0]], x[bnd[:, 1]]
    dx = b[:, 0] - a[:, 0]
    lo, hi = np.minimum(a[:, 0], b[:, 0]), np.maximum(a[:, 0], b[:, 0])
    xs = np.unique(x[np.unique(bnd), 0])
    h = []
    for side in (-1, 1):
        q = xs[:, None]
        spans = (lo < q) & (q <= hi) if side < 0 else (lo <= q) & (q < hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(dx != 0, (q - a[:, 0]) / np.where(dx != 0, dx, 1.0), 0.0)
        y = a[:, 1] + s * (b[:, 1] - a[:, 1])
        h.append(np.sum(np.where(spans, -np.sign(dx) * y, 0.0), axis=1))
    return np.repeat(xs, 2), np.column_stack(h).ravel()


def run_row(run_dir: Path) -> dict:
    info = json.loads((run_dir / "run.json").read_text())
    cfg, summ = info["config"], info["summary"]
    g = cfg["geometry"]
    with (run_dir / "diagnostics.csv").open() as f:
        steps = list(csv.DictReader(f))
    its = np.array([int(r["iterations"]) for r in steps])
    cap = cfg["numerics"]["max_iterations"]
    t_mesh, x, cells = read_series(run_dir)[-1]
    xs, h = mesh_thickness_profile(x, cells)
    own = profile_front(xs, h, summ["film_threshold"])
    if abs(t_mesh - summ["t"]) < 1e-9 and abs(own - summ["thick_front"]) > 1e-9:
        sys.exit(f"{run_dir}: the last mesh's front {own} differs from run.json's {summ['thick_front']}")
    time_file = run_dir.parent / f"{run_dir.name}.time"
    cpu = ""
    if time_file.is_file():
        # /usr/bin/time -f '%U %S %e': its last line (after "Command exited with …")
        last = time_file.read_text().strip().splitlines()[-1:]
        words = last[0].split() if last else []
        if len(words) == 3 and all(w.replace(".", "", 1).isdigit() for w in words):
            cpu = f"{float(words[0]) + float(words[1]):.1f}"
    l0 = g["base_length"]      # 0.1 m in the family; the ladder's 0.07 m for a like-for-like run
    bed = cfg["boundary"]["bed_condition"]
    if bed == "coulomb":
        bed = f"coulomb {math.tan(math.radians(cfg['boundary']['bed_friction_angle'])):.2f}"
    return {
        "bed": bed,
        "a": f"{g['height'] / g['base_length']:.4g}", "cells": f"L0/{g['base_length'] / g['mesh_size']:.3g}",
        "mesh_size": g["mesh_size"], "grain_diameter": cfg["material"].get("grain_diameter", ""),
        "status": summ["status"], "t_end": f"{summ['t']:.4f}", "steps": summ["steps"],
        "iterations": int(its.sum()), "max_step_iterations": int(its.max()),
        "capped_steps": int((its >= cap).sum()),
        "mass_front": f"{(summ['front'] - l0) / l0:.4f}",
        "thickness_front": f"{(summ['thick_front'] - l0) / l0:.4f}",
        "film_threshold": f"{summ['film_threshold']:.5f}",
        "front_6mm": f"{(profile_front(xs, h, COMMON_THICKNESS) - l0) / l0:.4f}",
        "max_height": f"{summ['max_height'] / l0:.4f}", "area_drift": f"{summ['area_drift']:.1e}",
        "remeshes": summ["remeshes"], "landings": summ["landings"], "surgeries": summ["surgeries"],
        "cpu_s": cpu, "cpu_per_step_s": f"{float(cpu) / summ['steps']:.3f}" if cpu else "",
    }


def two_phase_law(path: Path) -> dict[str, list[dict]]:
    with path.open() as f:
        rows = list(csv.DictReader(f))
    out: dict[str, list[dict]] = {}
    for r in rows:
        out.setdefault(r["sweep"], []).append(r)
    return out


def bands(ax) -> None:
    aa = np.logspace(np.log10(0.4), np.log10(12), 60)
    ax.fill_between(aa, 1.2 * aa, 1.8 * aa, where=aa <= 3, color="0.88",
                    label="experiments 1.2–1.8 a (a ≲ 3)")
    ax.fill_between(aa, 1.9 * aa ** (2 / 3), 2.3 * aa ** (2 / 3), where=aa >= 2.8, color="0.72",
                    label="experiments 1.9–2.3 a^(2/3)")


def print_fits(moving: list[dict]) -> None:
    """ΔL/L0 = c a^n (least squares in log-log) on a ≤ 3 and a ≥ 3, per bed and cells, of the
    thickness front at 6 mm and at the run's own 3 d, and H_f/L0 on a ≥ 1."""
    for bed in sorted({r["bed"] for r in moving}):
        for cells in sorted({r["cells"] for r in moving if r["bed"] == bed}):
            sel = [r for r in moving if r["bed"] == bed and r["cells"] == cells]
            a = np.array([float(r["a"]) for r in sel])
            for key, lo, hi in (("front_6mm", 0, 3), ("front_6mm", 3, 99), ("thickness_front", 0, 3),
                                ("thickness_front", 3, 99), ("max_height", 1, 99)):
                y = np.array([float(r[key]) for r in sel])
                ok = (a >= lo - 1e-9) & (a <= hi + 1e-9) & (y > 0)
                if ok.sum() >= 2:
                    n, logc = np.polyfit(np.log(a[ok]), np.log(y[ok]), 1)
                    print(f"{bed}, {cells}: {key} on {lo} ≤ a ≤ {hi}: {np.exp(logc):.2f} a^{n:.2f} "
                          f"({ok.sum()} points)")


def figure(out: Path, moving_csv: Path, two_phase_csv: Path) -> None:
    with moving_csv.open() as f:
        moving = list(csv.DictReader(f))
    tp = two_phase_law(two_phase_csv)
    fig, axes = plt.subplots(1, 3, figsize=(16, 5.2))
    colours = {"L0/16": "C0", "L0/20": "C2", "L0/32": "C1"}          # the two-phase law's
    mm_colours = {"L0/16": "k", "L0/20": "C3", "L0/32": "C4"}       # the moving mesh's
    for ax, bed, tp_bed in ((axes[0], "no_slip", "no slip"), (axes[1], "coulomb", "Coulomb")):
        bands(ax)
        rows = [r for r in moving if r["bed"].startswith(bed)]
        mu_b = rows[0]["bed"].split()[-1] if rows and bed == "coulomb" else ""
        for cells in sorted({r["cells"] for r in rows}, key=lambda c: float(c.split("/")[1])):
            sel = sorted((r for r in rows if r["cells"] == cells), key=lambda r: float(r["a"]))
            a = np.array([float(r["a"]) for r in sel])
            rested = np.array([r["status"] == "at_rest" for r in sel])
            f6 = np.array([float(r["front_6mm"]) for r in sel])
            own = np.array([float(r["thickness_front"]) for r in sel])
            c = mm_colours.get(cells, "C5")
            ax.loglog(a, f6, "o-", color=c, label=f"moving mesh {cells}, h_f = 6 mm")
            ax.loglog(a, own, "o:", color=c, mfc="white", label=f"moving mesh {cells}, h_f = 3 d (its d)")
            if (~rested).any():
                ax.loglog(a[~rested], f6[~rested], "x", color="k", ms=10, label="not at rest")
        for name, rs in tp.items():
            if not name.startswith(tp_bed):
                continue
            rs = sorted(rs, key=lambda r: float(r["a"]))
            cells = name.split(", ")[1]
            ax.loglog([float(r["a"]) for r in rs], [float(r["thickness_front"]) for r in rs], "s--",
                      color=colours.get(cells, "C3"), alpha=0.6, ms=4,
                      label=f"two-phase {cells}, h_f = 6 mm" + (" (μ_b = 0.32)" if bed == "coulomb" else ""))
        title = "no-slip bed" if bed == "no_slip" else f"Coulomb bed (moving mesh μ_b = {mu_b})"
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("a = H0/L0"), ax.set_ylabel("ΔL/L0 (thickness front)")
        ax.grid(alpha=0.3, which="both"), ax.legend(fontsize=6.5, loc="upper left")
    ax = axes[2]
    aa = np.logspace(np.log10(0.4), np.log10(12), 60)
    ax.plot(aa[aa <= 0.7], aa[aa <= 0.7], "k--", lw=0.8, label="H_f/L0 = a")
    ax.plot(aa[aa >= 0.7], 0.74 * (aa[aa >= 0.7] / 0.74) ** (1 / 3), "k:", lw=0.8,
            label="∝ a^(1/3) (through 0.74)")
    for bed, marker in (("no_slip", "o"), ("coulomb", "^")):
        rows = [r for r in moving if r["bed"].startswith(bed)]
        for cells in sorted({r["cells"] for r in rows}, key=lambda c: float(c.split("/")[1])):
            sel = sorted((r for r in rows if r["cells"] == cells), key=lambda r: float(r["a"]))
            ax.loglog([float(r["a"]) for r in sel], [float(r["max_height"]) for r in sel], marker + "-",
                      color=mm_colours.get(cells, "C5"), mfc="white" if bed == "coulomb" else None,
                      label=f"moving mesh, {bed}, {cells}")
    for name, rs in tp.items():
        rs = sorted(rs, key=lambda r: float(r["a"]))
        ax.loglog([float(r["a"]) for r in rs], [float(r["max_height"]) for r in rs],
                  ("s" if name.startswith("no slip") else "v") + "--", alpha=0.5, ms=4,
                  color=colours.get(name.split(", ")[1], "C3"), label=f"two-phase, {name}")
    ax.set_xlabel("a = H0/L0"), ax.set_ylabel("H_f/L0"), ax.set_title("deposit height", fontsize=10)
    ax.grid(alpha=0.3, which="both"), ax.legend(fontsize=6, loc="upper left")
    print_fits(moving)
    fig.suptitle("Column runout law: moving mesh (μ(I), d per a: 3 d = 5–18 mm) beside the two-phase "
                 "model (d = 2 mm), both read at h_f = 6 mm", fontsize=11)
    fig.tight_layout()
    fig.savefig(out, dpi=120)


def figure_dp(out: Path, dp_csv: Path, ladder_csv: Path) -> None:
    """The Drucker–Prager family: ΔL/L0 (thickness front at ΔX/4 and at 6 mm) and H_f/L0 against
    a per bed and cells, beside the ladder's Drucker–Prager columns (L0 = 0.07 m, bed tan 25.5°):
    the two-phase rung's c > ½ front (runout_tp) and the 2D rung's front (runout_2d, 1 cm cells)."""
    with dp_csv.open() as f:
        moving = list(csv.DictReader(f))
    with ladder_csv.open() as f:
        ladder = [r for r in csv.DictReader(f) if r["group"] == "column"]
    lad_l0 = 0.07
    lad_a = [float(r["param"]) for r in ladder]
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.2))
    ax = axes[0]
    bands(ax)
    styles = {}
    for r in moving:
        styles.setdefault((r["bed"], r["cells"]), f"C{len(styles)}")
    for (bed, cells), c in styles.items():
        sel = sorted((r for r in moving if r["bed"] == bed and r["cells"] == cells),
                     key=lambda r: float(r["a"]))
        a = [float(r["a"]) for r in sel]
        ax.loglog(a, [float(r["thickness_front"]) for r in sel], "o-", color=c,
                  label=f"moving mesh, {bed}, {cells}, h_f = ΔX/4")
        ax.loglog(a, [float(r["front_6mm"]) for r in sel], "o:", color=c, mfc="white",
                  label=f"moving mesh, {bed}, {cells}, h_f = 6 mm")
        axes[1].loglog(a, [float(r["max_height"]) for r in sel], "o-", color=c,
                       label=f"moving mesh, {bed}, {cells}")
    ax.loglog(lad_a, [float(r["runout_tp"]) / lad_l0 for r in ladder], "s--", color="0.4", ms=4,
              label="ladder two-phase (c > ½), coulomb 0.48, 4.4 mm")
    ax.loglog(lad_a, [float(r["runout_2d"]) / lad_l0 for r in ladder], "v--", color="0.6", ms=4,
              label="ladder 2D (mass front), coulomb 0.48, 1 cm")
    axes[1].loglog(lad_a, [float(r["height_tp"]) / lad_l0 for r in ladder], "s--", color="0.4", ms=4,
                   label="ladder two-phase")
    axes[1].loglog(lad_a, [float(r["height_2d"]) / lad_l0 for r in ladder], "v--", color="0.6", ms=4,
                   label="ladder 2D")
    ax.set_xlabel("a = H0/L0"), ax.set_ylabel("ΔL/L0")
    ax.grid(alpha=0.3, which="both"), ax.legend(fontsize=6.5, loc="upper left")
    axes[1].set_xlabel("a = H0/L0"), axes[1].set_ylabel("H_f/L0")
    axes[1].set_title("deposit height", fontsize=10)
    axes[1].grid(alpha=0.3, which="both"), axes[1].legend(fontsize=6.5, loc="upper left")
    print_fits(moving)
    fig.suptitle("Drucker–Prager columns (μ = tan 25.5°, η = 1 Pa s) on the moving mesh, L0 = 0.1 m, "
                 "beside the ladder's (L0 = 0.07 m)", fontsize=11)
    fig.tight_layout()
    fig.savefig(out, dpi=120)


def deposits(out: Path, run_dirs: list[Path]) -> None:
    """h(x)/L0 of each run's last mesh (``mesh_thickness_profile``), a panel per column."""
    panels: dict[str, list] = {}
    for d in run_dirs:
        info = json.loads((d / "run.json").read_text())
        cfg, summ = info["config"], info["summary"]
        g = cfg["geometry"]
        l0 = g["base_length"]
        t, x, cells = read_series(d)[-1]
        xs, h = mesh_thickness_profile(x, cells)
        rheology = "DP" if cfg["material"]["rheology"] == "drucker_prager" else "μ(I)"
        bed = cfg["boundary"]["bed_condition"].replace("_", " ")
        key = f"{rheology}, a = {g['height'] / l0:.3g}, {bed}"
        panels.setdefault(key, []).append(
            (f"L0/{l0 / g['mesh_size']:.3g}, {summ['status']} t = {t:.3f} s", xs / l0, h / l0,
             (summ["thick_front"] / l0, summ["film_threshold"] / l0)))
    fig, axes = plt.subplots(len(panels), 1, figsize=(10, 2.6 * len(panels)), squeeze=False)
    for ax, (key, lines) in zip(axes[:, 0], panels.items()):
        for i, (label, xs, h, (xf, hf)) in enumerate(lines):
            ax.plot(xs, h, color=f"C{i}", lw=1.2, label=label)
            ax.plot([xf], [hf], "|", color=f"C{i}", ms=14, mew=2)
        ax.set_title(key, fontsize=9), ax.set_ylabel("h/L0")
        ax.grid(alpha=0.3), ax.legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel("x/L0 (bars: the thickness front at the run's film_threshold)")
    fig.tight_layout()
    fig.savefig(out, dpi=110)


def main(argv: list[str]) -> None:
    kind = argv[0] if argv else ""
    if kind == "commands":
        opts = dict(zip(argv[1::2], argv[2::2]))
        cells = [int(c) for c in opts.get("--cells", "16,32").split(",")]
        beds = opts.get("--beds", "no_slip,coulomb").split(",")
        aspect = [float(a) for a in opts.get("--a", ",".join(f"{a:g}" for a in FAMILY)).split(",")]
        rheology = opts.get("--rheology", "mu_i")
        if rheology not in ("mu_i", "drucker_prager"):
            sys.exit(f"--rheology = {rheology}: allowed mu_i, drucker_prager")
        out = "runs/dpfam" if rheology == "drucker_prager" else "runs/fam"
        print("\n".join(commands(cells, beds, aspect, out=out, rheology=rheology)))
    elif kind == "table":
        rows = [run_row(Path(d)) for d in argv[2:]]
        printed = rows
        if Path(argv[1]).is_file():   # keep the table's other cases; a case run again replaces its row
            new = {(r["bed"], str(r["a"]), r["cells"]): r for r in rows}
            with open(argv[1]) as f:
                old = list(csv.DictReader(f))
            keys = {(r["bed"], r["a"], r["cells"]) for r in old}
            rows = ([new.get((r["bed"], r["a"], r["cells"]), r) for r in old]
                    + [r for k, r in new.items() if k not in keys])
        with open(argv[1], "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=COLUMNS)
            writer.writeheader()
            writer.writerows(rows)
        for r in printed:
            print(" | ".join(str(r[k]) for k in COLUMNS))
    elif kind == "figure":
        figure(Path(argv[1]), Path(argv[2]), Path(argv[3]))
    elif kind == "fronts":     # the thickness front at given h, on each run's last mesh
        hs = [float(v) for v in argv[1].split(",")]
        for d in argv[2:]:
            l0 = json.loads((Path(d) / "run.json").read_text())["config"]["geometry"]["base_length"]
            t, x, cells = read_series(Path(d))[-1]
            xs, h = mesh_thickness_profile(x, cells)
            runout = [profile_front(xs, h, v) - l0 for v in hs]
            print(d, f"t = {t:.4f} s:", " ".join(f"h = {v:g}: {r:.5f} m ({r / l0:.4f} L0)"
                                                  for v, r in zip(hs, runout)))
    elif kind == "figure-dp":
        figure_dp(Path(argv[1]), Path(argv[2]), Path(argv[3]))
    elif kind == "deposits":
        deposits(Path(argv[1]), [Path(d) for d in argv[2:]])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])
