"""The dam break on a step (``geometry.shape: dambreak_step``, added as one scene file, its
config class and a config file): the column released on the plateau falls over the step's
edge (the moving mesh's bed profile, ``ale.motion``), keeping its area, and no node enters
the step."""

import numpy as np
from mpi4py import MPI

from tests.helpers import simulation


def test_the_column_falls_over_the_step_keeping_its_area(tmp_path):
    """configs/dambreak_step.yaml on a 2 cm mesh to t = 0.16 s (x_e = 0.12 m, s = 0.05 m):
    the front passes the edge and the mass falls below the plateau (measured: front 0.1528 m,
    lowest node 0.0080 m), the area moves by 4.7e-6 of itself (1e-3 allowed: remeshes), and
    no node is ever inside the step x < x_e, y < s."""
    sim = simulation("dambreak_step.yaml", ["geometry.mesh_size=0.02", "time.end_time=0.16"],
                     tmp_path, comm=MPI.COMM_SELF)
    g = sim.cfg.geometry
    depth, lowest = [], []

    def observe(s):
        x = s.disc.mesh.geometry.x
        into = np.minimum(g.plateau_length - x[:, 0], g.step_height - x[:, 1])
        depth.append(float(into.max()))          # > 0: a node inside the step
        lowest.append(float(x[:, 1].min()))
        return False

    summary = sim.run(observers=[observe])
    assert summary["status"] == "end_time"
    assert summary["front"] > g.plateau_length + 0.02
    assert min(lowest) < g.step_height - 0.02
    assert abs(summary["area_drift"]) < 1e-3
    assert max(depth) <= 1e-12
