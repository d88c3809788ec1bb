"""``dpcollapse plot-sweep``: a column of ``sweep.csv`` against one varied parameter, one
line per value of a second (and per combination of the other varied parameters)."""

from __future__ import annotations

import csv
from pathlib import Path

from dpcollapse.errors import ConfigError
from dpcollapse.sweep.collect import DONE

__all__ = ["plot_sweep"]


def _read(sweep_dir: Path) -> tuple[list[str], list[dict]]:
    path = Path(sweep_dir) / "sweep.csv"
    try:
        with path.open(newline="") as fh:
            reader = csv.DictReader(fh)
            rows = list(reader)
            return list(reader.fieldnames or []), rows
    except FileNotFoundError:
        raise ConfigError(f"{path}: not found; run 'dpcollapse sweep SWEEP.yaml --collect' "
                          "first") from None


def _column(name: str, params: list[str], option: str) -> str:
    """A varied parameter by its full ``section.key`` or its last part."""
    matches = [p for p in params if p == name or p.rpartition(".")[2] == name]
    if len(matches) != 1:
        raise ConfigError(f"{option} = {name}: must be one of the varied parameters: "
                          + (", ".join(params) or "none"))
    return matches[0]


def _number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def plot_sweep(sweep_dir: Path, x: str, y: str = "runout", by: str | None = None,
               where: tuple[str, ...] = (), out: Path | None = None) -> Path:
    """Write the PNG and return its path. Failed and unfinished cases are left out (their
    number is in the title)."""
    fields, rows = _read(sweep_dir)
    params = fields[1:fields.index("status")] if "status" in fields else []
    x = _column(x, params, "--x")
    by = _column(by, params, "--by") if by else None
    if y not in fields or y in params or y in ("case", "status", "error", "run_dir"):
        numeric = [f for f in fields if f not in params and f not in
                   ("case", "status", "error", "run_dir")]
        raise ConfigError(f"--y = {y}: must be a numeric column of sweep.csv: "
                          + ", ".join(numeric))
    for item in where:
        key, sep, value = item.partition("=")
        if not sep:
            raise ConfigError(f"--where {item!r}: must be KEY=VALUE")
        key = _column(key.strip(), params, "--where")
        rows = [r for r in rows if r[key] == value.strip()]
    shown = [r for r in rows if r["status"] in DONE and _number(r[y]) is not None]
    left_out = len(rows) - len(shown)
    if not shown:
        raise ConfigError(f"{sweep_dir}: no finished case with a value of {y} to plot")
    others = [p for p in params if p not in (x, by) and len({r[p] for r in shown}) > 1]
    xs_num = all(_number(r[x]) is not None for r in shown)
    categories = list(dict.fromkeys(r[x] for r in shown))

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups: dict[tuple, list[dict]] = {}
    for r in shown:
        groups.setdefault(tuple(r[k] for k in ([by] if by else []) + others), []).append(r)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    markers = "os^Dv<>ph*"

    def short(k):
        return k.rpartition(".")[2]

    # colour: the value of --by; line style and marker: the other varied parameters
    colours = list(dict.fromkeys(k[0] for k in groups)) if by else [()]
    styles = list(dict.fromkeys(k[1:] if by else k for k in groups))
    dashes = ["-", "--", ":", "-."]
    for key, items in groups.items():
        pos = [(_number(r[x]) if xs_num else categories.index(r[x]), _number(r[y])) for r in items]
        pos.sort()
        label = ", ".join(f"{short(k)} = {v or 'base'}"
                          for k, v in zip(([by] if by else []) + others, key))
        c = colours.index(key[0]) if by else styles.index(key)
        j = styles.index(key[1:] if by else key) if by else 0
        ax.plot([p[0] for p in pos], [p[1] for p in pos], color=f"C{c % 10}",
                marker=markers[j % len(markers)],
                linestyle=dashes[j % len(dashes)] if len(pos) > 1 else "none", label=label or None)
    if not xs_num:
        ax.set_xticks(range(len(categories)), categories)
    ax.set_xlabel(x)
    unit = {"front": " [m]", "runout": " [m]", "max_height": " [m]", "t_end": " [s]",
            "wall_time": " [s]", "process_time": " [s]"}.get(y, "")
    ax.set_ylabel(y + unit)
    title = f"{Path(sweep_dir).resolve().name}: {y} against {short(x)}"
    if where:
        title += " (" + ", ".join(where) + ")"
    if left_out:
        title += f"\n{left_out} case(s) not shown (failed or not finished)"
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    if by or others:
        ax.legend(fontsize=8)
    fig.tight_layout()
    out = Path(out) if out else Path(sweep_dir) / f"{y}_vs_{short(x)}.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out

