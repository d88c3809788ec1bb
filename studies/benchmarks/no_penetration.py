"""u·n = 0 on a slanted side: Nitsche's method against the penalty alone, on the rotated
half-Poiseuille channel of tests/unit/test_no_penetration.py (exact in P2/P1).

    .venv/bin/python benchmarks/no_penetration.py

prints the largest nodal velocity error relative to the largest speed, per rotation φ and
parameter γ (docs/benchmarks/2026-12-01-slanted-walls.md).
"""

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from tests.unit.test_no_penetration import channel_velocity_error  # noqa: E402

print(f"strong, φ = 0: {channel_velocity_error(0.0, 'strong'):.1e}")
print("| φ [deg] | γ | Nitsche | penalty alone |\n| --- | --- | --- | --- |")
for phi in (0.0, 30.0, 117.0):
    for gamma in (1.0, 10.0, 100.0, 1e4):
        nitsche = channel_velocity_error(math.radians(phi), "nitsche", gamma)
        penalty = channel_velocity_error(math.radians(phi), "penalty", gamma)
        print(f"| {phi:g} | {gamma:g} | {nitsche:.1e} | {penalty:.1e} |")
