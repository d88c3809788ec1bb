"""The ladder's deposits read at several thicknesses: for each case with a two-phase rung,
the front x where the deposit profile h(x) last reaches h ≥ 1, 2, 5, 10, 20 mm, on the 2D
(moving-mesh) rung and the two-phase rung, from ladder_series.csv's "profile" rows (linear
between the stored points), as runouts x − L0 and their relative difference.

    python studies/benchmarks/two_phase/ladder_thresholds.py LADDER_DIR [CASE ...]

(LADDER_DIR: the folder of ladder.csv and ladder_series.csv, e.g. docs/figures.)
"""

import csv
import sys
from pathlib import Path

import numpy as np

from dpcollapse.fronts import profile_front

THRESHOLDS = (1e-3, 2e-3, 5e-3, 1e-2, 2e-2)


def front(profile: np.ndarray, threshold: float) -> float:
    """Largest x with h ≥ threshold, interpolated to the next stored point; nan if none
    (``dpcollapse.fronts.profile_front``, every model's front)."""
    return profile_front(profile[:, 0], profile[:, 1], threshold)


def main(folder: str, cases: list[str]) -> None:
    folder = Path(folder)
    rows = {r["case"]: r for r in csv.DictReader(open(folder / "ladder.csv"))}
    series: dict = {}
    for r in csv.DictReader(open(folder / "ladder_series.csv")):
        if r["kind"] == "profile":
            series.setdefault((r["case"], r["rung"]), []).append((float(r["x"]), float(r["y"])))
    heads = " | ".join(f"h ≥ {1000 * t:g} mm" for t in THRESHOLDS)
    print(f"| case | L0 [m] | runout 2D / two-phase [m] (Δ): {heads} |")
    print("| --- | --- |" + " --- |" * len(THRESHOLDS))
    for name, row in rows.items():
        if (cases and name not in cases) or (name, "tp") not in series:
            continue
        l0 = float(row["front_2d"]) - float(row["runout_2d"])
        two_d, tp = (np.array(sorted(series[(name, k)])) for k in ("2d", "tp"))
        cells = []
        for t in THRESHOLDS:
            a, b = front(two_d, t) - l0, front(tp, t) - l0
            cells.append(f"{a:.3f} / {b:.3f} ({100 * (b - a) / a:+.0f} %)" if a > 0 else "–")
        print(f"| {name} | {l0:.3g} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
