"""``python -m studies stability plug --quick`` and ``rigid --quick`` (reduced cell sets): the classes
of known cells of the map, the Newton fallback column, the CSV and PNG, and bad input → exit 2."""

import csv
import subprocess

import pytest

from tests.helpers import ROOT, studies_cmd


def _run_map(out, *args):
    proc = subprocess.run(studies_cmd() + ["stability", *args, "--out", str(out)],
                          capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc


@pytest.fixture(scope="module")
def quick_map(tmp_path_factory):
    out = tmp_path_factory.mktemp("stability")
    _run_map(out, "plug", "--quick", "--methods", "newton,picard", "--cap", "4")
    with (out / "stability_plug.csv").open() as f:
        rows = {(r["method"], float(r["epsilon"])): r for r in csv.DictReader(f)}
    return out, rows


def test_quick_map_classes(quick_map):
    """At t = 0.8 s (ΔX 1 cm, Δt 4 ms, tolerance 3e-2): ε = 1e-1 converges but is wrong
    (regularization error 6e-2), Newton at ε = 1e-6 is accurate (1.6e-2), and plain Picard
    needs thousands of iterations after the static layer appears: too slow at a 4 CPU-second cap (Newton:
    about 1 s)."""
    out, rows = quick_map
    assert rows[("newton", 0.1)]["class"] == "wrong"
    assert float(rows[("newton", 0.1)]["error"]) > 3e-2
    assert rows[("newton", 1e-6)]["class"] == "accurate"
    assert float(rows[("newton", 1e-6)]["error"]) <= 3e-2
    assert int(rows[("newton", 1e-6)]["factorizations"]) < 1000
    assert rows[("picard", 1e-6)]["class"] == "too_slow"
    assert (out / "stability_plug.png").stat().st_size > 10_000


def test_quick_map_fallback_columns(quick_map):
    """The fallback count is Newton's alone (Picard runs report 0). On the plug Newton needs
    none at ε = 1e-1 and carries nearly every step at ε = 1e-6 (measured: 2 fallbacks in 200
    steps, after the static layer appears); no step is halved in the runs that finish. (Plain
    Picard at ε = 1e-6 is stopped by the CPU cap near t = 0.72 s, where its steps start to
    be halved: how many it halves before the cap depends on the CPU's speed, 1 to 5 measured.)"""
    _, rows = quick_map
    assert int(rows[("newton", 0.1)]["fallbacks"]) == 0
    assert int(rows[("newton", 1e-6)]["fallbacks"]) < int(rows[("newton", 1e-6)]["steps"]) / 10
    for key in [("picard", 0.1), ("picard", 1e-6)]:
        assert int(rows[key]["fallbacks"]) == 0, key
    for key in rows:
        if rows[key]["class"] != "too_slow":
            assert int(rows[key]["halvings"]) == 0, key


def test_rigid_quick_newton_falls_back(tmp_path):
    """On the collapse (4 cm, Δt 1 ms, ε = ε_f = 1e-6, to t = 0.1 s) Newton's front is within
    the 1 cm tolerance of the reference (augmented Lagrangian, Δt 0.5 ms, rtol 1e-4), but only
    with Picard redoing steps Newton failed (the wall friction at ε_f = 1e-6 m/s): the
    fallback count is > 0 and the map draws the mark open."""
    _run_map(tmp_path, "rigid", "--quick", "--methods", "newton", "--epsilons", "1e-6", "--end-time", "0.1")
    with (tmp_path / "stability_rigid.csv").open() as f:
        (row,) = list(csv.DictReader(f))
    assert row["class"] == "accurate", row
    assert float(row["error"]) <= 0.01
    assert int(row["fallbacks"]) > 0
    assert (tmp_path / "reference_rigid.json").is_file()
    assert (tmp_path / "stability_rigid.png").stat().st_size > 10_000


def test_front_at_compare_time_is_interpolated(tmp_path):
    """The rigid compare value is the front at the compare time, linear between the steps
    that bracket it (not the front of the first step past it), from the running map and from
    a run's diagnostics.csv alike."""
    from studies.stability import fronts_from_diagnostics, interpolate

    assert interpolate((0.096, 0.30), (0.104, 0.31), 0.1) == pytest.approx(0.305)
    assert interpolate((0.1, 0.30), (0.1, 0.31), 0.1) == 0.31
    path = tmp_path / "diagnostics.csv"
    path.write_text("t,front\n0.004,0.3\n0.104,0.4\n0.2,0.5\n")
    values = fronts_from_diagnostics(path, [0.1, 0.2], front0=0.297)
    assert values[0.1] == pytest.approx(0.3 + 0.1 * 0.096 / 0.1)
    assert values[0.2] == pytest.approx(0.5)
    assert values["front0"] == 0.297


@pytest.mark.parametrize("args, key", [(["--methods", "bisection"], "--methods"),
                                       (["--epsilons", "1e-2,abc"], "--epsilons"),
                                       (["--cap", "-1"], "--cap")])
def test_bad_input_exit_2(args, key, tmp_path):
    proc = subprocess.run(studies_cmd() + ["stability", "plug", "--quick", "--out", str(tmp_path), *args],
                          capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert key in proc.stderr and "Traceback" not in proc.stderr
