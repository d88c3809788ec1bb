"""Error against cost of the rigid collapse over the mesh size and the time tolerance (issue 51).

    python benchmarks/rigid_pareto.py RUNS_DIR --reference NAME [--richardson C M F ...] \
        [--default NAME] [--proposed NAME] --csv docs/benchmarks/rigid_pareto/grid.csv \
        --png docs/figures/rigid_pareto.png

RUNS_DIR holds run directories of ``dpcollapse run configs/rigid.yaml --set
geometry.mesh_size=H [--set geometry.surface_mesh_size=S] --set time.tolerance=TOL``, each
with ``NAME.time`` beside it (``/usr/bin/time -v``; the CPU time is its user + system).
Every run that came to rest is measured:

- the front history x_f(t) at t = 0.1, …, 0.9 s (``time_order.front_history``: the
  diagnostics' front, linear between the steps that bracket each time);
- the free surface at rest h(x): the SURFACE edges of the last checkpoint's mesh
  (``deposit_surface.surface_edges``), their vertices sorted by x, linear between them,
  h = 0 beyond the toe; on 0 ≤ x ≤ 0.75 m (3 001 points);
- the deposit front (run.json ``front``) and its largest height (``max_height``).

Errors against the reference run ``--reference`` (the finest ΔX at the tightest tolerance):
front history max_t |x_f − x_f,ref| [mm], profile L∞ max_x |h − h_ref| [mm] and L¹
∫|h − h_ref| dx [cm²] (the area between the two surfaces; the mass is 628.7 cm²), deposit
front and height differences [mm].

``--reference richardson:C,M,F`` takes as the reference the Richardson extrapolation of three
runs at one tolerance (ΔX decreasing; below), each quantity with its own observed order
(the finest run's value where the three do not converge monotonically).

``--richardson C M F`` (three runs at one tolerance, ΔX decreasing): the observed order in
ΔX of each scalar (deposit front, height, each x_f(t_i)) and of the front history and the
profile as a whole (their differences' max norms), p = ln(‖Q_C − Q_M‖/‖Q_M − Q_F‖) /
ln(ΔX_M/ΔX_F) for ΔX_C/ΔX_M = ΔX_M/ΔX_F (else solved numerically), and the extrapolated
value Q_F + (Q_F − Q_M)/(r^p − 1) with r = ΔX_M/ΔX_F: the estimate of the reference's own
error in ΔX.

With more than three runs (``--richardson C M1 M2 F``, ΔX decreasing) each consecutive
triple is reported as above, and each scalar is fitted over all levels by least squares,
Q = Q0 + C ΔX^p (``power_fit``; none where the levels do not converge monotonically).

With ``--default NAME`` every run is checked against issue 51's Done-when (``meets``): its
front-history, profile L∞ and L¹ errors no larger than that run's, its deposit front within
2.5 mm of the reference's (the column "meets" of the table and the CSV).

The split: at each ΔX the run at the tightest tolerance stands for Δt → 0; the temporal part
of a run's error is its distance to that run, the spatial part that run's distance to the
reference. The observed order in the tolerance (and in the step count N, the mean Δt being
∝ 1/N) is the least-squares slope of log(temporal part) against log(tol) (log N).

The chart: front-history error and profile L∞ against CPU time, one marker per run (colour:
ΔX, marker: tolerance, open: graded mesh), the Pareto front (no run both cheaper and more
accurate in that error) drawn, ``--default`` and ``--proposed`` ringed. Runs sized by the
error indicator (``numerics.mesh_tolerance``, column ``accuracy``) are drawn as large stars,
apart from ΔX's colours.

``--rows CSV`` adds the rows of an earlier run of this script (its ``--csv``) whose run
directories were not kept: charted, on the Pareto fronts and checked against the default, but
not measured again (their errors are against that CSV's reference, which must be this
one: the script checks that its reference row's deposit front and steps equal this
reference's; names already loaded are skipped).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from deposit_surface import surface_edges  # noqa: E402
from time_order import TIMES, cpu_seconds, front_history  # noqa: E402

X_PROFILE = np.linspace(0.0, 0.75, 3001)
MASS_AREA_CM2 = 628.7


def profile(run: Path) -> np.ndarray:
    """h(x) at X_PROFILE of the run's free surface at rest [m]."""
    segs = surface_edges(run)
    pts = np.unique(np.round(segs.reshape(-1, 2), 12), axis=0)
    pts = pts[np.argsort(pts[:, 0], kind="stable")]
    return np.interp(X_PROFILE, pts[:, 0], pts[:, 1], left=pts[0, 1], right=0.0)


