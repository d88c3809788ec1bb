"""The model ladder (studies.ladder) in its --quick form: two tiny 2D column runs
(3 cm cells: Coulomb to 0.1 s, μ(I) to rest) and their Savage–Hutter twins; the table's
structure, mass conservation of both rungs, the cost ratio, the early front, the μ(I) runout
ordering, and that a second call reuses the CSV."""

import csv
import math

import numpy as np

from studies import ladder
from studies.cli import main as cli_main


def test_ladder_quick(tmp_path):
    out, work = tmp_path / "out", tmp_path / "runs"
    assert ladder.main(["--quick", "--out", str(out), "--work", str(work)]) == 0
    with (out / "ladder.csv").open() as fh:
        reader = csv.DictReader(fh)
        assert reader.fieldnames == ladder.COLUMNS
        rows = list(reader)
    assert [r["case"] for r in rows] == ["column_a2_quick", "column_a2_mui_quick"]
    text_keys = ("case", "group", "config", "overrides", "status_2d", "status_sh", "within_5pct",
                 "sh_friction", "status_sh_k", "status_sh_ka")
    r, mui = ({k: (v if k in text_keys or v == "" else float(v)) for k, v in row.items()}
              for row in rows)   # "": a rung not run (the two-phase one)
    assert r["status_2d"] == "end_time" and r["status_sh"] == "end_time"
    assert math.isclose(r["t_end_2d"], 0.1) and math.isclose(r["t_end_sh"], 0.1)
    # mass: the 2D domain keeps its area (ALE, measured −7e-4 at 3 cm), SH to round-off
    assert abs(r["area_drift_2d"]) < 5e-3
    assert r["mass_error_sh"] < 1e-12
    # both deposit profiles on the SH grid hold the column's area (0.14 × 0.07 m²):
    # the L1 difference of two profiles of equal mass is at most twice that mass
    assert 0 < r["l1_diff_m2"] <= 2 * 0.14 * 0.07 * (1 + 5e-3)
    # the 2D run costs more than the depth-averaged one
    assert r["cost_ratio_cpu"] > 1 and r["cost_ratio"] > 1
    # at 0.1 s the depth-averaged column has spread as a dam break (front speed ~2√(g H0)) while
    # the 2D column is still falling: the SH front is ahead (measured 0.167 m against 0.032 m)
    assert r["runout_sh"] > 2 * r["runout_2d"] > 0
    assert (out / "ladder.png").stat().st_size > 10_000
    # the same depth-averaged run with Savage–Hutter's K (δ = φ = 25.5°: K = 1 + 2 tan²φ = 1.455
    # > 1) spreads faster, with Rankine's K_a = 0.398 slower than with K = 1
    assert math.isclose(r["k_act"], 1.455011, rel_tol=1e-5) and r["k_act"] == r["k_pass"]
    assert math.isclose(r["k_rankine"], 0.398102, rel_tol=1e-5)
    assert r["runout_sh_k"] > r["runout_sh"] > r["runout_sh_ka"] > 0
    assert math.isclose(r["runout_diff_k"], (r["runout_sh_k"] - r["runout_2d"]) / r["runout_2d"],
                        rel_tol=1e-5)
    text = ladder.table(ladder.read_rows(out / "ladder.csv"))
    assert text.count("\n") == 3 and "column_a2_quick" in text

    # μ(I) in both rungs (seed 004's fit), to rest: both conserve mass, the depth-averaged runout
    # is the shorter one — the seeds' ordering 2D > SH — by about 9 % (measured −9.4 % here,
    # −9.2 % with 1 cm cells and Δx = 1 mm, docs/ladder.md)
    assert mui["status_2d"] == "at_rest" and mui["status_sh"] == "at_rest"
    assert mui["sh_friction"].startswith("rheology MuIFriction")
    assert abs(mui["area_drift_2d"]) < 1e-2 and mui["mass_error_sh"] < 1e-12
    assert -0.2 < mui["runout_diff"] < 0 and mui["runout_sh"] < mui["runout_2d"]
    assert mui["cost_ratio_cpu"] > 1

    # a second call (the `python -m studies ladder` subcommand) finds the case in the CSV and does
    # not run it again
    (work / "column_a2_quick" / "run.json").unlink()
    assert cli_main(["ladder", "--quick", "--out", str(out), "--work", str(work)]) == 0
    assert not (work / "column_a2_quick" / "run.json").exists()
    series = ladder.read_series(out / "ladder_series.csv")
    assert {("column_a2_quick", rung, kind) for rung in ("2d", "sh")
            for kind in ("front", "profile")} <= set(series)


def _half_digit(x: float) -> float:
    """Half a unit in the 6th significant digit of x (the CSV's rounding)."""
    return 0.5 * 10.0 ** (math.floor(math.log10(abs(x))) - 5) if x else 0.0


def test_ladder_two_phase_rung_quick(tmp_path):
    """--two-phase adds the two-phase rung to a case of the CSV (the quick Coulomb column at
    L0/4 = 1.75 cm cells, to the 2D rung's end time 0.1 s; measured 8 s CPU): the same time,
    the column's area in its deposit profile, the front ahead of the wall, the table and the
    chart; a second call finds it in the CSV."""
    out, work = tmp_path / "out", tmp_path / "runs"
    only = ["--only", "column_a2_quick", "--out", str(out), "--work", str(work)]
    assert ladder.main(["--quick", *only]) == 0
    assert ladder.main(["--quick", "--two-phase", *only]) == 0
    r = ladder.read_rows(out / "ladder.csv")[0]
    assert r["status_tp"] == "end_time" and math.isclose(r["t_end_tp"], 0.1)
    assert math.isclose(r["cell_tp"], 0.07 / 4)
    assert math.isclose(r["ritter_speed"], 2 * math.sqrt(9.81 * 0.14), rel_tol=1e-5)   # 6 digits
    assert 0 < r["runout_tp"] and 0 < r["height_tp"] <= 0.14
    # the CSV keeps 6 significant digits: the difference of two rounded runouts carries their
    # rounding, δd ≤ δa/b + a δb/b² + δd_own (a = runout_tp, b = runout_2d)
    a, b, d = r["runout_tp"], r["runout_2d"], r["runout_diff_tp"]
    bound = _half_digit(a) / b + a * _half_digit(b) / b**2 + _half_digit(d)
    assert abs(d - (a - b) / b) <= bound, (d, a, b)
    series = ladder.read_series(out / "ladder_series.csv")
    x, h = series[("column_a2_quick", "tp", "profile")].T
    area = float(np.sum(0.5 * (h[1:] + h[:-1]) * np.diff(x)))   # of the stored (thinned) profile
    assert abs(area - 0.14 * 0.07) < 0.03 * 0.14 * 0.07          # measured 2.3 % short
    assert ("column_a2_quick", "tp", "front") in series
    assert "column_a2_quick" in ladder.tp_table([r])
    assert (out / "ladder_two_phase.png").stat().st_size > 10_000
    (work / "column_a2_quick_tp" / "run.json").unlink()
    assert ladder.main(["--quick", "--two-phase", *only]) == 0
    assert not (work / "column_a2_quick_tp" / "run.json").exists()


def test_ladder_unknown_case_is_one_line(tmp_path, capsys):
    """An unknown case name: exit 2, one line naming the case, nothing run or written."""
    assert cli_main(["ladder", "--only", "no_such_case", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "no_such_case" in err and "column_a2" in err
    assert ladder.main(["--sh-resolution", "nope", "--out", str(tmp_path)]) == 2
    assert not any(tmp_path.iterdir())
