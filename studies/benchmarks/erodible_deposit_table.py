"""The erodible bed's deposits at several resolutions, one markdown row each (issue 49).

    python studies/benchmarks/erodible_deposit_table.py LABEL=RUN_DIR[:TIME_FILE] ...

For each run: status, t, steps, remeshes, surgeries, area drift (run.json), CPU (user time
of ``/usr/bin/time -v``'s file, when given), the front (the furthest x of the nodes above
2 h_e, ``scenes.erodible``), the highest point, and the free-surface height y(x) at
x = 0.1 … 0.6 m, read from the checkpoint (the mesh of the last checkpointed step: at rest
within ``time.checkpoint_every`` steps of the end): the highest free-surface or wall edge
spanning x.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import numpy as np

from dpcollapse.geometry.mesher import SURFACE

XS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6)


def surface_height(run: Path, xs=XS) -> list[float]:
    """The height of the free surface at each x [m] (NaN where no free-surface edge spans x)."""
    z = np.load(run / "checkpoint.npz", allow_pickle=True)
    x = z["mesh_x"][:, :2]
    e = x[z["mesh_edges"][z["mesh_edge_tags"] == SURFACE]]
    out = []
    for xq in xs:
        a, b = e[:, 0], e[:, 1]
        span = (np.minimum(a[:, 0], b[:, 0]) <= xq) & (np.maximum(a[:, 0], b[:, 0]) > xq)
        if not span.any():
            out.append(float("nan"))
            continue
        t = (xq - a[span, 0]) / (b[span, 0] - a[span, 0])
        out.append(float(np.max(a[span, 1] + t * (b[span, 1] - a[span, 1]))))
    return out


def cpu_seconds(time_file: Path) -> float:
    text = time_file.read_text()
    user = float(re.search(r"User time \(seconds\): ([0-9.]+)", text).group(1))
    system = float(re.search(r"System time \(seconds\): ([0-9.]+)", text).group(1))
    return user + system


def row(label: str, run: Path, time_file: Path | None) -> str:
    info = json.loads((run / "run.json").read_text())
    s = info["summary"]
    heights = " / ".join(f"{1000 * h:.1f}" for h in surface_height(run))
    cpu = f"{cpu_seconds(time_file):.0f}" if time_file and time_file.exists() else "—"
    return (f"| {label} | {info['status']} | {s.get('t', float('nan')):.4f} | {s.get('steps')} | "
            f"{s.get('remeshes')} | {s.get('surgeries', 0)} | {s.get('area_drift', float('nan')):+.2e} | "
            f"{s.get('front', float('nan')):.4f} | {1000 * s.get('max_height', float('nan')):.1f} | "
            f"{heights} | {cpu} |")


def main(argv=None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    print("| run | status | t [s] | steps | remeshes | surgeries | area drift | front [m] | "
          "highest [mm] | y(x) at x = " + ", ".join(f"{x:g}" for x in XS) + " m [mm] | CPU [s] |")
    print("| --- " * 11 + "|")
    for item in argv:
        label, _, rest = item.partition("=")
        run, _, tf = rest.partition(":")
        print(row(label, Path(run), Path(tf) if tf else None))


if __name__ == "__main__":
    main()