def load(run: Path) -> dict | None:
    """The run's settings, cost and measures; None unless it came to rest."""
    info = json.loads((run / "run.json").read_text())
    if info.get("status") != "at_rest":
        return None
    cfg, s = info["config"], info["summary"]
    h = cfg["geometry"]["mesh_size"]
    surf = cfg["geometry"].get("surface_mesh_size") or h
    return {"name": run.name, "h": h, "surface": surf, "graded": surf != h,
            "accuracy": cfg.get("numerics", {}).get("mesh_tolerance"),
            "tol": cfg["time"]["tolerance"], "norm": cfg["time"].get("error_norm", "rms"),
            "cpu": cpu_seconds(run),
            "total": info["timings"]["total"], "steps": s["steps"],
            "lu": s.get("flow_factorizations"), "rejected": s.get("rejected_steps"),
            "remeshes": s["remeshes"], "rest": s["t"], "front": s["front"],
            "height": s["max_height"], "history": front_history(run), "profile": profile(run)}


def errors(r: dict, ref: dict) -> dict:
    dx = X_PROFILE[1] - X_PROFILE[0]
    dh = np.abs(r["profile"] - ref["profile"])
    return {"e_hist": 1e3 * float(np.max(np.abs(r["history"] - ref["history"]))),
            "e_inf": 1e3 * float(dh.max()),
            "e_l1": 1e4 * float(np.sum(0.5 * (dh[1:] + dh[:-1])) * dx),
            "e_front": 1e3 * (r["front"] - ref["front"]),
            "e_height": 1e3 * (r["height"] - ref["height"])}


#: issue 51's Done-when: the errors no larger than the default's, the deposit front within
#: this distance of the reference's [mm]
FRONT_BAND_MM = 2.5
BOUND_KEYS = ("e_hist", "e_inf", "e_l1")


def meets(row: dict, default: dict, band: float = FRONT_BAND_MM) -> dict:
    """Issue 51's Done-when for one run against the default's errors (same reference): per
    error of ``BOUND_KEYS`` whether it is no larger than the default's, whether |deposit front
    − reference's| ≤ ``band`` mm, and ``all``."""
    out = {k: bool(row[k] <= default[k]) for k in BOUND_KEYS}
    out["e_front"] = bool(abs(row["e_front"]) <= band)
    out["all"] = all(out.values())
    return out


def observed_order(qc, qm, qf, hc, hm, hf) -> float:
    """p with ‖Q_C − Q_M‖/‖Q_M − Q_F‖ = (h_C^p − h_M^p)/(h_M^p − h_F^p) (Q = Q0 + C h^p);
    NaN unless the two differences point the same way (Σ (Q_C − Q_M)(Q_M − Q_F) > 0:
    monotone convergence)."""
    d1, d2 = np.asarray(qc, dtype=float) - qm, np.asarray(qm, dtype=float) - qf
    a, b = float(np.max(np.abs(d1))), float(np.max(np.abs(d2)))
    if b == 0 or a == 0 or float(np.sum(d1 * d2)) <= 0:
        return math.nan
    target = a / b

    def ratio(p):
        return (hc ** p - hm ** p) / (hm ** p - hf ** p)

    lo, hi = 0.05, 8.0
    if not (ratio(lo) - target) * (ratio(hi) - target) < 0:
        return math.nan
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if (ratio(lo) - target) * (ratio(mid) - target) <= 0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def power_fit(hs, qs) -> tuple[float, float, float]:
    """Least-squares Q = Q0 + C h^p over any number ≥ 3 of levels: (Q0, C, p) with p the
    minimizer of the linear fit's residual on 0.05 ≤ p ≤ 8 (golden search after a scan); NaNs
    unless the levels converge monotonically (successive differences of one sign) and the
    minimizer lies inside that range (at its ends the differences do not shrink like a power
    of ΔX: e.g. the last step larger than the first)."""
    hs, qs = np.asarray(hs, dtype=float), np.asarray(qs, dtype=float)
    d = np.diff(qs)
    if len(hs) < 3 or np.any(d == 0) or not (np.all(d > 0) or np.all(d < 0)):
        return math.nan, math.nan, math.nan

    def fit(p):
        a = np.c_[np.ones_like(hs), hs ** p]
        coef, *_ = np.linalg.lstsq(a, qs, rcond=None)
        return coef, float(np.sum((a @ coef - qs) ** 2))

    ps = np.linspace(0.05, 8.0, 160)
    k = int(np.argmin([fit(p)[1] for p in ps]))
    lo, hi = ps[max(k - 1, 0)], ps[min(k + 1, len(ps) - 1)]
    g = (math.sqrt(5) - 1) / 2
    for _ in range(100):
        a, b = hi - g * (hi - lo), lo + g * (hi - lo)
        if fit(a)[1] < fit(b)[1]:
            hi = b
        else:
            lo = a
    p = 0.5 * (lo + hi)
    if not ps[0] + 0.01 < p < ps[-1] - 0.01:
        return math.nan, math.nan, math.nan
    (q0, c), _ = fit(p)
    return float(q0), float(c), float(p)


