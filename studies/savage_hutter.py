"""Verification of the Savage–Hutter solver: convergence tables and plots.

    python -m studies.savage_hutter [--quick] [--out docs/figures]

* Mangeney et al. (2000) dam break: θ = 22°, δ = 21°, h0 = 1 m, dam at x = 0, domain
  [−20, 40] m with open (zero-gradient) ends — the sliding reservoir h = h0, ū = m t is then
  exact at the left end, so the reservoir is effectively infinite — t = 5 s. L1 error
  ‖h − h_exact‖₁ = Σ|h_i − h_exact(x_i)| Δx [m²] at orders 1 and 2, observed orders
  log2(e_N/e_2N), CPU time (time.process_time), fronts at h = 1 mm against the exact one.
* Kerswell (2005) arrest on a flat bed: μ = 0.5, h0 = 1 m, reservoir [−10, 0] m behind a wall,
  domain to 6 m, run to 6 s (or to rest); the front stop time (last step at which the wet front
  advanced) and runout (final wet front, and the 1 mm front) against 2√(h0/g)/μ and 2h0/μ;
  fitted rates, at orders 1 and 2.
* A heap at rest on a 10° slope (μ = tan 30°): max|ū| and max|Δh| after many steps, with the
  friction locking and with the plain split.
* The shape factor α = 5/4 on a column: fastest speed and runout against the taper depth h_α.
* The 1600-cell dam break timing (best and median of repeats, load average stated).

Writes docs/figures/savage_hutter_mangeney.png and docs/figures/savage_hutter_kerswell.png.
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import statistics
import sys
from pathlib import Path

import numpy as np

from dpcollapse.models.savage_hutter.exact import (
    kerswell_front,
    kerswell_runout,
    kerswell_stop_time,
    mangeney_dam_break,
)
from dpcollapse.models.savage_hutter.friction import CoulombFriction, MuIFriction
from dpcollapse.models.savage_hutter.solver import Grid, SavageHutter, simulate

G = 9.81
MANGENEY = {"theta": 22.0, "delta": 21.0, "h0": 1.0, "t": 5.0, "x_min": -20.0, "x_max": 40.0}
KERSWELL = {"mu": 0.5, "h0": 1.0, "x_min": -10.0, "x_max": 6.0, "t_end": 6.0}
FRONT_THRESHOLD = 1e-3


def dam(h0: float):
    """Initial reservoir h = h0 for x < 0."""
    return lambda x: np.where(x < 0.0, h0, 0.0)


def mangeney_model(order: int = 1, cfl: float = 0.9) -> SavageHutter:
    """The Mangeney case's model (open ends, Coulomb δ = 21° on θ = 22°)."""
    return SavageHutter(basal=CoulombFriction(math.tan(math.radians(MANGENEY["delta"]))),
                        slope_deg=MANGENEY["theta"], left="open", right="open", order=order,
                        cfl=cfl, front_threshold=FRONT_THRESHOLD)


def mangeney_exact_front(threshold: float = FRONT_THRESHOLD) -> float:
    """x where the exact fan thickness equals threshold at t: tip − t √(9 g cosθ threshold)."""
    c = MANGENEY
    g_cos = G * math.cos(math.radians(c["theta"]))
    m = G * math.sin(math.radians(c["theta"])) - g_cos * math.tan(math.radians(c["delta"]))
    t = c["t"]
    tip = m * t * t / 2 + 2 * math.sqrt(g_cos * c["h0"]) * t
    return tip - t * math.sqrt(9 * g_cos * threshold)


def mangeney_run(n: int, order: int = 1, cfl: float = 0.9) -> dict:
    """One dam-break run: L1 errors of h (and of h ū), fronts, steps, CPU, mass balance."""
    c = MANGENEY
    grid = Grid(c["x_min"], c["x_max"], n)
    res = simulate(mangeney_model(order, cfl), grid, dam(c["h0"]), [c["t"]])
    h_ex, u_ex = mangeney_dam_break(grid.centers, c["t"], c["h0"], c["theta"], c["delta"], G)
    h, u = res.h[-1], res.u[-1]
    return {"n": n, "dx": grid.dx, "order": order, "steps": res.steps, "cpu": res.cpu_seconds,
            "err_h": float(np.sum(np.abs(h - h_ex)) * grid.dx),
            "err_q": float(np.sum(np.abs(h * u - h_ex * u_ex)) * grid.dx),
            "front": float(res.front[-1]), "wet_front": float(res.wet_front[-1]),
            "mass_balance": float(res.mass[-1] + res.series["outflow"][-1] - res.initial_mass),
            "x": grid.centers, "h": h, "h_exact": h_ex}


