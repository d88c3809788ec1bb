"""Where in time two rigid-collapse runs part, and whether the remeshes move the front (issue 51).

    python studies/benchmarks/rigid_dx_divergence.py RUN_A RUN_B [RUN ...] [--t0 0.3 --t1 0.8 --dt 0.02]

Each RUN is a run directory of ``dpcollapse run configs/rigid.yaml`` (its diagnostics.csv is
read; no solver is imported). Printed:

- per run: steps, remeshes, landings, surgeries, the rest time, the deposit front and the
  area drift (area_end / area_0 − 1);
- per remesh: the front's jump over the remesh step minus the advance the front speed on
  either side predicts, Δx_f − ½(v⁻ + v⁺)Δt (v± from the 5 steps before / after): the
  front displacement the remesh itself (transfer, resampling of the toe) adds;
- the front history of every run against the first, x_f(t) − x_f,A(t) [mm] (linear between
  steps), the thick front's, the front speed dx_f/dt and the largest height, on t0 … t1.
"""
import argparse
import csv
from pathlib import Path

import numpy as np


def load(run):
    rows = list(csv.DictReader(open(Path(run) / "diagnostics.csv")))
    return {k: np.array([float(r[k]) if r[k] not in ("", "nan") else np.nan for r in rows])
            for k in rows[0]}


def remesh_excess(d):
    """[(t, jump, excess)] in m for each remesh: the front jump minus the predicted advance."""
    out = []
    for i in np.where(np.diff(d["remeshes"]) > 0)[0] + 1:
        if i < 6 or i + 6 >= len(d["t"]):
            continue
        v_before = (d["front"][i - 1] - d["front"][i - 6]) / (d["t"][i - 1] - d["t"][i - 6])
        v_after = (d["front"][i + 6] - d["front"][i + 1]) / (d["t"][i + 6] - d["t"][i + 1])
        jump = d["front"][i] - d["front"][i - 1]
        predicted = 0.5 * (v_before + v_after) * (d["t"][i] - d["t"][i - 1])
        out.append((d["t"][i], jump, jump - predicted))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--t0", type=float, default=0.3)
    ap.add_argument("--t1", type=float, default=0.8)
    ap.add_argument("--dt", type=float, default=0.02)
    args = ap.parse_args()
    data = {run: load(run) for run in args.runs}
    for run, d in data.items():
        ex = remesh_excess(d)
        landing_t = d["t"][np.where(np.diff(d["landings"]) > 0)[0] + 1]
        print(f"== {run}: {int(d['step'][-1])} steps to t = {d['t'][-1]:.4f} s, "
              f"front {d['front'][-1]:.5f} m, {int(d['remeshes'][-1])} remeshes, "
              f"{int(d['landings'][-1])} landings, {int(d['surgeries'][-1])} surgeries, "
              f"area drift {d['area'][-1] / d['area'][0] - 1:+.2e}")
        print("   landings at t =", " ".join(f"{t:.3f}" for t in landing_t))
        print("   remesh t [s] / front jump [mm] / jump minus predicted advance [mm]:")
        for t, jump, excess in ex:
            print(f"     {t:.4f}  {jump * 1e3:+.3f}  {excess * 1e3:+.4f}")
        if ex:
            print(f"   sum of the excesses {sum(e for _, _, e in ex) * 1e3:+.4f} mm, "
                  f"largest |excess| {max(abs(e) for _, _, e in ex) * 1e3:.4f} mm")
    ref_name, ref = args.runs[0], data[args.runs[0]]
    print(f"\nagainst {ref_name}: t, then per run x_f − x_f,A [mm] / thick front − A's [mm] / "
          "dx_f/dt [m/s] / max height [m]")
    for t in np.arange(args.t0, args.t1 + 1e-9, args.dt):
        cells = []
        for run, d in data.items():
            if t > d["t"][-1]:
                cells.append("(at rest)")
                continue
            diff = np.interp(t, d["t"], d["front"]) - np.interp(t, ref["t"], ref["front"])
            thick = (np.interp(t, d["t"], d["thick_front"])
                     - np.interp(t, ref["t"], ref["thick_front"]))
            speed = np.interp(t, d["t"][1:], np.diff(d["front"]) / np.diff(d["t"]))
            height = np.interp(t, d["t"], d["max_height"])
            cells.append(f"{diff * 1e3:+6.2f} {thick * 1e3:+6.2f} {speed:6.3f} {height:.4f}")
        print(f"t={t:.2f}  " + " | ".join(cells))


if __name__ == "__main__":
    main()
