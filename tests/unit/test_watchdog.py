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
    if mode == "finished":         # the run wrote its last run.json, then the signal came
        watchdog.final()
        run_json.write_text(json.dumps({"status": "end_time", "summary": {}}))
    if mode == "other_rank":       # rank 1 wrote "failed" and ended the job (MPI_Abort:
        run_json.write_text(json.dumps({"status": "failed", "summary": {}}))   # SIGTERM here)
    watchdog.prepare(run_json, {"status": "running", "summary": {"t": 0.5}},
                     "the last checkpoint (step 7, t = 0.5000 s) is whole")
    signal.signal(signal.SIGTERM, lambda *args: None)   # the loop's handler: records only
    os.kill(os.getpid(), signal.SIGTERM)
    start = time.monotonic()
    if mode == "stuck":            # never at a safe point (a step that never ends)
        while True:
            sum(range(1000))
    time.sleep(0.5)
    print("early:", json.dumps(json.loads(run_json.read_text())))   # while still in the step
    watchdog.safe_point()          # the end of the step: the loop honours the request
    if mode == "final":            # the loop's own last run.json replaces the early one
        watchdog.final()
        run_json.write_text(json.dumps({"status": "interrupted", "summary": {"t": 0.6}}))
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


def _early(done) -> dict:
    """run.json as the child read it 0.5 s after the signal, still inside its step."""
    line = next(ln for ln in done.stdout.splitlines() if ln.startswith("early: "))
    return json.loads(line[len("early: "):])


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
    # the early record (the loop replaces it with its own: the next test), not the fired one
    info = json.loads((tmp_path / "run.json").read_text())
    assert info["status"] == "interrupted" and "if this status stays" in info["summary"]["error"]
    assert not done.stderr.strip(), done.stderr


@pytest.mark.parametrize("native", [True, False], ids=["native", "python"])
def test_the_signal_writes_an_early_record_that_the_loop_replaces(tmp_path, native):
    """SIGTERM to mpirun: Open MPI forwards it and SIGKILLs the ranks 1 s later, before the
    step ends. run.json says ``interrupted`` at once (not ``running``), with the last
    checkpoint; the loop's own last write (after :func:`watchdog.final`) replaces it."""
    done, _ = _child(tmp_path, native, "final")
    assert done.returncode == 0 and "ended normally" in done.stdout, done.stderr[-2000:]
    early = _early(done)
    assert early["status"] == "interrupted" and early["summary"]["t"] == 0.5
    error = early["summary"]["error"]
    assert "stop request" in error and "step 7" in error and "if this status stays" in error
    assert json.loads((tmp_path / "run.json").read_text()) == {
        "status": "interrupted", "summary": {"t": 0.6}}
    assert not done.stderr.strip(), done.stderr
    assert not list(tmp_path.glob("*.tmp"))


@pytest.mark.parametrize("native", [True, False], ids=["native", "python"])
@pytest.mark.parametrize("mode, status", [("finished", "end_time"), ("other_rank", "failed")])
def test_no_early_record_over_a_run_json_that_says_how_the_run_ended(tmp_path, native, mode,
                                                                     status):
    """A signal after the run wrote its last run.json (:func:`watchdog.final`), or after
    another rank wrote ``failed`` and ended the job (Open MPI's abort sends SIGTERM to the
    others), leaves it."""
    done, _ = _child(tmp_path, native, mode)
    assert done.returncode == 0 and "ended normally" in done.stdout, done.stderr[-2000:]
    assert _early(done)["status"] == status
    assert json.loads((tmp_path / "run.json").read_text())["status"] == status
