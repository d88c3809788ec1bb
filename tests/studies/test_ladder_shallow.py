"""The shallow-limit plan and its ε-threshold table (studies.ladder): the family
(five ε from 0.5 to 0.05, five 2D cells across the thickness, the same material on every bed),
and the rule "the largest ε below which every measured ε is within the tolerance"."""

import math

from studies import ladder


def test_shallow_plan_family():
    plan = ladder.shallow_plan()
    groups = {}
    for case in plan:
        groups.setdefault(case.group, []).append(case)
    assert set(groups) == {"shallow_flat", "shallow_slope12", "shallow_slope18",
                           "shallow_flat_mui", "shallow_slope12_mui"}
    for members in groups.values():
        eps = sorted(c.param for c in members)
        assert len(eps) >= 5 and eps[0] == 0.05 and eps[-1] == 0.5
    for case in plan:
        cfg = case.load()
        g = cfg.geometry
        assert math.isclose(g.height / g.base_length, case.param, rel_tol=1e-5)
        assert g.height / g.mesh_size >= 5 - 1e-9           # cells across the thickness
        assert g.bed_angle < cfg.boundary.bed_friction_angle  # the mass stops
        assert cfg.material.friction_angle >= cfg.boundary.bed_friction_angle


def _rows(diffs):
    return [{"case": f"c{e}", "group": "g", "param": e, "status_2d": "at_rest", "runout_diff": d}
            for e, d in diffs]


def test_eps_threshold():
    rows = _rows([(0.5, 0.30), (0.3, 0.08), (0.2, 0.04), (0.1, -0.03), (0.05, 0.01)])
    assert ladder.eps_threshold(rows, "runout_diff", 0.05) == "≤ 0.2"
    assert ladder.eps_threshold(rows, "runout_diff", 0.10) == "≤ 0.3"
    assert ladder.eps_threshold(rows, "runout_diff", 0.50) == "all (≤ 0.5)"
    # the thinnest fails: no threshold, even if a thicker one passes
    rows = _rows([(0.5, 0.01), (0.05, 0.2)])
    assert ladder.eps_threshold(rows, "runout_diff", 0.05) == "none (+20 % at ε = 0.05)"
    # a failed 2D run breaks the chain
    rows = _rows([(0.1, 0.01), (0.05, 0.01)])
    rows[0]["status_2d"] = "failed: fold"
    assert ladder.eps_threshold(rows, "runout_diff", 0.05) == "≤ 0.05"


def test_threshold_table_has_a_two_phase_row_only_where_the_rung_ran():
    rows = _rows([(0.5, 0.30), (0.05, 0.20)])
    for r in rows:
        r.update(runout_diff_k=0.1, runout_diff_ka=0.1)
    assert "| two-phase |" not in ladder.threshold_table(rows)
    rows[0]["runout_diff_tp"], rows[1]["runout_diff_tp"] = 0.12, 0.04
    line = next(ln for ln in ladder.threshold_table(rows).splitlines() if "| two-phase |" in ln)
    assert "| ≤ 0.05 | ≤ 0.05 |" in line and "0.05: +4 %, 0.5: +12 %" in line
