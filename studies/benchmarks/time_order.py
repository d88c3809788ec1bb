"""Error against cost of the time schemes on the rigid collapse (issue 25).

    python benchmarks/time_order.py --reference RUN_DT RUN_DT2 --runs RUN ... \
        --csv docs/figures/time_order_2cm.csv --png docs/figures/time_order_2cm.png
    python benchmarks/time_order.py --reference-run FINEST --times 0.024 0.048 0.072 0.096 \
        --quantity kinetic_energy --runs RUN ... --csv … --png …

Each RUN is a run directory of ``dpcollapse run`` with ``RUN.time`` beside it (the output of
``/usr/bin/time -v``). The front history x_f(t) of a run is its diagnostics' ``front``
interpolated linearly at t = 0.1, 0.2, …, 0.9 s (x_f(0) = l0 = 0.297 m before the first
step). The Δt → 0 reference is Richardson's extrapolation of the two first-order runs
RUN_DT, RUN_DT2 (steps Δt and Δt/2): x_ref = 2 x(Δt/2) − x(Δt) (``--order p``:
x(Δt/2) + (x(Δt/2) − x(Δt))/(2^p − 1)), its uncertainty |x(Δt/2) − x(Δt)| (dotted). Per run: max_t
|x_f(t) − x_ref(t)| [m], the deposit front, steps, LU
factorizations of the flow, rejected steps, CPU time (user + system) [s] and run.json's
``total`` [s]. The chart: error against CPU time and against factorizations (log-log) per
family (``bdf1``/``bdf2`` fixed Δt, ``tol``/``tolmax`` error-controlled in the rms/max norm; ``newton:…``
and ``al:…`` for
Newton and the augmented Lagrangian, by colour), and error against Δt for the fixed-step
families with the least-squares slope. ``--reference-run`` takes one run as the
reference instead (a much finer one; ``--reference-check`` a coarser run of its family, whose
distance to it is the dotted uncertainty), ``--times`` other compare times (step times of every
run, so that no interpolation error enters), ``--quantity`` another diagnostics column.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import re
from pathlib import Path

import numpy as np

TIMES = np.round(np.arange(0.1, 0.91, 0.1), 10)
QUANTITY = "front"
L0 = 0.297


def front_history(run: Path) -> np.ndarray:
    """x_f (or QUANTITY) at TIMES, interpolated between the steps that bracket each time."""
    with open(run / "diagnostics.csv") as fh:
        rows = list(csv.DictReader(fh))
    t = np.array([float(r["t"]) for r in rows])
    x = np.array([float(r[QUANTITY]) for r in rows])
    if QUANTITY == "front":    # before the first step: the toe at l0
        t, x = np.r_[0.0, t], np.r_[L0, x]
    return np.interp(TIMES, t, x)


def cpu_seconds(run: Path) -> float:
    """User + system time of ``/usr/bin/time -v`` in RUN.time [s] (NaN without it)."""
    path = Path(str(run) + ".time")
    if not path.exists():
        return math.nan
    text = path.read_text()
    user = float(re.search(r"User time \(seconds\): ([\d.]+)", text).group(1))
    system = float(re.search(r"System time \(seconds\): ([\d.]+)", text).group(1))
    return user + system


def method(config: dict) -> str:
    """The run's treatment of the yield stress: "picard", "newton" or "al" (augmented
    Lagrangian), from its saved config (the parsed config.yaml)."""
    numerics = config.get("numerics", {})
    if numerics.get("method") == "augmented_lagrangian":
        return "al"
    return "newton" if numerics.get("nonlinear_solver") == "newton" else "picard"


def family(run: Path) -> tuple[str, float | None]:
    """(family, Δt or tolerance) from the run's saved config: ``bdf1``/``bdf2`` (fixed Δt) or
    ``tol`` (error-controlled), prefixed ``newton:`` or ``al:`` for those methods."""
    import yaml

    config = yaml.safe_load((run / "config.yaml").read_text())
    cfg, name = config["time"], method(config)
    prefix = "" if name == "picard" else name + ":"
    if cfg.get("tolerance"):
        norm = "max" if cfg.get("error_norm") == "max" else ""
        return prefix + "tol" + norm, float(cfg["tolerance"])
    return prefix + cfg.get("scheme", "bdf1"), float(cfg["dt"])


def measure(run: Path, reference: np.ndarray) -> dict:
    info = json.loads((run / "run.json").read_text())
    s = info["summary"]
    kind, value = family(run)
    x = front_history(run)
    return {"run": run.name, "family": kind, "value": value, "status": s["status"],
            "error": float(np.max(np.abs(x - reference))),
            "error_time": float(TIMES[np.argmax(np.abs(x - reference))]),
            "deposit_front": s["front"], "steps": s["steps"],
            "factorizations": s["flow_factorizations"], "rejected": s.get("rejected_steps", 0),
            "remeshes": s["remeshes"], "cpu": cpu_seconds(run),
            "total": info["timings"]["total"]}


def slope(rows: list[dict], kind: str) -> float | None:
    """Least-squares slope of log(error) against log(Δt) of a fixed-step family."""
    pts = [(r["value"], r["error"]) for r in rows if r["family"] == kind]
    if len(pts) < 2:
        return None
    dt, err = np.log(np.array(pts)).T
    return float(np.polyfit(dt, err, 1)[0])


def plot(rows: list[dict], png: Path, title: str, floor: float | None = None) -> None:
    """The three panels; ``floor``: the reference's uncertainty, dotted."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    schemes = {"bdf1": ("o", "-", "BDF1, fixed Δt"), "bdf2": ("s", "--", "BDF2, fixed Δt"),
               "tol": ("^", ":", "BDF2, error-controlled"),
               "tolmax": ("v", "-.", "BDF2, error-controlled, max norm")}
    methods = {"": ("C0", "Picard + Anderson"), "newton:": ("C3", "Newton"),
               "al:": ("C2", "augmented Lagrangian")}
    several = any(":" in r["family"] for r in rows)   # Newton or AL runs: colour by method
    fig, axes = plt.subplots(1, 3, figsize=(15, 5.6 if several else 4.6))
    for prefix, (color, name) in methods.items():
        for scheme, (marker, ls, label) in schemes.items():
            kind = prefix + scheme
            sel = sorted((r for r in rows if r["family"] == kind), key=lambda r: r["value"])
            if not sel:
                continue
            label = f"{name}, {label}" if several else label
            style = dict(marker=marker, ls=ls, color=color if several else None)
            err = [r["error"] for r in sel]
            line = axes[0].loglog([r["cpu"] for r in sel], err, label=label, **style)[0]
            style["color"] = line.get_color()
            axes[1].loglog([r["factorizations"] for r in sel], err, label=label, **style)
            for r, e in zip(sel, err):
                tag = f"{1e3 * r['value']:g} ms" if not scheme.startswith("tol") else f"{r['value']:g}"
                axes[0].annotate(tag, (r["cpu"], e), fontsize=7, xytext=(3, 3),
                                 textcoords="offset points")
            if not scheme.startswith("tol"):
                p = slope(rows, kind)
                axes[2].loglog([1e3 * r["value"] for r in sel], err,
                               label=label if p is None else f"{label}: slope {p:.2f}", **style)
    if floor is not None:
        for ax in axes:
            ax.axhline(floor, color="grey", ls=":", lw=1)
    axes[0].set_xlabel("CPU time [s]")
    axes[1].set_xlabel("factorizations of the flow matrix")
    axes[2].set_xlabel("Δt [ms]")
    for ax in axes:
        ax.set_ylabel(f"max_t |{QUANTITY}(t) − reference(t)|" + (" [m]" if QUANTITY == "front" else ""))
        ax.grid(True, which="both", alpha=0.3)
    if several:   # one legend for the three panels, below them
        axes[1].legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=3)
        axes[2].legend(fontsize=7)
    else:
        for ax in axes:
            ax.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


