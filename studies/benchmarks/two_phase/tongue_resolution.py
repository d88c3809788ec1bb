"""Issue 50: the two-phase column's tongue resolved by ``model.layer_cell``, against the moving mesh.

    python studies/benchmarks/two_phase/tongue_resolution.py RESULTS.jsonl [--case column_a2_mui]
                                     [--work runs/tongue] [--figure PNG] [--stopped LABEL ...]

Reads the runs of ``columns_cause.py`` (one JSON line each in RESULTS.jsonl, run directories
``WORK/CASE_tp_LABEL``) and, from each run's final checkpoint (checkpoint.npz: the mesh and c),
the deposit h(x) = (1/w) Σ_K c_K |K ∩ S_j| on strips of w = 0.5 mm (exact cell–strip
overlaps, ``models.two_phase.remap.strip_overlaps``; the runs' own h is on strips of min_cell),
its fronts x_f − L0 at h ≥ 1, 2, 5 mm (``fronts.profile_front``) and the mass front (the
furthest vertex of a cell with c > ½), and prints them beside the stored moving-mesh rung's
(docs/figures/ladder_series.csv: its profile h(x); its mesh tip, ladder.csv's front_2d_mesh)
as a Markdown table. ``--figure``: the deposits' thin ends h(x) and the mass fronts over time
(diagnostics.csv's ``front``) beside the moving mesh's; a run that did not end at rest (stopped
by its time limit: ``--stopped LABEL``, its run directory without a JSON line, run.json
``interrupted``) shows its front history only, its state is no deposit.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))  # studies/ is not installed
from dpcollapse.fronts import profile_front  # noqa: E402
from dpcollapse.io.diagnostics import read_diagnostics  # noqa: E402
from dpcollapse.models.two_phase.remap import strip_overlaps  # noqa: E402
from studies import ladder  # noqa: E402

THRESHOLDS = (1e-3, 2e-3, 5e-3)
STRIP = 5e-4          # the post-processing strips' width [m]
FIGURES = ladder.ROOT / "docs" / "figures"


def final_state(run_dir: Path) -> tuple[np.ndarray, np.ndarray]:
    """(triangles (n, 3, 2), c (n,)) of the run's final checkpoint."""
    data = np.load(run_dir / "checkpoint.npz", allow_pickle=True)
    return data["x_volume_fraction_vertices"], data["x_volume_fraction_values"][:, :, 0].mean(axis=1)


def thickness(tri: np.ndarray, c: np.ndarray, width: float = STRIP) -> tuple[np.ndarray, np.ndarray]:
    """(strip centres, h_j) on strips of ``width`` over the box."""
    count = int(np.ceil(tri[:, :, 0].max() / width))
    cell, strip, area = strip_overlaps(tri, width, count)
    h = np.bincount(strip, weights=c[cell] * area, minlength=count) / width
    return (np.arange(count) + 0.5) * width, h


