"""The typed loop state (what a checkpoint stores), old checkpoints, and the run's events."""

import json
import shutil

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse.io.diagnostics import read_diagnostics
from dpcollapse.loop import Events, LoopState
from tests.helpers import RIGID_BDF1, ROOT, simulation

#: A checkpoint written by the code before the redesign (commit d1fd579, dict state) at
#: step 20 of this run, with its diagnostics.
OLD_RUN = ROOT / "tests/data/checkpoint_d1fd579"
#: the old checkpoint's run: rigid.yaml's fixed 1 ms BDF1 step and implicit convection of that time
OVERRIDES = ["geometry.mesh_size=0.04", "time.checkpoint_every=10", "time.output_every=10",
             *RIGID_BDF1, "numerics.convection=implicit"]


def test_state_round_trip_leaves_out_what_is_unset():
    st = LoopState(t=0.5, step=3, dt_target=1e-3, area0=0.06)
    d = st.to_dict()
    assert "landings" not in d and "remesh_angle_after" not in d
    assert LoopState.from_dict(json.loads(json.dumps(d))) == st


def test_old_checkpoint_state_loads_with_unknown_keys_kept():
    old = json.loads(str(np.load(OLD_RUN / "checkpoint.npz")["state"]))
    st = LoopState.from_dict({**old, "from_the_future": 1})
    assert (st.t, st.step, st.checkpoint_step) == (0.02, 20, 20)
    assert st.kinetic_energy_previous == old["kinetic_energy_previous"]
    assert st.to_dict() == {**old, "from_the_future": 1}


def test_resume_from_an_old_checkpoint_continues_the_run(tmp_path):
    """Resuming the old code's checkpoint gives the diagnostics of an uninterrupted run of
    this code (steps 21–30)."""
    run = tmp_path / "old"
    shutil.copytree(OLD_RUN, run)
    over = OVERRIDES + ["time.end_time=0.03"]
    simulation("rigid.yaml", over, run, comm=MPI.COMM_SELF, resume=True).run()
    simulation("rigid.yaml", over, tmp_path / "full", comm=MPI.COMM_SELF).run()
    resumed, full = (
        read_diagnostics(run / "diagnostics.csv"),
        read_diagnostics(tmp_path / "full" / "diagnostics.csv"),
    )
    assert resumed["step"] == full["step"] == list(range(1, 31))
    for key in ("t", "front", "max_height", "kinetic_energy", "max_speed"):
        np.testing.assert_allclose(resumed[key], full[key], rtol=1e-6, atol=1e-12, err_msg=key)


def test_events_in_order_and_a_subscriber_stops_the_run(tmp_path):
    """discretization at the start and at each remesh, output at t = 0 and every N steps,
    step_accepted per step; True from a step_accepted subscriber stops the run."""
    seen = []
    events = Events()
    events.subscribe("discretization", lambda sim, disc: seen.append(("discretization", sim.state.step)))
    tagged_cells = []
    events.subscribe(
        "discretization", lambda sim, disc: tagged_cells.append(disc.tagged.cell_tags is not None)
    )
    events.subscribe("output", lambda sim, t: seen.append(("output", round(t, 9))))
    events.subscribe("remesh", lambda sim, info: seen.append(("remesh", info["reason"][:9])))
    events.subscribe(
        "step_accepted", lambda sim, row: seen.append(("step", row["step"])) or row["step"] == 12
    )
    summary = simulation("rigid.yaml", [*RIGID_BDF1, "geometry.mesh_size=0.04", "time.end_time=0.05",
                                        "numerics.remesh_min_angle=59", "time.output_every=10"],
                         tmp_path, comm=MPI.COMM_SELF, events=events).run()
    assert summary["status"] == "stopped_by_observer" and summary["steps"] == 12
    assert seen[0] == ("discretization", 0) and seen[1] == ("output", 0.0)
    assert [e for e in seen if e[0] == "step"] == [("step", k) for k in range(1, 13)]
    remeshes = [i for i, e in enumerate(seen) if e[0] == "remesh"]
    assert len(remeshes) == summary["remeshes"] >= 1
    assert all(seen[i - 1][0] == "discretization" for i in remeshes)   # the new mesh, then the event
    assert ("output", 0.01) in seen and seen[-1] == ("output", 0.012)
    assert len(tagged_cells) >= 2 and all(tagged_cells)   # a remesh keeps the cell tags


