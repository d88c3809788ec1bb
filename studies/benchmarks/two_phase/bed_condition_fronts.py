"""Front histories of the rigid-bed trapezoid: the two-phase model against the moving mesh,
Coulomb bed against no-slip bed.

    python studies/benchmarks/two_phase/bed_condition_fronts.py OUT.png "label=RUN" ...

Each RUN is a run directory (diagnostics.csv); a label starting with "MM" is drawn dashed.
The front is diagnostics.csv's ``front`` (the moving mesh's mesh front; the two-phase model's
mass front, the furthest cell with c > 1/2).
"""

import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main(out, runs):
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for spec in runs:
        label, run = spec.split("=", 1)
        rows = list(csv.DictReader(open(f"{run}/diagnostics.csv")))
        t = np.array([float(r["t"]) for r in rows])
        front = np.array([float(r["front"]) for r in rows])
        ax.plot(t, front, "--" if label.startswith("MM") else "-", label=label)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("front [m]")
    ax.set_xlim(0, 1.0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=100)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