def richardson_levels(runs: list[dict], log=print) -> dict:
    """Richardson over N ≥ 3 levels (ΔX decreasing): the observed order of each consecutive
    triple (``richardson``), and for each scalar (deposit front, height, each x_f(t_i)) the
    least-squares fit Q = Q0 + C ΔX^p over all levels (``power_fit``). Returns the finest
    triple's ``richardson`` (the extrapolation a reference takes) with ``fits``: per scalar
    (Q0, C, p) and the finest run's error Q_F − Q0 [m]."""
    out = None
    for k in range(len(runs) - 2):
        out = richardson(runs[k:k + 3], log=log)
    hs = [r["h"] for r in runs]
    fits = {}
    scalars = [("front", lambda r: r["front"]), ("height", lambda r: r["height"])]
    if all(len(r["history"]) == len(TIMES) for r in runs):
        scalars += [(f"x_f({t:.1f})", lambda r, i=i: r["history"][i]) for i, t in enumerate(TIMES)]
    log("least-squares Q = Q0 + C ΔX^p over " + ", ".join(r["name"] for r in runs) + ":")
    for key, get in scalars:
        q0, c, p = power_fit(hs, [get(r) for r in runs])
        err = get(runs[-1]) - q0 if q0 == q0 else math.nan
        fits[key] = {"q0": q0, "c": c, "p": p, "finest_error": err}
        log(f"  {key}: " + (f"p = {p:.2f}, Q0 = {q0:.5f} m, the finest run's error {1e3 * err:+.2f} mm"
                            if p == p else "no power law (not monotone, or the differences do not shrink)"))
    out = dict(out or {})
    out["fits"] = fits
    return out


def richardson(runs: list[dict], log=print) -> dict:
    c, m, f = runs
    out = {}
    log(f"Richardson in ΔX: {c['name']}, {m['name']}, {f['name']}")
    for key, scale, unit in (("front", 1e3, "mm"), ("height", 1e3, "mm"),
                             ("history", 1e3, "mm"), ("profile", 1e3, "mm")):
        p = observed_order(c[key], m[key], f[key], c["h"], m["h"], f["h"])
        r = m["h"] / f["h"]
        ext = (np.asarray(f[key]) + (np.asarray(f[key]) - m[key]) / (r ** p - 1)
               if p == p else np.full_like(np.asarray(f[key], dtype=float), np.nan))
        err = scale * float(np.max(np.abs(ext - f[key]))) if p == p else math.nan
        out[key] = {"p": p, "extrapolated": ext, "finest_error": err}
        extra = f", extrapolated {float(ext):.5f} m" if np.ndim(ext) == 0 else ""
        log(f"  {key}: observed order {p:.2f}, the finest run's error in ΔX ≈ {err:.2f} {unit}{extra}")
    if len(c["history"]) == len(TIMES):
        ps = [observed_order(c["history"][i], m["history"][i], f["history"][i], c["h"], m["h"], f["h"])
              for i in range(len(TIMES))]
        log("  x_f(t_i) orders: " + ", ".join(f"{t:.1f}: {p:.2f}" for t, p in zip(TIMES, ps)))
    return out


