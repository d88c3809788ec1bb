"""Issue 27's rest rule, read from two runs: the run that came to rest (run.json's t = T)
and its continuation to 2T with the rest rule held off. Prints the mass front, thickness
front and top height at T and at the end, their changes in % of H0, and the largest granular
speed after T.

    python docs/benchmarks/two_phase/rest_check.py RUN_AT_REST RUN_CONTINUED H0
"""

import csv
import json
import sys


def main(rest: str, continued: str, height: float) -> None:
    t_rest = json.load(open(f"{rest}/run.json"))["summary"]["t"]
    with open(f"{continued}/diagnostics.csv") as fh:
        rows = list(csv.DictReader(fh))
    start = min(rows, key=lambda r: abs(float(r["t"]) - t_rest))
    end = rows[-1]
    for label, row in (("T ", start), ("2T", end)):
        print(f"{label} t = {float(row['t']):.3f} s: front {float(row['front']):.4f} m, thickness "
              f"front {float(row['thick_front']):.4f} m, top {float(row['max_height']):.5f} m, "
              f"granular max speed {float(row['max_speed']):.2e} m/s")
    for key in ("front", "thick_front", "max_height"):
        change = float(end[key]) - float(start[key])
        print(f"  {key}: {change:+.2e} m = {100 * change / height:+.2f} % of H0")
    after = max(float(r["max_speed"]) for r in rows if float(r["t"]) >= t_rest)
    print(f"largest granular speed from T on: {after:.2e} m/s")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], float(sys.argv[3]))
