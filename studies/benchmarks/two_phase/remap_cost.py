"""CPU of the adaptive rebuild's remap of c and cⁿ⁻¹: one call per field (before 2026-12-07)
against one call for both (``models.two_phase.flow.remap_fields``), interleaved in one process.

    python studies/benchmarks/two_phase/remap_cost.py OLD_RUN NEW_RUN [repeats]

OLD_RUN's checkpoint.npz gives the old mesh with its c and cⁿ⁻¹ (the snapshot fields
``volume_fraction``, ``volume_fraction_previous``); NEW_RUN's checkpoint the mesh they are
remapped onto (two adaptive meshes of the same box, e.g. the a = 6.26 column's at two times).
Prints the best CPU time (``time.process_time``) of each way and the largest difference of
the remapped values (round-off: the sum order of the overlaps changes), and how many old
cells a skip of numerical zeros would leave out: those where neither c nor cⁿ⁻¹ exceeds
1e-30, 1e-16 or 1e-6 of its largest value (the light fluid's haze of c).
"""

import sys
import time

import numpy as np

from dpcollapse.models.two_phase.remap import remap


def _field(run: str, name: str):
    data = np.load(f"{run}/checkpoint.npz")
    return data[f"x_{name}_vertices"], data[f"x_{name}_values"][:, 0, 0]


def main(old_run: str, new_run: str, repeats: int = 3) -> None:
    tri, c = _field(old_run, "volume_fraction")
    tri_prev, c_prev = _field(old_run, "volume_fraction_previous")
    assert np.array_equal(tri, tri_prev)
    new, _ = _field(new_run, "volume_fraction")
    separate, together = [], []
    for _ in range(repeats):          # interleaved: the same load for both
        t0 = time.process_time()
        one = np.c_[remap(tri, c, new), remap(tri, c_prev, new)]
        separate.append(time.process_time() - t0)
        t0 = time.process_time()
        both = remap(tri, np.c_[c, c_prev], new)
        together.append(time.process_time() - t0)
    print(f"old mesh {len(tri)} cells, new mesh {len(new)} cells; "
          f"nonzero c {np.count_nonzero(c)}, nonzero c_prev {np.count_nonzero(c_prev)}")
    fields = np.c_[c, c_prev]
    for zero in (1e-30, 1e-16, 1e-6):
        above = np.count_nonzero(np.any(np.abs(fields) > zero * np.abs(fields).max(axis=0), axis=1))
        print(f"cells where c or c_prev exceeds {zero:g} of its largest value: {above} "
              f"({above / len(tri):.1%})")
    print(f"two calls (c, c_prev): {min(separate):.3f} s CPU (all {np.round(separate, 3).tolist()})")
    print(f"one call for both:     {min(together):.3f} s CPU (all {np.round(together, 3).tolist()})")
    print(f"ratio {min(together) / min(separate):.2f}; largest difference {np.abs(one - both).max():.1e}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], *(int(a) for a in sys.argv[3:4]))
