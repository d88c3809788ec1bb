"""The stop watchdog (``dpcollapse.watchdog``, issue 47): after SIGINT/SIGTERM the main
thread has STOP_BOUND seconds to reach a safe point; if it does not, run.json becomes
``interrupted`` with the reason, one line goes to stderr and the process exits 130. Each
case runs in a child process (the watchdog ends the process)."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import time

import pytest

from tests.helpers import ROOT, clean_env

_CHILD = textwrap.dedent("""
    import json, os, signal, sys, time
    from pathlib import Path
    from dpcollapse import watchdog
    native, mode, run_json = sys.argv[1] == "native", sys.argv[2], Path(sys.argv[3])
    watchdog.install(native=native)
    assert (watchdog._native is not None) == native
    watchdog.arm()
    run_json.write_text(json.dumps({"status": "running", "summary": {}}))
    watchdog.prepare(run_json, {"status": "running", "summary": {"t": 0.5}},
                     "the last checkpoint (step 7, t = 0.5000 s) is whole")
    signal.signal(signal.SIGTERM, lambda *args: None)   # the loop's handler: records only
    os.kill(os.getpid(), signal.SIGTERM)
    start = time.monotonic()
    if mode == "stuck":            # never at a safe point (a step that never ends)
        while True:
            sum(range(1000))
    time.sleep(0.5)
    watchdog.safe_point()          # the end of the step: the loop honours the request
    time.sleep(3)
    print("ended normally")
""")


def _child(tmp_path, native: bool, mode: str):
    env = {**clean_env(), "DPCOLLAPSE_STOP_BOUND": "1.5"}
    t0 = time.monotonic()
    done = subprocess.run([sys.executable, "-c", _CHILD, "native" if native else "python",
                           mode, str(tmp_path / "run.json")], env=env, cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    return done, time.monotonic() - t0


@pytest.mark.parametrize("native", [True, False], ids=["native", "python"])
def test_no_safe_point_within_the_bound_is_an_interrupt(tmp_path, native):
    done, seconds = _child(tmp_path, native, "stuck")
    assert done.returncode == 130, done.stderr[-2000:]
    assert 1.5 <= seconds < 60
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("dpcollapse: error: interrupted: "), lines
    assert "within 1.5 s of the stop request" in lines[0] and "--resume" in lines[0]
    info = json.loads((tmp_path / "run.json").read_text())
    assert info["status"] == "interrupted" and info["summary"]["t"] == 0.5
    assert "step 7" in info["summary"]["error"]
    assert not list(tmp_path.glob("*.tmp"))


@pytest.mark.parametrize("native", [True, False], ids=["native", "python"])
def test_a_safe_point_within_the_bound_lets_the_loop_stop(tmp_path, native):
    done, _ = _child(tmp_path, native, "safe")
    assert done.returncode == 0 and "ended normally" in done.stdout, done.stderr[-2000:]
    assert json.loads((tmp_path / "run.json").read_text())["status"] == "running"
