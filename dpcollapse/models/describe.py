"""The lines of ``dpcollapse check`` that every 2D model shares: friction coefficients, the
law's own parameters, the initial mass, the time steps. Each model's factory
(``describe(cfg)``) adds its own and may replace these."""

from __future__ import annotations

from dpcollapse.rheology.choice import law_from_material


def friction_line(cfg) -> str:
    m, b = cfg.material, cfg.boundary
    return f"mu_s = {m.mu_s:.4f}  mu_b = {b.mu_bed:.4f}  mu_l = {b.mu_wall:.4f}"


def law_lines(cfg) -> list[str]:
    """The law's own line (μ(I): its parameters and well-posed window), if it has one."""
    line = law_from_material(cfg.material).describe()
    return [line] if line else []


def time_line(cfg) -> str:
    t = cfg.time
    if t.adaptive:
        return (f"time: adaptive dt from {t.dt:g} s up to {t.dt_max:g} s (Courant number <= "
                f"{t.cfl:g}), end {t.end_time:g} s")
    return f"time: dt {t.dt:g} s, end {t.end_time:g} s, at most {t.max_steps} steps"


def lines_2d(cfg, model_lines: list[str]) -> list[str]:
    """friction, the law, ``model_lines``, the mass, the time steps."""
    return [friction_line(cfg), *law_lines(cfg), *model_lines, cfg.geometry.describe(),
            time_line(cfg)]
