"""Run the erodible-bed collapse on the two-phase model with the measurements of its report,
and plot them.

    python benchmarks/erodible_eulerian.py run CONFIG OUT [--set KEY=VALUE ...]
    python benchmarks/erodible_eulerian.py plot OUT.json [OUT.json ...] --png FILE

``run``: ``dpcollapse run`` of CONFIG into OUT (a run directory; its diagnostics.csv holds
the fronts, heights, area and the layer measures of every step) with, every 0.05 s and at the
end, the thickness profiles h(x) = ∫ c dy and h_L(x) = ∫ c_L dy of the columns of cells, and
at the end c and c_L of every cell with its centroid. Writes OUT.json and OUT.npz.
``plot``: the final c = 0.5 contour and h(x) of each run with the initial shape, the moving
mesh deposit's front and top (1 cm, docs/benchmarks/2026-12-02-erodible-tension-mesh.md),
h_L(x) of the layer, and the front and the layer set in motion against time.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
PROFILE_EVERY = 0.05
#: the moving-mesh (ALE) deposits at 1 cm, (front, top) [m]: on the layer with seed 000's
#: tension (docs/benchmarks/2026-12-02-erodible-tension-mesh.md) and on the rigid bed
#: (configs/rigid.yaml, docs/benchmarks/2026-12-01-dolfinx-versions.md)
ALE_DEPOSIT = (0.6250, 0.2148)
RIGID_DEPOSIT = (0.6664, 0.2100)


def _columns(disc, values):
    """∫ values dy of each column of cells (as ``disc.thickness``) [m]."""
    from mpi4py import MPI

    local = np.bincount(disc._bin, weights=values * disc._volume, minlength=disc.nx)
    return disc.comm.allreduce(local, op=MPI.SUM) / disc.dx_bin


def run(config: str, out: str, overrides: list[str]) -> int:
    from mpi4py import MPI

    from dpcollapse.config import load_config
    from dpcollapse.errors import DpcollapseError
    from dpcollapse.io.diagnostics import read_diagnostics
    from dpcollapse.loop import Events
    from dpcollapse.models.two_phase.fraction import owned_triangles
    from dpcollapse.simulation import Simulation

    cfg = load_config(Path(config), overrides)
    profiles = []

    def profile(sim, t):
        disc = sim.disc
        h = disc.thickness()
        hl = _columns(disc, disc.layer.fraction.c.x.array[disc._cells])
        profiles.append((float(t), h, hl))

    def on_step(sim, row):
        if row["t"] >= PROFILE_EVERY * len(profiles) - 1e-9:
            profile(sim, row["t"])
        return False

    events = Events()
    events.subscribe("step_accepted", on_step)
    code, summary, error = 0, None, None
    sim = Simulation(cfg, Path(out), quiet=False, events=events)
    profile(sim, 0.0)
    try:
        summary = sim.run()
    except DpcollapseError as exc:
        code, error = exc.exit_code, str(exc)
    disc = sim.disc
    end = summary["t"] if summary else math.nan
    if not profiles[-1][0] == end:
        profile(sim, end)
    tri = owned_triangles(disc.mesh)
    cells = (tri.mean(axis=1), disc.fraction.c.x.array[disc._cells],
             disc.layer.fraction.c.x.array[disc._cells], disc.layer.chi)
    gathered = disc.comm.gather(cells, root=0)
    if MPI.COMM_WORLD.rank != 0:
        return code
    if summary is None:
        summary = json.loads((Path(out) / "run.json").read_text()).get("summary")
    columns = read_diagnostics(Path(out) / "diagnostics.csv")
    moving = np.asarray(columns["layer_moving"])
    k = int(np.argmax(moving)) if len(moving) else 0
    report = {"config": config, "overrides": overrides, "exit_code": code, "error": error,
              "summary": summary, "timings": sim.timings,
              "layer_moving_max": float(moving[k]) if len(moving) else math.nan,
              "layer_moving_max_t": float(columns["t"][k]) if len(moving) else math.nan,
              "profile_times": [p[0] for p in profiles], "dx_bin": disc.dx_bin}
    Path(out + ".json").write_text(json.dumps(report, indent=1))
    np.savez(out + ".npz", times=np.array([p[0] for p in profiles]),
             h=np.array([p[1] for p in profiles]), hl=np.array([p[2] for p in profiles]),
             centroids=np.concatenate([g[0] for g in gathered]),
             c=np.concatenate([g[1] for g in gathered]), cl=np.concatenate([g[2] for g in gathered]),
             chi=np.concatenate([g[3] for g in gathered]),
             t=np.asarray(columns["t"]), front=np.asarray(columns["front"]),
             thick_front=np.asarray(columns["thick_front"]), layer_moving=moving,
             layer_outside=np.asarray(columns["layer_outside"]))
    print(json.dumps({k: report[k] for k in ("exit_code", "error", "layer_moving_max",
                                             "layer_moving_max_t")} | {"summary": summary}))
    return code


def plot(reports: list[str], png: str) -> None:
    """Top: final c = 0.5 contours and h(x) of each run, the initial shape, the ALE deposit's
    front and top; middle: h_L(x) of the layer at t = 0 and at the end; bottom: mass front
    and layer set in motion against time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sys.path.insert(0, str(REPO))
    fig = plt.figure(figsize=(11, 10))
    grid = fig.add_gridspec(3, 2, height_ratios=[2.2, 1, 1.3])
    ax, axl = fig.add_subplot(grid[0, :]), fig.add_subplot(grid[1, :])
    axt, axm = fig.add_subplot(grid[2, 0]), fig.add_subplot(grid[2, 1])
    he, h0, l0 = 0.005, 0.25, 0.297
    top = l0 - h0 / math.tan(math.radians(70.0))
    ax.plot([0, l0, top, 0], [he, he, he + h0, he + h0], "k:", lw=0.9, label="initial mass")
    for (front, height), mark, what in ((ALE_DEPOSIT, "s", "erodible, tension"),
                                        (RIGID_DEPOSIT, "^", "rigid bed")):
        ax.plot(front, height, "k" + mark, ms=6, label=f"moving mesh 1 cm at rest, {what}: "
                f"front {front} m (marker x), top {height} m (marker y)")
        ax.plot([0, front], [height, height], "k--", lw=0.5)
        ax.plot([front] * 2, [0, 0.03], "k--", lw=0.5)
    colors = plt.get_cmap("tab10")
    for i, path in enumerate(reports):
        rep = json.loads(Path(path).read_text())
        d = np.load(path[:-5] + ".npz")
        s = rep["summary"] or {}
        name = Path(path).stem
        x = (np.arange(d["h"].shape[1]) + 0.5) * rep["dx_bin"]
        label = (f"{name}: t = {s.get('t', math.nan):.3f} s ({s.get('status', 'fail')}), "
                 f"front {s.get('front', math.nan):.4f} m")
        ax.plot(x, d["h"][-1], color=colors(i), lw=1.3, label=label + ", h(x) = ∫c dy")
        ax.tricontour(d["centroids"][:, 0], d["centroids"][:, 1], d["c"], levels=[0.5],
                      colors=[colors(i)], linewidths=0.7, linestyles="--")
        axl.plot(x, d["hl"][0] * 1e3, color=colors(i), lw=0.7, ls=":", label=f"{name}, t = 0")
        axl.plot(x, d["hl"][-1] * 1e3, color=colors(i), lw=1.2, label=f"{name}, end")
        axt.plot(d["t"], d["front"], color=colors(i), label=f"{name}: mass front")
        axt.plot(d["t"], d["thick_front"], color=colors(i), ls=":", label=f"{name}: thickness front")
        axm.plot(d["t"], d["layer_moving"], color=colors(i), label=f"{name}: set in motion")
        axm.plot(d["t"], d["layer_outside"], color=colors(i), ls="--",
                 label=f"{name}: outside its initial cells")
    ax.set_xlim(0, 1.0)
    ax.set_ylim(0, 0.27)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("final deposit: h(x) solid, c = 0.5 dashed", fontsize=9)
    ax.legend(fontsize=7, loc="center right")
    axl.set_xlim(0, 1.0)
    axl.set_xlabel("x [m]")
    axl.set_ylabel("h_L = ∫ c_L dy [mm]")
    axl.legend(fontsize=7, loc="upper right")
    axt.set_xlabel("t [s]")
    axt.set_ylabel("front [m]")
    axt.legend(fontsize=7)
    axm.set_xlabel("t [s]")
    axm.set_ylabel("fraction of the layer")
    axm.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run")
    r.add_argument("config")
    r.add_argument("out")
    r.add_argument("--set", action="append", default=[])
    p = sub.add_parser("plot")
    p.add_argument("reports", nargs="+")
    p.add_argument("--png", required=True)
    args = parser.parse_args(argv)
    if args.command == "run":
        return run(args.config, args.out, args.set)
    plot(args.reports, args.png)
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(REPO))
    sys.exit(main())