def observed_orders(errors) -> list:
    """log2(e_k / e_{k+1}) for successive halvings of Δx (None for the first)."""
    return [None] + [math.log2(a / b) for a, b in itertools.pairwise(errors)]


def fitted_rate(dxs, errors) -> float:
    """Least-squares slope of log(error) against log(Δx)."""
    return float(np.polyfit(np.log(dxs), np.log(errors), 1)[0])


def kerswell_model(order: int = 1) -> SavageHutter:
    """Flat bed, Coulomb μ, walls at both ends."""
    return SavageHutter(basal=CoulombFriction(KERSWELL["mu"]), slope_deg=0.0, left="wall",
                        right="wall", order=order, front_threshold=FRONT_THRESHOLD)


def kerswell_run(n: int, order: int = 1) -> dict:
    """One arrest run: front stop time and runout (wet and 1 mm fronts), rest time, mass."""
    c = KERSWELL
    grid = Grid(c["x_min"], c["x_max"], n)
    res = simulate(kerswell_model(order), grid, dam(c["h0"]), [c["t_end"]])
    s = res.series
    moved = np.flatnonzero(np.diff(s["wet_front"]) > 0)
    stop_time = float(s["t"][moved[-1] + 1]) if moved.size else 0.0
    return {"n": n, "dx": grid.dx, "order": order, "steps": res.steps, "cpu": res.cpu_seconds,
            "stop_time": stop_time, "rest_time": res.rest_time,
            "runout_wet": float(s["wet_front"][-1]), "runout_thr": float(s["front"][-1]),
            "mass_error": float(res.mass[-1] - res.initial_mass), "t": s["t"],
            "wet_front": s["wet_front"], "front": s["front"], "x": grid.centers, "h": res.h[-1]}


def heap_run(well_balanced: bool, basal=None, n: int = 350, t_end: float = 20.0,
             earth_pressure=None) -> dict:
    """Heap on a 10° slope, faces rising 0.5 (upslope) and falling 0.3 (downslope), peak 1 m:
    ∂x h − tanθ ∈ {0.324, −0.476}, within μ = tan 30° = 0.577, so it must stay at rest
    (earth_pressure: an ``EarthPressure``, K ∂x h in place of ∂x h; None: K = 1)."""
    basal = basal or CoulombFriction(math.tan(math.radians(30.0)))
    model = SavageHutter(basal=basal, slope_deg=10.0, left="open", right="open",
                         well_balanced=well_balanced, earth_pressure=earth_pressure)
    grid = Grid(-3.0, 4.0, n)
    h0 = grid.cell_values(lambda x: np.maximum(0.0, np.where(x < 0, 1 + 0.5 * x, 1 - 0.3 * x)))
    res = simulate(model, grid, h0, [t_end], stop_at_rest=False)
    return {"steps": res.steps, "max_speed": float(np.max(res.series["max_speed"])),
            "max_dh": float(np.max(np.abs(res.h[-1] - h0))),
            "mass_error": float(res.mass[-1] - res.initial_mass)}


def column_run(basal, alpha: float, alpha_depth: float, n: int, t_end: float = 5.0) -> dict:
    """A 0.4 m high, 0.2 m long column against a wall on a flat bed, domain 4 m, open end."""
    model = SavageHutter(basal=basal, shape_factor=alpha, alpha_depth=alpha_depth, left="wall",
                         right="open", front_threshold=FRONT_THRESHOLD)
    res = simulate(model, Grid(0.0, 4.0, n), lambda x: np.where(x < 0.2, 0.4, 0.0), [t_end])
    return {"front": float(res.front[-1]), "wet_front": float(res.wet_front[-1]),
            "max_speed": float(np.max(res.series["max_speed"])),
            "outflow": float(res.series["outflow"][-1]), "rest_time": res.rest_time,
            "steps": res.steps, "cpu": res.cpu_seconds}


def timing(n: int = 1600, repeats: int = 7, order: int = 1) -> dict:
    """CPU seconds (time.process_time) of the Mangeney dam break to 5 s on n cells."""
    times = [mangeney_run(n, order)["cpu"] for _ in range(repeats)]
    return {"n": n, "order": order, "best": min(times), "median": statistics.median(times),
            "repeats": repeats, "load": os.getloadavg()}


