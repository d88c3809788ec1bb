"""Issue 50: how much the bed's Coulomb friction read in the cut cells holds the two-phase
thin front back — a sensitivity, not a model.

    python studies/benchmarks/two_phase/cut_cell_friction.py CASE LABEL [columns_cause.py options]

Runs ``columns_cause.py`` (the ladder's two-phase rung, one JSON line) with every Coulomb
wall's friction of the two-phase model weighted by the cell's grain fraction,

    ∫ min(max(c, 0), 1) μ [p − σ'_nn]_+ u_T·v_T / √(|u_Tᵏ|² + ε_f²) ds

instead of μ [p − σ'_nn]_+: in a cell the thin front only partly fills (c < 1) the bed
friction is cut in proportion. Where the front then moves little, the friction's reading
in the cut cells is not what holds it back. The weight is patched in for this process
only (``forms.friction.coulomb_friction``; the fraction is the one the flow's forms are
built with), so the model's code is the same as every other run's.
"""

from __future__ import annotations

import sys
from pathlib import Path

import ufl

from dpcollapse.forms import friction
from dpcollapse.models.two_phase import fraction

sys.path.insert(0, str(Path(__file__).resolve().parent))
import columns_cause

LATEST = {}
_init, _coulomb = fraction.VolumeFraction.__init__, friction.coulomb_friction


def _remember(self, *args, **kwargs):
    _init(self, *args, **kwargs)
    if self.c.name == "volume_fraction":     # c, not the erodible layer's tracer
        LATEST["c"] = self.c


def _weighted(mu, normal_stress, u_iter, eps_f, u, v, n, ds):
    c = LATEST.get("c")       # the flow's forms are built right after its fraction
    if c is not None:
        mu = mu * ufl.min_value(ufl.max_value(c, 0.0), 1.0)
    return _coulomb(mu, normal_stress, u_iter, eps_f, u, v, n, ds)


fraction.VolumeFraction.__init__ = _remember
friction.coulomb_friction = _weighted

if __name__ == "__main__":
    sys.exit(columns_cause.main())
