"""Issue 50: one knob at a time on a ladder column, two-phase against the moving mesh.

    python studies/benchmarks/two_phase/columns_cause.py CASE LABEL [--rung tp|2d] [--cells N]
                                                      [--work DIR] [--out FILE] [KEY=VALUE ...]

CASE is a ladder case (``studies.ladder.full_plan``, e.g. column_a3); the run is
the ladder's own rung (``ladder.two_phase_config`` for ``tp`` with L0/N cells, N = 16 by
default; the case's 2D config for ``2d``), to the ladder's end time, with the ``KEY=VALUE``
overrides applied last (the knob). The reference is the 2D rung stored in docs/figures
(ladder.csv, ladder_series.csv). Printed, and appended as one JSON line to ``--out``:

* runouts x_f − L0 of the deposit profile h(x) at h ≥ 1, 2, 5, 10, 20 mm (the ladder's
  ``ladder_thresholds``) and their difference from the stored 2D rung, the two-phase mass
  front (c > ½), the deposit height H_f = max h;
* the two-phase ∫ c: max over the steps of |∫ c(t) + outflow(t) − ∫ c(0)| / ∫ c(0) from
  diagnostics.csv's area column (the box of the columns has no outflow side), and the
  2D rung's area drift.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))  # studies/ is not installed
from dpcollapse.config import with_overrides  # noqa: E402
from dpcollapse.fronts import front_thickness, profile_front  # noqa: E402
from dpcollapse.io.diagnostics import read_diagnostics  # noqa: E402
from dpcollapse.rheology.choice import law_from_material  # noqa: E402
from studies import ladder  # noqa: E402

THRESHOLDS = (1e-3, 2e-3, 5e-3, 1e-2, 2e-2)
FIGURES = ladder.ROOT / "docs" / "figures"


def fronts(x: np.ndarray, h: np.ndarray, l0: float, thresholds=THRESHOLDS) -> list[float]:
    """x_f − L0 at each threshold: the largest x with h ≥ it, linear to the next point
    (``dpcollapse.fronts.profile_front``: every model's front)."""
    return [profile_front(x, h, t) - l0 for t in thresholds]


def reference(case: str):
    """The stored 2D rung: its ladder.csv row and its profile h on the SH grid."""
    row = next(r for r in ladder.read_rows(FIGURES / "ladder.csv") if r["case"] == case)
    profile = ladder.read_series(FIGURES / "ladder_series.csv")[(case, "2d", "profile")]
    return row, profile


def area_drift(run_dir: Path, counted: bool = True) -> float:
    """max_t |∫ c(t) + escaped(t) − ∫ c(0)| / ∫ c(0) over the accepted steps (diagnostics.csv;
    escaped: what left through the open top, counted since issue 50's one-answer report)."""
    diag = read_diagnostics(run_dir / "diagnostics.csv")
    area = np.asarray(diag.get("area", []), dtype=float)
    if counted and diag.get("escaped_area"):
        area = area + np.asarray(diag["escaped_area"], dtype=float)
    return float(np.max(np.abs(area - area[0])) / area[0]) if len(area) else math.nan


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case")
    ap.add_argument("label")
    ap.add_argument("overrides", nargs="*")
    ap.add_argument("--rung", choices=("tp", "2d"), default="tp")
    ap.add_argument("--cells", type=int, default=ladder.TWO_PHASE_CELLS_ACROSS_L0)
    ap.add_argument("--work", default="runs/cause")
    ap.add_argument("--out", default="runs/cause/results.jsonl")
    args = ap.parse_intermixed_args(argv)
    case = next(c for c in ladder.full_plan() if c.name == args.case)
    cfg = case.load()
    _, grid, _, _ = ladder.sh_problem(cfg, ladder.SH_DX, case.sh_x_max)
    row, profile = reference(args.case)
    l0 = cfg.geometry.base_length
    run_dir = Path(args.work) / f"{args.case}_{args.rung}_{args.label}"
    if args.rung == "tp":
        cfg = ladder.two_phase_config(cfg, grid, ladder.two_phase_end(row), args.cells)
        cfg = with_overrides(cfg, args.overrides)
        rung = ladder.run_two_phase(cfg, run_dir, grid)
        extra = {"front_c_half": rung.extra["front"] - l0, "drift": area_drift(run_dir),
                 "drift_without_escaped": area_drift(run_dir, counted=False),
                 "cell": cfg.model.min_cell}
    else:
        cfg = with_overrides(cfg, args.overrides)
        rung = ladder.run_2d(cfg, run_dir, grid)
        extra = {"front_mesh": rung.extra["front_mesh"] - l0, "drift": rung.extra["area_drift"],
                 "cell": cfg.geometry.mesh_size}
    profile = profile[np.argsort(profile[:, 0])]
    ref_h = profile[:, 1]
    ref = fronts(profile[:, 0], ref_h, l0)
    mine = fronts(np.asarray(grid.centers), rung.h, l0)
    # the stated thickness of both: 3 d or a quarter of the moving mesh's (coarser) cell
    stated = front_thickness(law_from_material(cfg.material).grain_scale, case.load().geometry.mesh_size)
    ref_s = fronts(profile[:, 0], ref_h, l0, (stated,))[0]
    mine_s = fronts(np.asarray(grid.centers), rung.h, l0, (stated,))[0]
    result = {"case": args.case, "label": args.label, "rung": args.rung, "overrides": args.overrides,
              "status": rung.status, "t_end": rung.t_end, "steps": rung.steps, "cpu": rung.cpu,
              "runout": mine, "runout_2d": ref,
              "diff": [(b - a) / a for a, b in zip(ref, mine)],
              "height": float(rung.h.max()), "height_2d": float(ref_h.max()),
              "height_diff": float(rung.h.max() / ref_h.max() - 1.0),
              "stated_thickness": stated, "runout_stated": mine_s, "runout_stated_2d": ref_s,
              "diff_stated": (mine_s - ref_s) / ref_s} | extra
    print(f"{args.case} {args.rung} {args.label}: " + ", ".join(
        f"h≥{1000 * t:g}mm {r:.4f} ({100 * d:+.1f} %)" for t, r, d in
        zip(THRESHOLDS, mine, result["diff"])) + f"; h≥{1000 * stated:.3g}mm (stated) {mine_s:.4f} "
        f"({100 * result['diff_stated']:+.1f} %); H_f {result['height']:.4f} "
        f"({100 * result['height_diff']:+.2f} %); drift {extra['drift']:.2e}; "
        + (f"c>½ {extra['front_c_half']:.4f}; " if "front_c_half" in extra else "")
        + f"{rung.status}, {rung.cpu:.0f} s CPU", flush=True)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "a") as fh:
        fh.write(json.dumps(result) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
