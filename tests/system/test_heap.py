"""The heap scene (``geometry.shape: heap``, added as one scene file, its config class and a
config file): a heap steeper than the friction angle spreads, one below it stands."""

from mpi4py import MPI

from tests.helpers import simulation


def test_a_heap_steeper_than_the_friction_angle_spreads(tmp_path):
    """Flank 45° > φ = 25.5°: in 0.1 s the top falls and the toe advances (measured on a
    2 cm mesh: max height 0.0803 m from 0.1, front 0.1031 m from 0.1)."""
    over = ["geometry.mesh_size=0.02", "time.end_time=0.1"]
    summary = simulation("heap.yaml", over, tmp_path, comm=MPI.COMM_SELF).run()
    assert summary["status"] == "end_time"
    assert summary["max_height"] < 0.09 and summary["front"] > 0.101
    assert abs(summary["area_drift"]) < 1e-3


def test_a_heap_below_the_friction_angle_stands(tmp_path):
    """Flank atan(0.0364/0.1) = 20° < φ: at rest within 0.1 s, neither toe nor top moved by
    10 µm (measured: 2e-8 and 3e-8 m)."""
    over = ["geometry.mesh_size=0.01", "geometry.height=0.0364", "time.end_time=0.1"]
    summary = simulation("heap.yaml", over, tmp_path, comm=MPI.COMM_SELF).run()
    assert summary["status"] == "at_rest"
    assert abs(summary["front"] - 0.1) < 1e-5 and abs(summary["max_height"] - 0.0364) < 1e-5