def measure(run_dir: Path, l0: float) -> dict:
    tri, c = final_state(run_dir)
    x, h = thickness(tri, c)
    return {"x": x, "h": h, "fronts": [profile_front(x, h, t) - l0 for t in THRESHOLDS],
            "mass_front": float(tri[c > 0.5][:, :, 0].max()) - l0, "cells": len(tri)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results")
    ap.add_argument("--case", default="column_a2_mui")
    ap.add_argument("--work", default="runs/tongue")
    ap.add_argument("--figure")
    ap.add_argument("--stopped", nargs="*", default=[])
    args = ap.parse_args(argv)
    case = next(c for c in ladder.full_plan() if c.name == args.case)
    l0 = case.load().geometry.base_length
    row = next(r for r in ladder.read_rows(FIGURES / "ladder.csv") if r["case"] == args.case)
    series = ladder.read_series(FIGURES / "ladder_series.csv")
    ref = series[(args.case, "2d", "profile")]
    ref = ref[np.argsort(ref[:, 0])]
    ref_fronts = [profile_front(ref[:, 0], ref[:, 1], t) - l0 for t in THRESHOLDS]
    ref_tip = float(row["front_2d_mesh"]) - l0
    runs = [json.loads(line) for line in Path(args.results).read_text().splitlines() if line.strip()]
    runs = [r for r in runs if r["case"] == args.case and r["rung"] == "tp"]
    print("| run | layer cell [m] | h ≥ 1 mm | 2 mm | 5 mm | c > ½ | columns' h ≥ 1 / 2 / 5 mm "
          "(min_cell strips) | status, t_end, steps, CPU | drift | cells at the end |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    print(f"| moving mesh (stored rung) | — | {ref_fronts[0]:.4f} | {ref_fronts[1]:.4f} | "
          f"{ref_fronts[2]:.4f} | {ref_tip:.4f} (mesh tip) | | | {row['area_drift_2d']:.1e} | |")
    shown = []
    for r in runs:
        run_dir = Path(args.work) / f"{args.case}_tp_{r['label']}"
        if r["status"] != "at_rest":
            print(f"| {r['label']} | {r['overrides']} | {r['status']} at t = {r['t_end']:.3f} s, "
                  f"{r['steps']} steps, {r['cpu']:.0f} s CPU: no deposit | drift {r['drift']:.1e} |")
            shown.append((r["label"], r["overrides"][-1].split("=")[1], None, run_dir))
            continue
        m = measure(run_dir, l0)
        layer = next((o.split("=")[1] for o in r["overrides"] if o.startswith("model.layer_cell=")), "off")
        cells = " | ".join(f"{f:.4f} ({100 * (f / g - 1):+.1f} %)" for f, g in zip(m["fronts"], ref_fronts))
        own = " / ".join(f"{100 * d:+.1f} %" for d in r["diff"][:3])
        tip = 100 * (m["mass_front"] / ref_tip - 1)
        print(f"| {r['label']} | {layer} | {cells} | {m['mass_front']:.4f} ({tip:+.1f} %) | {own} | "
              f"{r['status']}, {r['t_end']:.3f} s, {r['steps']}, {r['cpu']:.0f} s | {r['drift']:.1e} | "
              f"{m['cells']} |")
        shown.append((r["label"], layer, m, run_dir))
    for label in args.stopped:
        run_dir = Path(args.work) / f"{args.case}_tp_{label}"
        layer = yaml.safe_load((run_dir / "config.yaml").read_text())["model"]["layer_cell"]
        state = json.loads((run_dir / "run.json").read_text())
        t = read_diagnostics(run_dir / "diagnostics.csv")["t"]
        print(f"| {label} | {layer} | {state['status']} at t = {float(t[-1]):.3f} s, {len(t)} steps: "
              "no deposit |")
        shown.append((label, layer, None, run_dir))
    if args.figure:
        figure(args.figure, shown, ref, series[(args.case, "2d", "front")], l0, args.case)
    return 0


def figure(path: str, shown, ref: np.ndarray, ref_front: np.ndarray, l0: float, case: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 4.2))
    ax.plot(ref[:, 0] - l0, 1e3 * ref[:, 1], "k-", lw=2, label="moving mesh (stored rung)")
    for label, layer, m, run_dir in shown:
        if m is not None:
            ax.plot(m["x"] - l0, 1e3 * m["h"], label=f"two-phase, layer cell {layer}")
        diag = read_diagnostics(run_dir / "diagnostics.csv")
        t, front = np.asarray(diag["t"], dtype=float), np.asarray(diag["front"], dtype=float)
        bx.plot(t, front - l0, label=f"two-phase c > ½, layer cell {layer}"
                + ("" if m is not None else " (stopped)"))
    bx.plot(ref_front[:, 0], ref_front[:, 1] - l0, "k-", lw=2, label="moving mesh (stored rung)")
    for t in (1, 2, 5):
        ax.axhline(t, color="0.7", lw=0.6, ls=":")
    ax.set(xlim=(0.2, 0.6), ylim=(0, 15), xlabel="x − L0 [m]", ylabel="h(x) [mm] (0.5 mm strips)",
           title=f"{case}: the deposit's thin end")
    bx.set(xlabel="t [s]", ylabel="front − L0 [m]", title="the mass front over time")
    ax.legend(fontsize=7)
    bx.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    sys.exit(main())