def orders(args) -> None:
    """Error against Δt of the fixed-step runs for several quantities (one panel each)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    global QUANTITY
    fig, axes = plt.subplots(1, len(args.quantity), figsize=(5 * len(args.quantity), 4.4))
    table = []
    for ax, quantity in zip(axes, args.quantity):
        QUANTITY = quantity
        coarse, fine = (front_history(r) for r in args.reference)
        reference = fine + (fine - coarse) / (2 ** args.order - 1)
        rows = [measure(r, reference) for r in args.runs]
        for kind, mark in (("bdf1", "o-"), ("bdf2", "s-")):
            sel = sorted((r for r in rows if r["family"] == kind), key=lambda r: r["value"])
            if sel:
                p = slope(rows, kind)
                ax.loglog([1e3 * r["value"] for r in sel], [r["error"] for r in sel], mark,
                          label=f"{kind}: slope {p:.2f}")
                print(f"{quantity:15s} {kind}: slope {p:.2f}; errors "
                      + " ".join(f"{r['error']:.2e}" for r in sel))
        ax.set_xlabel("Δt [ms]")
        ax.set_ylabel(f"max_t |{quantity} − reference|")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        table += [{"quantity": quantity, **r} for r in rows]
    fig.suptitle(args.title)
    fig.tight_layout()
    fig.savefig(args.png, dpi=110)
    with open(args.csv, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(table[0]))
        writer.writeheader()
        writer.writerows(table)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reference", nargs=2, type=Path,
                    help="first-order runs with Δt and Δt/2 (Richardson)")
    ap.add_argument("--order", type=float, default=1.0,
                    help="order p of the reference runs' scheme (Richardson: x + (x − x')/(2^p − 1))")
    ap.add_argument("--reference-run", type=Path, help="one run taken as the reference")
    ap.add_argument("--reference-check", type=Path,
                    help="with --reference-run: a coarser run of the same family; its largest "
                         "distance to the reference is drawn as the reference's uncertainty")
    ap.add_argument("--times", nargs="+", type=float, help="compare times [s]")
    ap.add_argument("--quantity", nargs="+", default=["front"],
                    help="diagnostics column(s) (default front); several: only error against Δt, "
                         "one panel each")
    ap.add_argument("--runs", nargs="+", type=Path, required=True)
    ap.add_argument("--csv", type=Path, required=True)
    ap.add_argument("--png", type=Path, required=True)
    ap.add_argument("--title", default="Rigid collapse: front-history error against cost")
    args = ap.parse_args(argv)
    global TIMES, QUANTITY
    if args.times:
        TIMES = np.array(args.times)
    if len(args.quantity) > 1:
        return orders(args)
    QUANTITY = args.quantity[0]
    floor = None
    if args.reference_run is not None:
        reference = front_history(args.reference_run)
        if args.reference_check is not None:
            gap = np.abs(front_history(args.reference_check) - reference)
            floor = float(np.max(gap))
            print("uncert      " + " ".join(f"{g:8.2e}" for g in gap))
    else:
        coarse, fine = (front_history(r) for r in args.reference)
        reference = fine + (fine - coarse) / (2 ** args.order - 1)
        floor = float(np.max(np.abs(fine - coarse)))
        print("uncert      " + " ".join(f"{abs(f - c):8.2e}" for f, c in zip(fine, coarse)))
    print("t [s]       " + " ".join(f"{t:8.3f}" for t in TIMES))
    print("ref         " + " ".join(f"{x:8.5f}" for x in reference))
    rows = [measure(r, reference) for r in args.runs]
    with open(args.csv, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    for r in rows:
        print(f"{r['run']:24s} {r['family']:11s} {r['value']:8.2e} error {r['error']:8.2e} "
              f"(t={r['error_time']:.1f}) deposit {r['deposit_front']:.4f} m steps {r['steps']:5d} "
              f"LU {r['factorizations']:5d} rejected {r['rejected']:3d} CPU {r['cpu']:6.1f} s "
              f"total {r['total']:6.1f} s {r['status']}")
    for kind in sorted({r["family"] for r in rows if "tol" not in r["family"]}):
        p = slope(rows, kind)
        if p is not None:
            print(f"slope of the error against Δt, {kind}: {p:.2f}")
    plot(rows, args.png, args.title, floor)


if __name__ == "__main__":
    main()
