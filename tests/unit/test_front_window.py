"""The moving domain's thickness-front window (the film trim's cut face chooses repose or
vertical by the front's speed since the last remesh) is in the checkpoint: a resumed run
continues the uninterrupted run's window instead of starting a new one at the resume."""

import json
import math

from dpcollapse.domain.moving import MovingDomain
from dpcollapse.loop import LoopState


def _step(domain, state, t, x_f):
    state.t = t
    domain.check_step({"thick_front": x_f, "kinetic_energy": 0.0, "gravity_moment": 0.0,
                       "min_angle": 30.0}, state)


def _domain():
    return MovingDomain(12.0, 0.01, trim_thickness=1e-3, trim_face_slope=0.6, trim_face_speed=0.1)


def test_a_resumed_run_keeps_the_front_window():
    fronts = [(0.10, 0.300), (0.11, 0.302), (0.12, 0.3035), (0.13, 0.3040), (0.14, 0.3042)]
    whole, state = _domain(), LoopState()
    for t, x in fronts[:3]:
        _step(whole, state, t, x)
    saved = json.loads(json.dumps(state.to_dict()))          # the checkpoint at t = 0.12 s
    resumed, restored = _domain(), LoopState.from_dict(saved)
    for t, x in fronts[3:]:
        _step(whole, state, t, x)
        _step(resumed, restored, t, x)
        # over the window since t = 0.10 s, not since the resume at 0.12 s
        assert resumed.front_speed == whole.front_speed
    assert whole.front_speed == (0.3042 - 0.300) / (0.14 - 0.10)


def test_a_remesh_starts_a_new_window_and_the_checkpoint_says_so():
    domain, state = _domain(), LoopState()
    _step(domain, state, 0.10, 0.300)
    _step(domain, state, 0.11, 0.302)
    assert state.front_window[:2] == [0.10, 0.300]
    domain._front_since, state.front_window = None, None    # what ``remeshed`` does
    resumed = _domain()
    resumed.check_step({"thick_front": 0.303, "kinetic_energy": 0.0, "gravity_moment": 0.0,
                        "min_angle": 30.0}, LoopState.from_dict(json.loads(json.dumps(state.to_dict()))))
    assert math.isinf(resumed.front_speed)        # one step of a new window: speed unknown