def test_unknown_event_is_refused():
    with pytest.raises(ValueError, match="step_acepted"):
        Events().subscribe("step_acepted", print)


def test_domains_implement_the_protocol():
    """Both domains answer every question of domain.base.Domain; the fixed one never limits
    the step nor moves."""
    import math

    from dpcollapse.config import load_config
    from dpcollapse.domain.base import Domain, make_domain
    from dpcollapse.domain.fixed import FixedDomain
    from dpcollapse.domain.moving import MovingDomain

    names = [n for n in vars(Domain) if not n.startswith("_")] + list(Domain.__annotations__)
    for cls in (FixedDomain, MovingDomain):
        assert all(hasattr(cls, n) or n == "solves" for n in names), cls
    fixed = make_domain(load_config(ROOT / "configs/plug.yaml"))
    assert isinstance(fixed, FixedDomain) and not fixed.moving
    assert fixed.limit_step(None, 1e-3) == math.inf and fixed.move(None, 1e-3) == (None, None)
    assert fixed.needs_remesh(None, LoopState()) is None
    moving = make_domain(load_config(ROOT / "configs/rigid.yaml"))
    assert isinstance(moving, MovingDomain) and moving.moving and moving.mesh_size == 0.01


def test_event_counts_are_checkpoint_entries_of_their_own_and_continue_on_resume():
    """A named event's count is stored under its name (``landings``, as before events were
    named), and a resumed run continues it; an event a checkpoint lacks starts at 0."""
    st = LoopState(t=0.5)
    st.count_events(("landings",))
    st.add_events({"landings": 3})
    d = st.to_dict()
    assert d["landings"] == 3 and "event_counts" not in d
    back = LoopState.from_dict(json.loads(json.dumps(d)))
    assert back.extra == {"landings": 3}
    back.count_events(("landings", "surgery"))
    assert back.event_counts == {"landings": 3, "surgery": 0} and back.extra == {}
    assert back.to_dict() == {**d, "surgery": 0}


def test_moving_domain_counts_the_landings_of_accepted_moves_only(monkeypatch):
    """``MovingDomain.take_events``: the nose nodes that landed in moves that were kept; a
    move taken back (``undo``: a failed or rejected attempt) counts none."""
    from types import SimpleNamespace

    from dpcollapse.domain import moving

    monkeypatch.setattr(moving, "retag_bed", lambda tagged, bed_height: "retagged")
    landed = [2, 3, 0, 1]
    disc = SimpleNamespace(motion=SimpleNamespace(move=lambda dt: (None, landed.pop(0), 0),
                                                  bed_height=None),
                           tagged=None, mesh=SimpleNamespace(geometry=SimpleNamespace(x=np.zeros(3))))
    domain = moving.MovingDomain(30.0, 0.01)
    assert domain.counted_events == ("landings", "surgeries", "surgery_area_change")
    none = {"surgeries": 0, "surgery_area_change": 0.0}   # no remesh: no surgery
    assert domain.move(disc, 1e-3) == (None, "retagged")
    domain.undo(disc, np.zeros(3))          # the attempt failed: its 2 nodes are back up
    assert domain.move(disc, 5e-4) == (None, "retagged")
    assert domain.take_events() == {"landings": 3, **none}
    assert domain.move(disc, 1e-3) == (None, None)
    domain.move(disc, 1e-3)
    assert domain.take_events() == {"landings": 1, **none}
    assert domain.take_events() == {"landings": 0, **none}
