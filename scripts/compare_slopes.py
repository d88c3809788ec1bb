#!/usr/bin/env python3
"""Collapses on 10°, 19° and 22° beds (seed 002): μ(I) vs constant viscosity, with and
without side-wall friction. Runs the 12 cases of configs/slope*_{mui,dp}.yaml, then writes
``slopes.csv`` (runout, stop time, wall time per case) and ``slopes.png`` (front position
and front velocity against time, all cases on one chart).

    .venv/bin/python scripts/compare_slopes.py [--out runs/slopes] [--mesh-size 0.01] [--end-time T]

All wall-time ratios come from this one run on this machine.
"""

from __future__ import annotations

import argparse
import csv
import json
import logging
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parent.parent

SLOPES = (10, 19, 22)
RHEOLOGIES = {"mui": "μ(I)", "dp": "constant η"}


def run_all(out: Path, mesh_size: float | None, end_time: float | None, log=print) -> list[dict]:
    from dpcollapse.config import load_config
    from dpcollapse.errors import DpcollapseError
    from dpcollapse.io.diagnostics import read_diagnostics
    from dpcollapse.simulation import Simulation

    rows = []
    for slope in SLOPES:
        for rh in RHEOLOGIES:
            for walls in (True, False):
                over = [] if walls else ["boundary.channel_width=null"]
                if mesh_size:
                    over.append(f"geometry.mesh_size={mesh_size}")
                if end_time:
                    over.append(f"time.end_time={end_time}")
                cfg = load_config(ROOT / "configs" / f"slope{slope}_{rh}.yaml", over)
                name = f"slope{slope}_{rh}_{'walls' if walls else 'nowalls'}"
                t0 = time.perf_counter()
                try:
                    summary = Simulation(cfg, out / name, quiet=True).run()
                except DpcollapseError as exc:  # reported, not hidden: the case keeps its rows
                    info = json.loads((out / name / "run.json").read_text())
                    summary = dict(info["summary"], status=f"failed: {exc}")
                wall = time.perf_counter() - t0
                d = read_diagnostics(out / name / "diagnostics.csv")
                rows.append({"case": name, "slope": slope, "rheology": rh, "side_walls": walls,
                             "status": summary["status"], "t_end": summary["t"],
                             "runout": summary["front"] - cfg.geometry.base_length,
                             "front": summary["front"], "max_height": summary["max_height"],
                             "mean_iterations": summary["mean_iterations"], "wall_time": wall,
                             "t": d["t"], "front_history": d["front"]})
                log(f"{name:28s} {summary['status'][:60]:9s} t = {summary['t']:.3f} s  runout "
                    f"{rows[-1]['runout']:.4f} m  iterations/step {summary['mean_iterations']:.2f}  "
                    f"wall {wall:.1f} s")
    return rows


def front_velocity(t, x, window: float = 0.02):
    """Front speed by a centred difference over ``window`` seconds (smooths step noise)."""
    import numpy as np

    t, x = np.asarray(t), np.asarray(x)
    v = np.empty_like(x)
    for i, ti in enumerate(t):
        lo = np.searchsorted(t, ti - window / 2)
        hi = min(np.searchsorted(t, ti + window / 2), len(t) - 1)
        lo = min(lo, hi - 1) if hi > 0 else 0
        v[i] = (x[hi] - x[lo]) / (t[hi] - t[lo]) if t[hi] > t[lo] else 0.0
    return v


def report(rows: list[dict], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with (out / "slopes.csv").open("w", newline="") as f:
        keys = [k for k in rows[0] if k not in ("t", "front_history")]
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: r[k] for k in keys})
    colours = {10: "tab:blue", 19: "tab:orange", 22: "tab:red"}
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 9), sharex=True)
    for r in rows:
        style = "-" if r["rheology"] == "mui" else "--"
        alpha = 1.0 if r["side_walls"] else 0.45
        label = f"{r['slope']}°, {RHEOLOGIES[r['rheology']]}, {'side walls' if r['side_walls'] else 'no side walls'}"
        a1.plot(r["t"], [x - r["front_history"][0] for x in r["front_history"]], style,
                color=colours[r["slope"]], alpha=alpha, label=label)
        a2.plot(r["t"], front_velocity(r["t"], r["front_history"]), style, color=colours[r["slope"]], alpha=alpha)
    a1.set_ylabel("front displacement [m]")
    a1.legend(fontsize=7, ncol=2)
    a1.grid(alpha=0.3)
    a2.set_ylabel("front velocity [m/s]")
    a2.set_xlabel("t [s]")
    a2.grid(alpha=0.3)
    fig.suptitle("Column collapse on inclined beds (seed 002): solid μ(I), dashed constant η; "
                 "faint: no side-wall friction", fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "slopes.png", dpi=110)
    plt.close(fig)


def ratios(rows: list[dict]) -> list[str]:
    """Wall-time and runout ratios μ(I)/constant η and with/without walls, per slope."""
    by = {(r["slope"], r["rheology"], r["side_walls"]): r for r in rows}
    lines = []
    for s in SLOPES:
        for walls in (True, False):
            m, d = by[(s, "mui", walls)], by[(s, "dp", walls)]
            lines.append(f"{s:2d}° {'walls   ' if walls else 'no walls'}: wall time μ(I)/η = "
                         f"{m['wall_time'] / d['wall_time']:.2f}, runout μ(I) {m['runout']:.4f} m vs η "
                         f"{d['runout']:.4f} m ({(m['runout'] - d['runout']) * 1000:+.1f} mm)")
        for rh in RHEOLOGIES:
            w, n = by[(s, rh, True)], by[(s, rh, False)]
            lines.append(f"{s:2d}° {RHEOLOGIES[rh]}: runout with walls {w['runout']:.4f} m, without "
                         f"{n['runout']:.4f} m ({(w['runout'] - n['runout']) * 1000:+.1f} mm); wall time "
                         f"ratio {w['wall_time'] / n['wall_time']:.2f}")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "runs" / "slopes")
    ap.add_argument("--mesh-size", type=float, default=None, help="override geometry.mesh_size [m]")
    ap.add_argument("--end-time", type=float, default=None, help="override time.end_time [s]")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, force=True)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = run_all(args.out, args.mesh_size, args.end_time)
    report(rows, args.out)
    for line in ratios(rows):
        print(line)
    print(f"wrote {args.out / 'slopes.csv'} and {args.out / 'slopes.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
