"""Run a config and draw the mesh and the tagged boundary near the front at its last steps
(the diagnosis of the folding toe in docs/benchmarks/2026-12-01-column.md).

    python studies/benchmarks/column_fold_diagnosis.py CONFIG OUT_DIR [KEY=VALUE ...]
    -> OUT_DIR/toe.png (4 cm x 3 cm window), OUT_DIR/toe_zoom.png (1 cm x 2.5 mm window)

Free surface blue, bed black, wall green, cells grey; the panels are the 9th, 5th and
last accepted steps before the end (or the failure).
"""

from __future__ import annotations

import logging
import sys

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from dpcollapse import compat
from dpcollapse.config import load_config
from dpcollapse.geometry.mesher import BED, SURFACE
from dpcollapse.simulation import Simulation

COLOURS = {SURFACE: "b", BED: "k"}


def main(config: str, out: str, overrides: list[str]) -> None:
    logging.basicConfig(level=logging.WARNING)
    history = []

    def keep(sim) -> bool:
        mesh, ft = sim.disc.mesh, sim.disc.tagged.facet_tags
        x = mesh.geometry.x[:, :2]
        cells = compat.geometry_dofmap(mesh)[:compat.num_owned_cells(mesh)]
        history.append((sim.state.t, x[compat.entities_to_geometry(mesh, 1, ft.indices)].copy(),
                        np.asarray(ft.values).copy(), x[cells].copy(),
                        sim.state.event_counts.get("landings", 0), sim.state.remeshes))
        del history[:-12]
        return False

    sim = Simulation(load_config(config, overrides), out, quiet=True)
    try:
        print(sim.run([keep]))
    except Exception as exc:     # the failure is what we want to see
        print("FAIL", type(exc).__name__, exc)
    for name, (dx, ymax) in (("toe", (0.04, 0.03)), ("toe_zoom", (0.01, 0.0025))):
        fig, axes = plt.subplots(3, 1, figsize=(12, 10))
        for ax, k in zip(axes, [-9, -5, -1]):
            t, edges, tags, tri, landings, remeshes = history[k]
            for cell in tri:
                ax.fill(cell[:, 0], cell[:, 1], fill=False, lw=0.3, color="0.6")
            for seg, tag in zip(edges, tags):
                ax.plot(seg[:, 0], seg[:, 1], "-o", ms=2, color=COLOURS.get(tag, "g"))
            xs = edges[:, :, 0].max()
            ax.set_xlim(xs - dx, xs + dx / 20)
            ax.set_ylim(-ymax / 12, ymax)
            ax.set_title(f"t = {t:.4f} s, landings {landings}, remeshes {remeshes}")
        fig.savefig(f"{out}/{name}.png", dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3:])
