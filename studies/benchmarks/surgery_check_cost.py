"""The cost of the boundary surgery's contact check (docs/benchmarks/2026-12-07-surgery-check-cost.md).

    python benchmarks/surgery_check_cost.py run [--plain] -- run CONFIG [dpcollapse options]
        dpcollapse with the CPU time of MovingDomain's contact checks printed at exit
        ("CHECK calls=… cpu=… s"); --plain: the check without the reused chaining
        (chain_loops every step, as before geometry/boundary_loops.py).
    python benchmarks/surgery_check_cost.py record OUT.pkl -- run CONFIG [options]
        dpcollapse, the gathered boundary edges of every contact check saved to OUT.pkl.
    python benchmarks/surgery_check_cost.py replay OUT.pkl
        the recorded checks again: chain_loops against BoundaryLoops (the same loops
        bitwise and the same contacts at every check, else AssertionError), CPU time of the
        chaining each way and of the contact test, 5 interleaved repeats (medians).
"""

import atexit
import pickle
import sys
import time

import numpy as np


def _wrap(hook):
    from dpcollapse.domain import moving

    moving.boundary_contact = hook(moving.boundary_contact)


def _cli(args):
    from dpcollapse.cli import entry

    sys.argv = ["dpcollapse"] + args
    entry()


def run(args, plain):
    spent, calls = [0.0], [0]

    def hook(check):
        def timed(tagged, h, chained=None):
            t0 = time.process_time()
            try:
                return check(tagged, h) if plain else check(tagged, h, chained)
            finally:
                spent[0] += time.process_time() - t0
                calls[0] += 1
        return timed

    _wrap(hook)
    atexit.register(lambda: print(f"CHECK calls={calls[0]} cpu={spent[0]:.3f} s", file=sys.stderr))
    _cli(args)


def record(path, args):
    from dpcollapse.geometry.mesher import boundary_edges

    rec = []

    def hook(check):
        def saving(tagged, h, chained=None):
            edges, tags = boundary_edges(tagged)
            if edges is not None:
                rec.append((id(tagged.mesh), id(tagged.facet_tags), edges.copy(), tags.copy(), h))
            return check(tagged, h, chained)
        return saving

    _wrap(hook)
    def save():
        with open(path, "wb") as f:
            pickle.dump(rec, f)

    atexit.register(save)
    _cli(args)


def replay(path):
    from dpcollapse.geometry.boundary_loops import BoundaryLoops
    from dpcollapse.geometry.polygon import chain_loops
    from dpcollapse.geometry.surgery import surgery_needed

    with open(path, "rb") as f:
        rec = pickle.load(f)
    keys, prev = [], None
    for mesh_id, tags_id, *_ in rec:       # a new key whenever the mesh or its tags change
        if (mesh_id, tags_id) != prev:
            key, prev = (object(),), (mesh_id, tags_id)
        keys.append(key)
    print(f"{len(rec)} checks, {len(set(map(id, keys)))} meshes/tag sets, boundary edges "
          f"{min(len(r[2]) for r in rec)}–{max(len(r[2]) for r in rec)}")

    def plain_loops():
        return [chain_loops(e, t) for _, _, e, t, _ in rec]

    def reused_loops():
        chained = BoundaryLoops()
        return [chained.loops(e, t, k) for (_, _, e, t, _), k in zip(rec, keys)]

    def kinds(all_loops):
        return [surgery_needed(lp[0], r[4], lp[1:]) for lp, r in zip(all_loops, rec)]

    plain, reused = plain_loops(), reused_loops()
    for a, b in zip(plain, reused):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            assert np.array_equal(x.points, y.points) and np.array_equal(x.edge_tags, y.edge_tags)
    found = kinds(plain)
    assert found == kinds(reused)
    print("identical loops and contacts at every check; contacts found:",
          {k: found.count(k) for k in set(found)})

    def cpu(f):
        t0 = time.process_time()
        f()
        return time.process_time() - t0

    times = {"plain chaining": [], "reused chaining": [], "contact test": []}
    for _ in range(5):
        times["plain chaining"].append(cpu(plain_loops))
        times["reused chaining"].append(cpu(reused_loops))
        times["contact test"].append(cpu(lambda: kinds(plain)))
    for name, v in times.items():
        v = np.array(v)
        print(f"{name:16s} per run {np.median(v):.3f} s (min {v.min():.3f}, max {v.max():.3f}); "
              f"per check {1e3 * np.median(v) / len(rec):.3f} ms")


if __name__ == "__main__":
    what, rest = sys.argv[1], sys.argv[2:]
    cli_args = rest[rest.index("--") + 1:] if "--" in rest else []
    if what == "run":
        run(cli_args, plain="--plain" in rest[:rest.index("--")])
    elif what == "record":
        record(rest[0], cli_args)
    elif what == "replay":
        replay(rest[0])
    else:
        sys.exit(f"unknown command {what!r}: run, record or replay")
