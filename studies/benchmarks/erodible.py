"""Run a collapse with the measurements of the erodible-bed report, and plot them.

    python benchmarks/erodible.py run CONFIG OUT [--set KEY=VALUE ...]
    python benchmarks/erodible.py plot OUT.json [OUT.json ...] --png FILE [--rigid RIGID.json]

``run``: ``dpcollapse run`` of CONFIG into OUT (a run directory) with, after every accepted
step, the front, and every 10 steps the area of the layer's cells (cell tag LAYER) and of
those whose mean vertex speed |uⁿ| exceeds 1 mm/s (seed 000's flowing threshold), and the
tagged boundary edges every 0.05 s and at the end (also the last accepted state before a
failure). Writes OUT.json (summary, exit code, series) and OUT.npz (boundary edges).
``plot``: free-surface profiles, front against time and the layer set in motion of one or
more such runs, in one PNG.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
FLOWING_SPEED = 1e-3
PROFILE_EVERY = 0.05


def _edges(tagged):
    """(edges (m, 2, 2), tags (m,)) of the boundary on rank 0, None elsewhere."""
    from dpcollapse.geometry.mesher import boundary_edges

    edges, tags = boundary_edges(tagged)
    return None if edges is None else (edges, tags)


def run(config: str, out: str, overrides: list[str]) -> int:
    from mpi4py import MPI

    from dpcollapse.config import load_config
    from dpcollapse.errors import DpcollapseError
    from dpcollapse.geometry.mesher import LAYER
    from dpcollapse.loop import Events
    from dpcollapse.simulation import Simulation

    cfg = load_config(Path(config), overrides)
    series = {"step": [], "t": [], "front": [], "remeshes": []}
    layer = {"t": [], "layer_area": [], "layer_moving_area": [], "mass_moving_area": []}
    profiles, last = [], {}
    events = Events()

    def on_step(sim, row):
        for key in series:
            series[key].append(float(row[key]))
        disc = sim.disc
        last["edges"] = (row["t"], _edges(disc.tagged))
        if row["step"] % 10 == 0:
            layer["t"].append(row["t"])
            layer["layer_area"].append(disc.region_area(LAYER))
            layer["layer_moving_area"].append(disc.region_area(LAYER, FLOWING_SPEED))
            layer["mass_moving_area"].append(disc.region_area(10, FLOWING_SPEED))
        if row["t"] >= PROFILE_EVERY * len(profiles) - 1e-9:
            profiles.append(last["edges"])
        return False

    events.subscribe("step_accepted", on_step)
    code, summary, error = 0, None, None
    sim = Simulation(cfg, Path(out), quiet=False, events=events)
    profiles.append((0.0, _edges(sim.disc.tagged)))
    try:
        summary = sim.run()
    except DpcollapseError as exc:
        code, error = exc.exit_code, str(exc)
        summary = (
            json.loads((Path(out) / "run.json").read_text())["summary"] if MPI.COMM_WORLD.rank == 0 else None
        )
    if MPI.COMM_WORLD.rank != 0:
        return code
    if "edges" in last and (not profiles or profiles[-1][0] != last["edges"][0]):
        profiles.append(last["edges"])
    report = {"config": config, "overrides": overrides, "exit_code": code, "error": error,
              "summary": summary, "timings": sim.timings, "series": series, "layer": layer,
              "profile_times": [t for t, _ in profiles]}
    Path(out + ".json").write_text(json.dumps(report, indent=1))
    arrays = {}
    for i, (t, (edges, tags)) in enumerate(profiles):
        arrays[f"edges_{i}"], arrays[f"tags_{i}"] = edges, tags
    np.savez(out + ".npz", times=np.array([t for t, _ in profiles]), **arrays)
    print(json.dumps({k: report[k] for k in ("exit_code", "error")} | {"summary": summary}))
    return code


def _profile(data, i, keep_tags):
    edges, tags = data[f"edges_{i}"], data[f"tags_{i}"]
    return edges[np.isin(tags, keep_tags)]


def plot(reports: list[str], png: str, rigid: str | None = None) -> None:
    """One row per run: its profiles every PROFILE_EVERY s (the last in red; the rigid-bed
    run's profile nearest to that time dashed, and its final deposit dotted), and a zoom on
    the last profile's nodes around the place where it failed; then front against time."""
    import re

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    from dpcollapse.geometry.mesher import RIGHT, SURFACE

    free = [SURFACE, RIGHT]
    rows = len(reports) + 1
    fig = plt.figure(figsize=(13, 3.3 * rows))
    grid = fig.add_gridspec(rows, 3)
    ref = ref_data = None
    if rigid:
        ref = json.loads(Path(rigid).read_text())
        ref_data = np.load(rigid[:-5] + ".npz")
    cmap = plt.get_cmap("viridis")
    front_ax = fig.add_subplot(grid[-1, :])
    for row, path in enumerate(reports):
        ax, zoom = fig.add_subplot(grid[row, :2]), fig.add_subplot(grid[row, 2])
        rep = json.loads(Path(path).read_text())
        data = np.load(path[:-5] + ".npz")
        times = data["times"]
        for i, t in enumerate(times):
            last = i == len(times) - 1
            ax.add_collection(LineCollection(_profile(data, i, free), linewidths=1.4 if last else 0.7,
                                             colors=["r" if last else cmap(t / max(times.max(), 1e-9))]))
        if ref is not None:
            rtimes = ref_data["times"]
            j = int(np.argmin(np.abs(rtimes - times[-1])))
            ax.add_collection(LineCollection(_profile(ref_data, j, free), colors="k", linestyles="--",
                                             linewidths=0.9, label=f"rigid bed, t = {rtimes[j]:.3f} s"))
            ax.add_collection(LineCollection(_profile(ref_data, len(rtimes) - 1, free), colors="0.4",
                                             linestyles=":", linewidths=0.9,
                                             label=f"rigid bed at rest, t = {rtimes[-1]:.3f} s"))
            ax.legend(fontsize=7, loc="upper right")
        ax.set_xlim(0, 0.85)
        ax.set_ylim(0, 0.27)
        ax.set_aspect("equal")
        s = rep["summary"] or {}
        ax.set_title(f"{Path(path).stem}: exit {rep['exit_code']}, t = {s.get('t', float('nan')):.3f} s, "
                     f"{s.get('steps')} steps, {s.get('remeshes')} remeshes (profiles every "
                     f"{PROFILE_EVERY} s, red: last accepted step)", fontsize=8)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        where = re.search(r"at \(([0-9.]+), ([0-9.]+)\) m", rep.get("error") or "")
        last_edges = _profile(data, len(times) - 1, free)
        if where:
            x0, y0 = map(float, where.groups())
            zoom.add_collection(LineCollection(last_edges, colors="r", linewidths=0.8))
            pts = last_edges.reshape(-1, 2)
            zoom.plot(pts[:, 0], pts[:, 1], "k.", ms=2)
            zoom.set_xlim(x0 - 0.006, x0 + 0.006)
            zoom.set_ylim(y0 - 0.004, y0 + 0.006)
            zoom.set_aspect("equal")
            zoom.set_title(f"last profile's nodes near the crossing ({x0:.4f}, {y0:.4f}) m",
                           fontsize=8)
        else:
            zoom.set_axis_off()
        front_ax.plot(rep["series"]["t"], rep["series"]["front"], label=Path(path).stem)
    if ref is not None:
        front_ax.plot(ref["series"]["t"], ref["series"]["front"], "k--", label="rigid bed")
    front_ax.set_xlabel("t [s]")
    front_ax.set_ylabel("front [m]")
    front_ax.legend(fontsize=8)
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
    p.add_argument("--rigid", help="the .json of a rigid-bed run to compare with")
    args = parser.parse_args(argv)
    if args.command == "run":
        return run(args.config, args.out, args.set)
    plot(args.reports, args.png, args.rigid)
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(REPO))
    sys.exit(main())