def _plot_mangeney(runs, out: Path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax_err) = plt.subplots(1, 2, figsize=(11, 4.2))
    first = runs[0]
    ax.plot(first["x"], first["h_exact"], "k-", lw=2, label="exact (Mangeney et al. 2000)")
    for r in runs:
        if r["n"] in (200, 800, 3200) or r is runs[-1]:
            style = "-" if r["order"] == 1 else "--"
            ax.plot(r["x"], r["h"], style, lw=1, label=f"order {r['order']}, N = {r['n']}")
    ax.set_xlabel("x along the slope [m]")
    ax.set_ylabel("h [m]")
    ax.set_title("dam break, θ = 22°, δ = 21°, t = 5 s")
    ax.set_xlim(-16, 36)
    ax.legend(fontsize=8, loc="lower left")
    zoom = ax.inset_axes([0.55, 0.45, 0.42, 0.35])
    zoom.plot(first["x"], first["h_exact"], "k-", lw=2)
    for r in runs:
        if r["n"] in (200, 800, 3200) or r is runs[-1]:
            zoom.plot(r["x"], r["h"], "-" if r["order"] == 1 else "--", lw=1)
    zoom.set_xlim(15, 33)
    zoom.set_ylim(0, 0.2)
    zoom.set_title("front", fontsize=8)
    zoom.tick_params(labelsize=7)
    for order, mark in ((1, "o-"), (2, "s--")):
        rs = [r for r in runs if r["order"] == order]
        if rs:
            ax_err.loglog([r["cpu"] for r in rs], [r["err_h"] for r in rs], mark,
                          label=f"order {order}")
            for r in rs:
                ax_err.annotate(str(r["n"]), (r["cpu"], r["err_h"]), fontsize=7)
    ax_err.set_xlabel("CPU time [s] (labels: N cells)")
    ax_err.set_ylabel("L1 error of h [m²]")
    ax_err.set_title("error against cost")
    ax_err.legend()
    ax_err.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def _plot_kerswell(runs, out: Path, runs2=()):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    c = KERSWELL
    fig, (ax, ax_h) = plt.subplots(1, 2, figsize=(11, 4.2))
    t = np.linspace(0, c["t_end"], 300)
    ax.plot(t, kerswell_front(t, c["h0"], c["mu"], G), "k-", lw=2, label="exact (Kerswell 2005)")
    for r in runs:
        ax.plot(r["t"], r["wet_front"], "-", lw=1, label=f"wet front, N = {r['n']}")
    for r in runs2:
        ax.plot(r["t"], r["wet_front"], "--", lw=1, label=f"order 2, N = {r['n']}")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("front x_f − x0 [m]")
    ax.set_title(f"arrest on a flat bed, μ = {c['mu']}, h0 = {c['h0']} m (order 1 unless noted)")
    ax.legend(fontsize=8)
    for r in runs:
        ax_h.plot(r["x"], r["h"], lw=1, label=f"N = {r['n']}")
    ax_h.axvline(kerswell_runout(c["h0"], c["mu"]), color="k", ls=":", label="2h0/μ")
    ax_h.set_xlabel("x [m]")
    ax_h.set_ylabel("deposit h [m]")
    ax_h.set_xlim(-6, c["x_max"])
    ax_h.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def _fmt(v, spec):
    return "—" if v is None else format(v, spec)