def temporal_split(rows: list[dict], ref: dict, log=print) -> list[dict]:
    """Per ΔX (uniform meshes): spatial part (the tightest-tolerance run against the
    reference) and temporal parts (each run against that run), with the observed order and
    the tightest run's own temporal part estimated by that power law at its tolerance (C tol^q,
    C and q fitted to the looser runs). Max-norm runs only (the rms ones are another family)."""
    out = []
    rows = [r for r in rows if not r["graded"] and r.get("norm", "max") == "max"]
    tightest = min(r["tol"] for r in rows)
    # one family per ΔX, and per indicator accuracy (numerics.mesh_tolerance) at that ΔX
    for h, acc in sorted({(r["h"], r.get("accuracy") or 0.0) for r in rows}):
        group = sorted((r for r in rows if r["h"] == h and (r.get("accuracy") or 0.0) == acc),
                       key=lambda r: r["tol"])
        base = group[0]
        if base["tol"] > tightest:     # no Δt → 0 stand-in at this ΔX: nothing to split
            continue
        space = errors(base, ref)
        log(f"ΔX = {100 * h:g} cm{f', indicator {acc:g} m/s' if acc else ''}: spatial part "
            f"(tol {base['tol']:g}): front history "
            f"{space['e_hist']:.2f} mm, profile L∞ {space['e_inf']:.2f} mm, L¹ {space['e_l1']:.2f} cm², "
            f"deposit {space['e_front']:+.2f} mm")
        tols, eh, steps = [], [], []
        for r in group[1:]:
            t = errors(r, base)
            log(f"    tol {r['tol']:g}: temporal part: front history {t['e_hist']:.2f} mm, "
                f"profile L∞ {t['e_inf']:.2f} mm, deposit {t['e_front']:+.2f} mm ({r['steps']} steps)")
            out.append({"h": h, "accuracy": acc, "tol": r["tol"], "space_hist": space["e_hist"],
                        "time_hist": t["e_hist"], "time_inf": t["e_inf"], "time_front": t["e_front"]})
            tols.append(r["tol"])
            eh.append(t["e_hist"])
            steps.append(r["steps"])
        if len(tols) >= 2 and min(eh) > 0:
            q = np.polyfit(np.log(tols), np.log(eh), 1)[0]
            qn = np.polyfit(np.log(steps), np.log(eh), 1)[0]
            c0 = np.polyfit(np.log(tols), np.log(eh), 1)[1]
            log(f"    observed order of the temporal front-history error: tol^{q:.2f}, N^{qn:.2f}; "
                f"the tol {base['tol']:g} run's own ≈ {math.exp(c0) * base['tol'] ** q:.2f} mm")
    return out


ROW_FLOATS = ("h", "surface", "tol", "rest", "cpu", "total", "front", "height", "e_hist", "e_inf",
              "e_l1", "e_front", "e_height")


def earlier_rows(path: Path, ref: dict, skip: set) -> list[dict]:
    """The rows of an earlier ``--csv`` (``main``), as charted rows (no history or profile),
    those named in ``skip`` left out; refused (SystemExit) unless the CSV's reference row
    (its first) has this reference's deposit front (to 1e-12 m) and steps."""
    with open(path, newline="") as fh:
        raw = list(csv.DictReader(fh))
    head = raw[0]
    if (abs(float(head["front"]) - ref["front"]) > 1e-12 or int(head["steps"]) != ref["steps"]):
        raise SystemExit(f"--rows {path}: its reference {head['name']} (front {head['front']} m, "
                         f"{head['steps']} steps) is not this one ({ref['front']!r} m, {ref['steps']})")
    out = []
    for row in raw[1:]:
        if row["name"] in skip:
            continue
        r = {k: (float(v) if k in ROW_FLOATS and v != "" else v) for k, v in row.items()}
        for k in ("steps", "lu", "rejected", "remeshes"):
            r[k] = int(r[k]) if r.get(k) not in (None, "") else 0
        r["graded"] = r["surface"] != r["h"]
        r["accuracy"] = float(row["accuracy"]) if row.get("accuracy") else None
        r["from_rows"] = True
        out.append(r)
    return out


