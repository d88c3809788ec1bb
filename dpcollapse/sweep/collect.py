"""What each case's run directory says, and ``sweep.csv``: one row per case.

A sweep directory holds ``runs/<case>/`` (the run directories), ``records/<case>.json``
(how the sweep ran the case: exit code, process wall time, attempts), ``logs/<case>.log``
(the output of ``dpcollapse run``), ``sweep.csv`` and ``progress.txt``.
"""

from __future__ import annotations

import csv
import io
import json
import os
from dataclasses import dataclass
from pathlib import Path

from dpcollapse.config import GEOMETRIES, config_to_dict, from_saved, validate_config
from dpcollapse.errors import ConfigError
from dpcollapse.sweep.naming import yaml_value
from dpcollapse.sweep.spec import Case, Sweep

__all__ = [
    "DONE",
    "CaseState",
    "case_state",
    "collect",
    "progress_line",
    "read_json",
    "record_path",
    "run_dir",
    "write_atomic",
]

#: run.json statuses of a finished case: skipped when the sweep runs again.
DONE = ("at_rest", "end_time", "stopped_by_observer", "emptied")

#: The columns after the varied parameters, in order.
COLUMNS = ("case", "status", "exit_code", "front", "runout", "max_height", "t_end", "steps",
           "mean_iterations", "wall_time", "process_time", "error", "run_dir")


def run_dir(out: Path, case: Case) -> Path:
    return Path(out) / "runs" / case.name


def record_path(out: Path, case: Case) -> Path:
    return Path(out) / "records" / f"{case.name}.json"


def log_path(out: Path, case: Case) -> Path:
    return Path(out) / "logs" / f"{case.name}.log"


def read_json(path: Path) -> dict | None:
    """The JSON object in ``path``; None when missing or unreadable."""
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def write_atomic(path: Path, text: str) -> None:
    """Write ``text`` through a temporary file and a rename (never half-written)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


@dataclass(frozen=True)
class CaseState:
    """What the sweep finds for a case.

    ``state``: ``pending`` (nothing run), ``done`` (run.json status at_rest / end_time /
    stopped_by_observer with this config), ``failed`` (run.json failed, or the process ended
    with an exit status other than 0 and 130), ``interrupted`` (interrupted, or left
    ``running`` by a killed process), ``running`` (a process of this sweep is on it),
    ``stale`` (a run of another config: the base config or the sweep changed).
    """

    state: str
    status: str          #: run.json status ("" when none)
    exit_code: int | None
    run: dict | None     #: run.json
    record: dict | None  #: records/<case>.json
    resumable: bool      #: a checkpoint exists
    extendable: bool = False   #: stale only in what may change on resume (e.g. end time)


def saved_config(run: dict | None):
    """The config a run directory's run.json says it ran with, as this program reads it: a
    key added since (absent from the file) at its default, which by the project's rule
    reproduces the older program — so a finished run of an unchanged case stays done when
    the code gains a key. A config this program cannot validate (a key since removed) is
    compared as written."""
    saved = from_saved((run or {}).get("config"))
    try:
        return config_to_dict(validate_config(saved))
    except ConfigError:
        return saved


def case_state(out: Path, case: Case) -> CaseState:
    d = run_dir(out, case)
    run = read_json(d / "run.json")
    record = read_json(record_path(out, case))
    code = record.get("exit_code") if record else None
    running = bool(record and record.get("running"))
    resumable = any((d / n).is_file() for n in ("checkpoint.npz", "checkpoint.prev.npz"))
    if run is None:
        if running:
            return CaseState("running", "", None, None, record, resumable)
        state = "failed" if code not in (None, 0, 130) else "pending"
        return CaseState(state, "", code, None, record, resumable)
    status = str(run.get("status", ""))
    saved = saved_config(run)
    if saved != case.config:
        return CaseState("stale", status, code, run, record, resumable,
                         resumable and status != "failed" and _extendable(run, saved, case.config))
    if running:
        return CaseState("running", status, code, run, record, resumable)
    if status in DONE:
        state = "done"
    elif status == "failed" or code not in (None, 0, 130):
        state = "failed"
    else:  # interrupted, or running with no process: killed
        state = "interrupted"
    return CaseState(state, status, code, run, record, resumable)


def _extendable(run: dict, old, config: dict) -> bool:
    """True when the run's config ``old`` (``saved_config(run)``) differs from ``config`` only
    in keys that ``dpcollapse run --resume`` accepts changed, and the run has not gone past the
    new end time."""
    from dpcollapse.io.rundir import RESUMABLE_KEYS, changed_keys

    if not isinstance(old, dict):
        return False
    t = (run.get("summary") or {}).get("t", 0.0)
    end = (config.get("time") or {}).get("end_time", 0.0)
    return (all(k in RESUMABLE_KEYS for k in changed_keys(old, config))
            and isinstance(t, (int, float)) and t <= end + 1e-12)


def _last_line(path: Path) -> str:
    """The last line of a case's log (its error line, as a rule), at most 200 characters."""
    try:
        with Path(path).open("rb") as fh:
            fh.seek(max(0, fh.seek(0, os.SEEK_END) - 4096))
            lines = [ln.strip() for ln in fh.read().decode(errors="replace").splitlines()]
    except OSError:
        return f"see {path.parent.name}/{path.name}"
    lines = [ln for ln in lines if ln]
    return (lines[-1][:200] if lines else "no output") + f" (see logs/{path.name})"


