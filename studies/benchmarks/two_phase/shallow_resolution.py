"""Resolution check of the ladder's shallow rows (docs/benchmarks/2026-12-04-ladder-shallow-two-phase.md):
one case of ``ladder.shallow_plan()`` with ``geometry.mesh_size`` replaced by CELL, its
two-phase rung (``tp``, against the 2D row of docs/figures/ladder_shallow.csv) or its 2D and
depth-averaged rungs (``2d``); one JSON line of the results.

    python studies/benchmarks/two_phase/shallow_resolution.py tp shallow_flat_eps0.1 0.003 WORK
    python studies/benchmarks/two_phase/shallow_resolution.py 2d shallow_flat_eps0.1 0.003 WORK
    python studies/benchmarks/two_phase/shallow_resolution.py tp shallow_slope12_eps0.1 0.003 WORK \
        model.open_top=hydrostatic

Further KEY=VALUE arguments are applied last to the two-phase rung's config (a knob, as
``columns_cause.py``'s).
"""
import dataclasses
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))  # studies/ is not installed
from dpcollapse.config import with_overrides  # noqa: E402
from studies import ladder as L  # noqa: E402

rung, name, cell, work = sys.argv[1], sys.argv[2], float(sys.argv[3]), Path(sys.argv[4])
knobs = sys.argv[5:]
if knobs:   # the two-phase rung's config with the knobs applied last
    _rung_config = L.two_phase_config
    L.two_phase_config = lambda *a, **k: with_overrides(_rung_config(*a, **k), knobs)
case = next(c for c in L.shallow_plan() if c.name == name)
case = dataclasses.replace(case, overrides=tuple(o for o in case.overrides
                                                 if not o.startswith("geometry.mesh_size="))
                           + (f"geometry.mesh_size={cell:g}",))
if rung == "tp":
    row = {r["case"]: r for r in L.read_rows(L.ROOT / "docs/figures/ladder_shallow.csv")}[name]
    cols, _ = L.two_phase_rung(case, row, work, L.SH_DX, L.TWO_PHASE_CELLS_ACROSS_L0)
else:
    cols, _ = L.compare(case, work, L.SH_DX)
print(json.dumps({"case": name, "cell": cell, "knobs": knobs, **{k: v for k, v in cols.items()
                                                  if isinstance(v, (int, float, str))}}))