def pareto(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the points no other point beats in both coordinates, by increasing cost."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], math.inf
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def chart(rows: list[dict], png: Path, default: str | None, proposed: str | None,
          proposed_label: str = "proposed") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sizes = sorted({r["h"] for r in rows if not r.get("accuracy")})
    tols = sorted({r["tol"] for r in rows})
    accuracies = sorted({r["accuracy"] for r in rows if r.get("accuracy")})
    accuracy_colors = {a: plt.cm.plasma(0.15 + 0.7 * i / max(len(accuracies) - 1, 1))
                       for i, a in enumerate(accuracies)}
    markers = dict(zip(tols, "v^osDph*XP<>d12348"))
    colors = {h: f"C{i}" for i, h in enumerate(sizes)}
    fig, axes = plt.subplots(1, 3, figsize=(16, 7.0))
    for ax, key, label in zip(axes, ("e_hist", "e_inf", "e_l1"),
                              ("front history max |x_f − ref| [mm]", "profile at rest L∞ [mm]",
                               "profile at rest L¹ [cm²]")):
        for r in rows:
            rms = r.get("norm", "max") == "rms"
            if r.get("accuracy"):
                ax.plot(r["cpu"], r[key], "*", color=accuracy_colors[r["accuracy"]], ms=16,
                        mec="k", mew=1.0)
                ax.annotate(f"{100 * r['surface']:g}/{r['norm']} {r['tol']:g}", (r["cpu"], r[key]),
                            xytext=(6, -10), textcoords="offset points", fontsize=7)
                continue
            ax.plot(r["cpu"], r[key], markers[r["tol"]], color=colors[r["h"]], ms=8,
                    mfc="none" if r["graded"] else colors[r["h"]],
                    mec="k" if rms else colors[r["h"]], mew=1.6 if rms else 1.0)
        idx = pareto([(r["cpu"], r[key]) for r in rows])
        pts = [(rows[i]["cpu"], rows[i][key]) for i in idx]
        xs, ys = [], []
        for k, (x, y) in enumerate(pts):
            xs += [x] if k == 0 else [x, x]
            ys += [y] if k == 0 else [pts[k - 1][1], y]
        ax.plot(xs, ys, "k-", lw=1, alpha=0.6, label="Pareto front")
        for name, tag, col in ((default, "the 1 cm default (max 3e-4)", "red"),
                               (proposed, proposed_label, "green")):
            for r in rows:
                if r["name"] == name:
                    ax.plot(r["cpu"], r[key], "o", ms=18, mfc="none", mec=col, mew=2, label=tag)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("CPU time (user + system) [s]")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    handles = [plt.Line2D([], [], color=colors[h], marker="s", ls="", label=f"ΔX {100 * h:g} cm")
               for h in sizes]
    handles += [plt.Line2D([], [], color="gray", marker=markers[t], ls="", label=f"tol {t:g} m/s")
                for t in tols]
    handles += [plt.Line2D([], [], color="gray", marker="o", mfc="none", ls="",
                           label="graded (open: ΔX inside, surface finer)")]
    handles += [plt.Line2D([], [], color="gray", marker="o", mec="k", mew=1.6, ls="",
                           label="rms error norm (black edge; others: max)")]
    handles += [plt.Line2D([], [], color=accuracy_colors[a], marker="*", mec="k", ms=12, ls="",
                           label=f"indicator, mesh_tolerance {a:g} m/s (label: surface cm / norm tol)")
                for a in accuracies]
    handles += axes[1].get_legend_handles_labels()[0][-3:]
    fig.legend(handles=handles, fontsize=8, loc="lower center", ncol=6)
    fig.suptitle("rigid collapse: error against the space–time reference vs cost")
    fig.tight_layout(rect=(0, 0.2, 1, 1))
    fig.savefig(png, dpi=110)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs_dir", type=Path)
    ap.add_argument("--reference", required=True, help="name of the reference run in RUNS_DIR")
    ap.add_argument("--richardson", nargs="+", metavar="RUN",
                    help="three or more runs at one tolerance, ΔX decreasing")
    ap.add_argument("--default")
    ap.add_argument("--proposed")
    ap.add_argument("--proposed-label", default="proposed", help="its label in the chart")
    ap.add_argument("--exclude", nargs="*", default=[], help="run names not measured")
    ap.add_argument("--variants", nargs="*", default=[],
                    help="runs of a charted setting under other round-off (another OpenBLAS kernel): "
                         "listed apart, as the spread of that setting's errors, not charted")
    ap.add_argument("--rows", type=Path, help="rows of an earlier --csv (same reference) to chart")
    ap.add_argument("--csv", type=Path)
    ap.add_argument("--png", type=Path)
    args = ap.parse_args(argv)
    loaded = {}
    for run in sorted(p for p in args.runs_dir.iterdir() if (p / "run.json").exists()):
        r = load(run)
        if r is not None:
            loaded[run.name] = r
    if args.reference.startswith("richardson:"):
        names = args.reference.split(":", 1)[1].split(",")
        ext = richardson([loaded[n] for n in names])
        finest = loaded[names[-1]]
        ref = dict(finest, name="Richardson(" + ",".join(names) + ")", h=0.0, surface=0.0, cpu=math.nan)
        for key in ("front", "height", "history", "profile"):
            if ext[key]["p"] == ext[key]["p"]:
                ref[key] = ext[key]["extrapolated"]
            else:
                print(f"  {key}: no observed order (not monotone): the finest run's value is the reference")
        ref["profile"] = np.maximum(ref["profile"], 0.0)
        args.exclude = list(args.exclude)
    else:
        ref = loaded[args.reference]
    print(f"reference {ref['name']}: deposit front {ref['front']:.5f} m, height {ref['height']:.5f} m, "
          f"at rest {ref['rest']:.3f} s, {ref['steps']} steps, CPU {ref['cpu']:.1f} s")
    print("  x_f(t) = " + ", ".join(f"{x:.5f}" for x in ref["history"]) + " m")
    if args.richardson:
        if len(args.richardson) < 3:
            ap.error("--richardson takes three or more runs")
        richardson_levels([loaded[n] for n in args.richardson])
    rows = []
    for name, r in loaded.items():
        if name == ref["name"] or name in args.exclude or name in args.variants:
            continue
        rows.append(r | errors(r, ref))
    if args.rows:
        rows += earlier_rows(args.rows, ref, set(loaded) | set(args.exclude) | set(args.variants))
    variants = [loaded[n] | errors(loaded[n], ref) for n in args.variants if n in loaded]
    rows.sort(key=lambda r: (r["h"], r["surface"], r["tol"], r.get("norm", "max")))
    base = next((r for r in rows if r["name"] == args.default), None)
    for r in rows + variants:
        r["meets"] = ("" if base is None else
                      "yes" if meets(r, base)["all"] else
                      "no: " + ",".join(k for k, v in meets(r, base).items() if not v and k != "all"))
    print(f"{'run':16s} {'ΔX':>5s} {'surf':>5s} {'tol':>7s} {'steps':>5s} {'LU':>5s} {'CPU':>6s} "
          f"{'hist':>5s} {'L∞':>5s} {'L¹':>5s} {'front':>6s} {'height':>6s} {'rest':>5s} "
          "norm meets the default's bound")
    for r in rows + variants:
        if r is (variants or [None])[0]:
            print("round-off variants (other OpenBLAS kernels; not charted):")
        print(f"{r['name']:16s} {100 * r['h']:5.2g} {100 * r['surface']:5.2g} {r['tol']:7.2g} "
              f"{r['steps']:5d} {r['lu']:5d} {r['cpu']:6.1f} {r['e_hist']:5.2f} {r['e_inf']:5.2f} "
              f"{r['e_l1']:5.2f} {r['e_front']:+6.2f} {r['e_height']:+6.2f} {r['rest']:5.3f} "
              f"{r['norm']:4s} {r['meets']}")
    for key in ("e_hist", "e_inf", "e_l1"):
        idx = pareto([(r["cpu"], r[key]) for r in rows])
        print(f"Pareto front in {key}: " + ", ".join(rows[i]["name"] for i in idx))
    temporal_split([r for r in rows if "history" in r] + ([ref] if ref["h"] else []), ref)
    if args.csv:
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        keys = ["name", "h", "surface", "tol", "norm", "steps", "lu", "rejected", "remeshes", "rest", "cpu",
                "total", "front", "height", "e_hist", "e_inf", "e_l1", "e_front", "e_height", "meets",
                "accuracy"]
        with open(args.csv, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(keys)
            for r in [ref] + rows:
                w.writerow([r.get(k, "") for k in keys])
    if args.png:
        chart(rows, args.png, args.default, args.proposed, args.proposed_label)
    return 0


if __name__ == "__main__":
    sys.exit(main())