def _total_wall(run: dict) -> float | None:
    """The time loop's wall time over every segment of a resumed run [s]."""
    walls = [s.get("timings", {}).get("total") for s in run.get("segments", [])]
    walls.append(run.get("timings", {}).get("total"))
    walls = [w for w in walls if isinstance(w, (int, float))]
    return sum(walls) if walls else None


def case_row(sweep: Sweep, out: Path, case: Case) -> dict:
    """The CSV row of one case (empty cells where a value is unknown)."""
    cs = case_state(out, case)
    row: dict = {k: yaml_value(case.params.get(k)) if k in case.params else ""
                 for k in sweep.varied}
    row.update(case=case.name, exit_code="" if cs.exit_code is None else cs.exit_code,
               run_dir=str(run_dir(out, case).relative_to(out)))
    row["status"] = cs.state if cs.state in ("pending", "stale", "running") else (
        cs.status if cs.state != "failed" or cs.status == "failed" else "failed")
    if cs.state == "done" and cs.exit_code not in (0, None):
        row["exit_code"] = ""    # an earlier attempt's (130 of an interrupt): the run has ended since
    rec = cs.record or {}
    attempts = rec.get("attempts", [])
    times = [a.get("process_time") for a in attempts if isinstance(a.get("process_time"),
                                                                   (int, float))]
    row["process_time"] = sum(times) if times else ""
    summary = (cs.run or {}).get("summary", {}) if cs.state != "stale" else {}
    geometry = case.config.get("geometry", {})
    front = summary.get("front")
    row.update(front=front, max_height=summary.get("max_height"), t_end=summary.get("t"),
               steps=summary.get("steps"), mean_iterations=summary.get("mean_iterations"),
               wall_time=_total_wall(cs.run) if summary else None)
    kind = GEOMETRIES.get(geometry.get("shape", "trapezoid"))
    if isinstance(front, (int, float)) and kind is not None and not kind.periodic:
        row["runout"] = front - geometry.get("base_length", 0.0)
    row["error"] = summary.get("error") or (
        f"exit {cs.exit_code}: {_last_line(log_path(out, case))}" if cs.state == "failed" else "")
    for key in [k for k in summary if k.startswith("front_")] + list(sweep.spec.collect):
        row[key] = summary.get(key)
    return {k: ("" if v is None else v) for k, v in row.items()}


def collect(sweep: Sweep, out: Path, rows: dict[str, dict] | None = None) -> list[dict]:
    """Write ``out/sweep.csv`` (rows given, or read now from every case) and return the rows."""
    rows = rows or {}
    table = [rows.get(c.name) or case_row(sweep, out, c) for c in sweep.cases]
    extra: list[str] = []
    for r in table:
        extra += [k for k in r if k not in extra and k not in COLUMNS and k not in sweep.varied]
    fields = ["case", *sweep.varied, *[k for k in COLUMNS if k != "case"], *extra]
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=fields, lineterminator="\n", restval="")
    writer.writeheader()
    for r in table:
        writer.writerow({k: _cell(r.get(k, "")) for k in fields})
    write_atomic(Path(out) / "sweep.csv", buf.getvalue())
    return table


def _cell(v):
    return repr(v) if isinstance(v, float) else v


def progress_line(table: list[dict], elapsed: float | None = None) -> str:
    """``12 cases: 7 done, 1 failed, 2 running, 2 to go`` (+ elapsed time)."""
    status = [r["status"] for r in table]
    done = sum(s in DONE for s in status)
    failed = status.count("failed")
    running = status.count("running")
    interrupted = status.count("interrupted")
    rest = len(status) - done - failed - running - interrupted
    line = (f"{len(status)} cases: {done} done, {failed} failed, {running} running, "
            f"{interrupted} interrupted, {rest} to go")
    if elapsed is not None:
        line += f" ({elapsed:.0f} s)"
    return line
