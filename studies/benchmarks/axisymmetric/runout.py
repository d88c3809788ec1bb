"""The cylindrical columns' runout from their run directories (report 2026-12-07-axisymmetric).

Usage: python studies/benchmarks/axisymmetric/runout.py RUN_DIR [RUN_DIR ...]

For each run of ``configs/column_axi_a*.yaml`` (its config.yaml gives r0 = base_length and
H0 = height), from diagnostics.csv: the state when the kinetic energy first falls below
1e-3 of its peak after the peak ("settled"), and the last row ("end"): t√(g/H0), the mass
front r∞ (``front``) and the thickness front (``thick_front``) as (r∞ − r0)/r0, the height on
the deposit H∞/r0, the volume drift (``area`` is the body's volume), the remeshes; and the
laboratory's law for the same a as issue 52 quotes it (Lube et al. 2004; Lajeunesse et al.
2004): (r∞ − r0)/r0 ≈ 1.2 a for a ≲ 1.7, ≈ 1.6 a^{1/2} above.
"""

import csv
import math
import sys
from pathlib import Path

import yaml


def laboratory(a: float) -> float:
    """(r∞ − r0)/r0 of the cylinders' experiments as issue 52 quotes them: 1.2 a for
    a ≤ 1.7, 1.6 a^{1/2} above."""
    return 1.2 * a if a <= 1.7 else 1.6 * math.sqrt(a)


def summary(run: Path) -> dict:
    cfg = yaml.safe_load((run / "config.yaml").read_text())
    r0, h0 = cfg["geometry"]["base_length"], cfg["geometry"]["height"]
    g = cfg["material"].get("gravity", 9.81)
    rows = list(csv.DictReader((run / "diagnostics.csv").open()))
    ke = [float(r["kinetic_energy"]) for r in rows]
    peak = max(range(len(ke)), key=ke.__getitem__)
    settled = next((r for r, k in zip(rows[peak:], ke[peak:]) if k < 1e-3 * ke[peak]), None)
    v0 = float(rows[0]["area"])
    out = {"run": run.name, "a": h0 / r0, "mesh": cfg["geometry"]["mesh_size"],
           "laboratory": laboratory(h0 / r0)}
    for name, row in (("settled", settled), ("end", rows[-1])):
        if row is None:
            out[name] = None
            continue
        out[name] = {"T": float(row["t"]) * math.sqrt(g / h0),
                     "runout": (float(row["front"]) - r0) / r0,
                     "thick_runout": (float(row["thick_front"]) - r0) / r0,
                     "height": float(row["max_height"]) / r0,
                     "drift": (float(row["area"]) - v0) / v0,
                     "remeshes": int(float(row["remeshes"])),
                     "ke_ratio": float(row["kinetic_energy"]) / ke[peak]}
    return out


if __name__ == "__main__":
    print("| run | a | mesh | state | t√(g/H0) | (r∞−r0)/r0 front | thickness front | H∞/r0 | "
          "volume drift | remeshes | KE/peak | laboratory |")
    print("| --- " * 12 + "|")
    for arg in sys.argv[1:]:
        s = summary(Path(arg))
        for name in ("settled", "end"):
            v = s[name]
            if v is None:
                print(f"| {s['run']} | {s['a']:g} | {s['mesh']:g} | {name} | never | | | | | | | "
                      f"{s['laboratory']:.2f} |")
                continue
            print(f"| {s['run']} | {s['a']:g} | {s['mesh']:g} | {name} | {v['T']:.2f} | "
                  f"{v['runout']:.3f} | {v['thick_runout']:.3f} | {v['height']:.3f} | "
                  f"{v['drift']:.1e} | {v['remeshes']} | {v['ke_ratio']:.1e} | {s['laboratory']:.2f} |")