def main(argv=None) -> int:
    """Print the tables, write the plots; exit code 0."""
    parser = argparse.ArgumentParser(prog="python -m studies.savage_hutter")
    parser.add_argument("--quick", action="store_true", help="coarser meshes, fewer repeats")
    parser.add_argument("--out", default="runs/savage_hutter", help="directory of the PNG plots")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    ns = (200, 400, 800, 1600) if args.quick else (200, 400, 800, 1600, 3200, 6400)

    print(f"Mangeney dam break: θ = {MANGENEY['theta']}°, δ = {MANGENEY['delta']}°, "
          f"h0 = {MANGENEY['h0']} m, t = {MANGENEY['t']} s, domain "
          f"[{MANGENEY['x_min']}, {MANGENEY['x_max']}] m; exact 1 mm front "
          f"{mangeney_exact_front():.3f} m")
    print("order      N   dx[m]  steps  cpu[s]   L1(h)[m²]  order_h  L1(hu)[m³/s]  order_hu"
          "  front1mm  wet_front  mass_balance")
    runs = []
    for order in (1, 2):
        rows = [mangeney_run(n, order) for n in ns]
        runs += rows
        oh = observed_orders([r["err_h"] for r in rows])
        oq = observed_orders([r["err_q"] for r in rows])
        for r, a, b in zip(rows, oh, oq):
            print(f"{order:5d} {r['n']:6d} {r['dx']:7.4f} {r['steps']:6d} {r['cpu']:7.3f} "
                  f"{r['err_h']:11.4e} {_fmt(a, '8.3f')} {r['err_q']:13.4e} {_fmt(b, '9.3f')} "
                  f"{r['front']:9.3f} {r['wet_front']:10.3f} {r['mass_balance']:13.2e}")
        rate = fitted_rate([r["dx"] for r in rows], [r["err_h"] for r in rows])
        print(f"      fitted rate of L1(h): {rate:.3f}")
    _plot_mangeney(runs, out / "savage_hutter_mangeney.png")

    c = KERSWELL
    t_stop, runout = kerswell_stop_time(c["h0"], c["mu"], G), kerswell_runout(c["h0"], c["mu"])
    print(f"\nKerswell arrest: μ = {c['mu']}, h0 = {c['h0']} m; exact stop time {t_stop:.4f} s, "
          f"runout {runout:.4f} m")
    print("     N   dx[m]  steps  cpu[s]  stop_t[s]  err_t   runout_wet  err_wet  "
          "runout_1mm  err_1mm  rest_time[s]  mass_error")
    for order in (1, 2):
        rows = [kerswell_run(n, order) for n in ns]
        print(f"order {order}")
        for r in rows:
            print(f"{r['n']:6d} {r['dx']:7.4f} {r['steps']:6d} {r['cpu']:7.3f} "
                  f"{r['stop_time']:9.4f} {r['stop_time'] - t_stop:7.4f} {r['runout_wet']:11.4f} "
                  f"{r['runout_wet'] - runout:8.4f} {r['runout_thr']:11.4f} "
                  f"{r['runout_thr'] - runout:8.4f} {_fmt(r['rest_time'], '13.4f')} "
                  f"{r['mass_error']:11.2e}")
        dxs = [r["dx"] for r in rows]
        rate_t = fitted_rate(dxs, [abs(r["stop_time"] - t_stop) for r in rows])
        rate_w = fitted_rate(dxs, [abs(r["runout_wet"] - runout) for r in rows])
        rate_1 = fitted_rate(dxs, [abs(r["runout_thr"] - runout) for r in rows])
        print(f"fitted rates: stop time {rate_t:.3f}, wet runout {rate_w:.3f}, "
              f"1 mm runout {rate_1:.3f}")
        if order == 1:
            krows = rows
    _plot_kerswell(krows[::2] if len(krows) > 4 else krows, out / "savage_hutter_kerswell.png",
                   rows[-1:])

    print("\nHeap at rest on a 10° slope, μ = tan 30°, N = 350, 20 s:")
    mu = math.tan(math.radians(30.0))
    for label, wb, basal in (("locking, Coulomb", True, None),
                             ("locking, μ(I)", True, MuIFriction(mu, mu + 0.28, 0.4, 1e-3)),
                             ("plain split, Coulomb", False, None)):
        r = heap_run(wb, basal)
        print(f"  {label:22s} steps {r['steps']:5d}  max|ū| {r['max_speed']:.3e} m/s  "
              f"max|Δh| {r['max_dh']:.3e} m  mass error {r['mass_error']:.1e} m²")

    print("\nShape factor: 0.4 m x 0.2 m column, flat bed, wall + open end at 4 m, to 5 s "
          "(max speed over the run; front at 1 mm):")
    print("  friction   alpha  h_alpha[m]      N  steps  max|u|[m/s]  front1mm[m]  wet_front[m]"
          "  outflow[m2]")
    laws = (("Coulomb", CoulombFriction(0.4)), ("mu(I)", MuIFriction(0.32, 0.60, 0.4, 1e-3)))
    for name, law in laws:
        for alpha, depth in ((1.0, 1e-3), (1.25, 1e-3), (1.25, 1e-2), (1.25, 5e-2)):
            for n in ((400,) if args.quick else (400, 1600)):
                r = column_run(law, alpha, depth, n)
                print(f"  {name:9s} {alpha:6.2f} {depth:10.0e} {n:6d} {r['steps']:6d} "
                      f"{r['max_speed']:12.2f} {r['front']:12.3f} {r['wet_front']:13.3f} "
                      f"{r['outflow']:12.2e}")
    r = column_run(CoulombFriction(0.4), 1.25, 1e-9, 400, t_end=0.05)
    print(f"  untapered (h_alpha = 1e-9 m), Coulomb, N = 400, to 0.05 s: max|u| "
          f"{r['max_speed']:.1f} m/s after {r['steps']} steps")

    repeats = 3 if args.quick else 7
    print("\nTiming, 1600-cell dam break to 5 s (time.process_time):")
    for order in (1, 2):
        tm = timing(1600, repeats, order)
        print(f"  order {order}: best {tm['best']:.3f} s, median {tm['median']:.3f} s over "
              f"{tm['repeats']} runs; load average {tm['load'][0]:.2f} {tm['load'][1]:.2f} "
              f"{tm['load'][2]:.2f} on {os.cpu_count()} cores")
    print(f"\nplots: {out / 'savage_hutter_mangeney.png'}, {out / 'savage_hutter_kerswell.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
