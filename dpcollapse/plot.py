"""``dpcollapse plot RUN_DIR``: free-surface profiles and the front position (PNG); for a
depth-averaged run (a line mesh), the thickness h(x) and velocity ū(x) profiles.

Reads only what a run writes for its users — ``solution.xdmf`` (and the HDF5 files it
points to), ``diagnostics.csv`` and run.json's ``history_plot`` (the panel the model
declared for its diagnostics over time: ``HISTORY_PLOTS``) — so it plots any run, finished
or not.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np

from dpcollapse.errors import ConfigError
from dpcollapse.io.diagnostics import read_diagnostics
from dpcollapse.io.runinfo import read_history_plot

#: Tolerance to tell bed (y = 0) and wall (x = 0) edges from the free surface [m].
BOUNDARY_TOL = 1e-9


def _dataset(run_dir: Path, text: str) -> np.ndarray:
    """An HDF5 dataset a master names (``file.h5:/path``); a missing, truncated or damaged
    file is ConfigError naming it (a run directory the command cannot read: exit 2)."""
    filename, _, path = (text or "").strip().partition(":")
    try:
        with h5py.File(run_dir / filename, "r") as f:
            return f[path][()]
    except (OSError, KeyError, ValueError) as exc:
        why = "missing" if not (run_dir / filename).exists() else "cannot be read"
        raise ConfigError(f"RUN_DIR = {run_dir}: {filename} ({path}), listed in solution.xdmf, "
                          f"is {why} ({' '.join(str(exc).split())[:80]}); resume the run "
                          "(--resume drops unreadable steps) or run it again") from None


def _master(run_dir: Path) -> ET.Element:
    """The parsed solution.xdmf; a damaged one is ConfigError naming it."""
    try:
        return ET.parse(run_dir / "solution.xdmf").getroot()
    except ET.ParseError as exc:
        raise ConfigError(f"RUN_DIR = {run_dir}: solution.xdmf is damaged ({exc})") from None


def read_series(run_dir: Path) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """(t, node coordinates, triangles) for every time in ``solution.xdmf``."""
    root = _master(run_dir)
    series = []
    for grid in root.iter("Grid"):
        time = grid.find("Time")
        topo, geom = grid.find("Topology"), grid.find("Geometry")
        if time is None or topo is None or geom is None:
            continue
        x = _dataset(run_dir, geom.find("DataItem").text)
        cells = _dataset(run_dir, topo.find("DataItem").text)
        series.append((float(time.get("Value")), x[:, :2], cells.astype(np.int64)))
    return sorted(series, key=lambda s: s[0])


def read_cell_field(run_dir: Path, name: str) -> list[tuple[float, np.ndarray]]:
    """(t, cell values) of the cell attribute ``name`` for every time that has it."""
    root = _master(run_dir)
    out = []
    for grid in root.iter("Grid"):
        time = grid.find("Time")
        for attr in grid.iter("Attribute"):
            if attr.get("Name") == name and attr.get("Center") == "Cell" and time is not None:
                out.append((float(time.get("Value")), _dataset(run_dir, attr.find("DataItem").text).ravel()))
    return sorted(out, key=lambda s: s[0])


def free_surface(x: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Ordered points of the free surface (boundary edges not on the bed or the wall)."""
    edges = np.sort(np.concatenate([cells[:, [0, 1]], cells[:, [1, 2]], cells[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    boundary = unique[counts == 1]
    on_bed = np.all(np.abs(x[boundary, 1]) < BOUNDARY_TOL, axis=1)
    on_wall = np.all(np.abs(x[boundary, 0]) < BOUNDARY_TOL, axis=1)
    surf = boundary[~on_bed & ~on_wall]
    if len(surf) == 0:
        return np.zeros((0, 2))
    # chain the edges, starting at the wall end (smallest x)
    neighbours: dict[int, list[int]] = {}
    for a, b in surf:
        neighbours.setdefault(int(a), []).append(int(b))
        neighbours.setdefault(int(b), []).append(int(a))
    ends = [n for n, nb in neighbours.items() if len(nb) == 1]
    start = min(ends or neighbours, key=lambda n: x[n, 0])
    order, prev = [start], None
    while True:
        nxt = [n for n in neighbours[order[-1]] if n != prev]
        if not nxt or nxt[0] == start:
            break
        prev = order[-1]
        order.append(nxt[0])
    return x[order]


def _plot_profiles(run_dir: Path, series, picks, ax_h, ax_u, cmap) -> None:
    """Depth-averaged runs: h(x) and ū(x) (cell data on the line mesh) at the picked times."""
    fields = {name: dict(read_cell_field(run_dir, name)) for name in ("thickness", "velocity")}
    for j, i in enumerate(picks):
        t, x, cells = series[i]
        centres = x[cells, 0].mean(axis=1)
        order = np.argsort(centres)
        colour = cmap(j / max(len(picks) - 1, 1))
        for ax, name in ((ax_h, "thickness"), (ax_u, "velocity")):
            values = fields[name].get(t)
            if values is not None and len(values) == len(centres):
                ax.step(centres[order], values[order], where="mid", color=colour, label=f"t = {t:.3f} s")
    ax_u.set_xlabel("x [m]")
    ax_u.set_ylabel("depth-averaged velocity ū [m/s]")
    ax_u.grid(alpha=0.3)


def _plot_discharge(ax, d) -> None:
    """A bin's discharge: Q(t) from the orifice flux and −dm/dt of the bin's mass [kg/(m s)],
    the fill height H(t) on the right axis [m]."""
    t = np.asarray(d["t"])
    ax.plot(t, d["discharge_rate"], label="Q, flux through the orifice")
    if len(t) > 2:
        ax.plot(t, -np.gradient(np.asarray(d["bin_mass"]), t), "--", lw=1,
                label="−dm/dt of the bin's mass")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("Q [kg/(m s)]")
    ax.grid(alpha=0.3)
    right = ax.twinx()
    right.plot(t, d["fill_height"], color="k", lw=1, label="fill height H (right axis)")
    right.set_ylabel("H [m]")
    lines = ax.get_legend_handles_labels()
    more = right.get_legend_handles_labels()
    ax.legend(lines[0] + more[0], lines[1] + more[1], fontsize=8)


def _plot_front(ax, d) -> None:
    """The front position and the maximum height over time [m]."""
    ax.plot(d["t"], d["front"], label="front position (furthest x of the mass)")
    ax.plot(d["t"], d["max_height"], label="maximum height")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("[m]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)


#: the panels of the diagnostics over time, by the name a model declares
#: (``loop.Discretization.history_plot``, written to run.json)
HISTORY_PLOTS = {"front": _plot_front, "discharge": _plot_discharge}


def plot_run(run_dir: Path, times: list[float] | None = None) -> Path:
    """Draw profiles at ``times`` (default: six output times) and front vs time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run_dir = Path(run_dir)
    if not (run_dir / "solution.xdmf").exists():
        raise ConfigError(f"RUN_DIR = {run_dir}: no solution.xdmf there (is it a run directory?)")
    series = read_series(run_dir)
    if not series:
        raise ConfigError(f"RUN_DIR = {run_dir}: solution.xdmf lists no output step")
    available = np.array([s[0] for s in series])
    if times:
        lo, hi = float(available.min()), float(available.max())
        gap = float(np.max(np.diff(available))) if len(available) > 1 else 0.0
        outside = [t for t in times if t < lo - gap or t > hi + gap]
        if outside:
            raise ConfigError(f"--times = {','.join(f'{t:g}' for t in outside)}: outside the run's "
                              f"output times [{lo:g}, {hi:g}] s")
        picks = sorted({int(np.argmin(np.abs(available - t))) for t in times})
    else:
        picks = sorted(set(np.linspace(0, len(series) - 1, min(6, len(series))).round().astype(int)))

    profile = series[0][2].shape[1] == 2   # a line mesh: the depth-averaged model's grid
    rigid = read_cell_field(run_dir, "rigid")   # augmented Lagrangian runs only
    if profile:
        fig, (ax1, ax3, ax2) = plt.subplots(3, 1, figsize=(8, 10), gridspec_kw={"height_ratios": [3, 2, 2]})
    elif rigid:
        fig, (ax1, ax3, ax2) = plt.subplots(3, 1, figsize=(8, 11), gridspec_kw={"height_ratios": [3, 2, 2]})
    else:
        fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 8), gridspec_kw={"height_ratios": [3, 2]})
    cmap = plt.get_cmap("viridis")
    if profile:
        _plot_profiles(run_dir, series, picks, ax1, ax3, cmap)
    for j, i in enumerate(picks if not profile else ()):
        t, x, cells = series[i]
        surf = free_surface(x, cells)
        ax1.plot(surf[:, 0], surf[:, 1], color=cmap(j / max(len(picks) - 1, 1)), label=f"t = {t:.3f} s")
    ax1.axhline(0.0, color="k", lw=1)
    ax1.set_xlabel("x [m]")
    ax1.set_ylabel("y [m]" if not profile else "thickness h [m]")
    if not profile:
        ax1.set_aspect("equal")
    ax1.legend(fontsize=8)
    ax1.set_title(f"Free surface — {run_dir.name}" if not profile else
                  f"Thickness profiles h(x), depth-averaged model — {run_dir.name}")

    if rigid and not profile:  # exact rigid zone (γ̇ = 0) at the output time nearest to a third of the run
        k = int(np.argmin(np.abs(np.array([r[0] for r in rigid]) - available[-1] / 3)))
        t_r, values = rigid[k]
        i = int(np.argmin(np.abs(available - t_r)))
        _, x, cells = series[i]
        if len(values) == len(cells):
            ax3.tripcolor(x[:, 0], x[:, 1], cells, facecolors=values, cmap="Greys", vmin=-0.3, vmax=1.3,
                          edgecolors="none")
            ax3.set_aspect("equal")
            ax3.set_title(f"t = {t_r:.3f} s: rigid zone (dark, γ̇ = 0 exactly) and flowing zone (light)")
            ax3.set_xlabel("x [m]")
            ax3.set_ylabel("y [m]")

    diag_path = run_dir / "diagnostics.csv"
    if diag_path.exists():
        d = read_diagnostics(diag_path)
        if d:
            HISTORY_PLOTS[read_history_plot(run_dir / "run.json")](ax2, d)
    fig.tight_layout()
    out = run_dir / "collapse.png"
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out
