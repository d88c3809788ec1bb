"""Measure how far round-off moves the regression values: every case under several
floating-point environments (OpenBLAS kernels, BLAS threads), one subprocess each.

The regression tier compares the current code with stored values. Those values are not
bit-portable: MUMPS runs on OpenBLAS, whose kernel (chosen per CPU, or forced with
``OPENBLAS_CORETYPE``) and thread count change the order of floating-point sums, and a
collapse amplifies that round-off into a remesh more or fewer and a fraction of a
millimetre of runout. This script measures the spread, so that the tolerances of
``test_regression.py`` are set from numbers, not guessed::

    python tests/regression/spread.py run --out tests/regression/spread-0.5.json
    python tests/regression/spread.py summary tests/regression/spread-*.json
    python tests/regression/spread.py tolerances tests/regression/spread-*.json \
        --write tests/regression/reference.json

``run`` appends to ``--out`` (one entry per environment and case; reruns replace the
entry), so an interrupted measurement resumes and other DOLFINx versions (run inside a
Debian 13 or sid chroot) add their own file. ``summary`` prints, per case and quantity, the
smallest and largest value over every environment of every file, and the spread.
``tolerances`` writes the reference file that ``test_regression.py`` reads: per case and
quantity the centre of the measured range and a tolerance of :data:`FACTOR` times the
spread, never below the floors of :data:`FLOORS` (a platform nobody measured may round
differently again).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent

#: name -> environment overrides. The kernels are OpenBLAS's DYNAMIC_ARCH targets; one
#: that the CPU cannot execute is skipped (OpenBLAS falls back or the process dies: the
#: run is then recorded as failed, not as a value). ``auto-1``: no OPENBLAS_CORETYPE, the
#: kernel OpenBLAS picks for the CPU (what a chroot or a user's shell without the variable
#: runs; on this machine's AMD EPYC it is none of the named ones for the pip wheel's OpenBLAS).
ENVIRONMENTS: dict[str, dict[str, str | None]] = {
    "auto-1": {"OPENBLAS_CORETYPE": None, "OPENBLAS_NUM_THREADS": "1"},
    "prescott-1": {"OPENBLAS_CORETYPE": "Prescott", "OPENBLAS_NUM_THREADS": "1"},
    "sandybridge-1": {"OPENBLAS_CORETYPE": "Sandybridge", "OPENBLAS_NUM_THREADS": "1"},
    "haswell-1": {"OPENBLAS_CORETYPE": "Haswell", "OPENBLAS_NUM_THREADS": "1"},
    "zen-1": {"OPENBLAS_CORETYPE": "Zen", "OPENBLAS_NUM_THREADS": "1"},
    "skylakex-1": {"OPENBLAS_CORETYPE": "SkylakeX", "OPENBLAS_NUM_THREADS": "1"},
    "haswell-2": {"OPENBLAS_CORETYPE": "Haswell", "OPENBLAS_NUM_THREADS": "2"},
}

#: Quantities whose spread is reported (the ones test_regression.py compares).
KEYS = ("steps", "remeshes", "flow_solves", "t", "front", "max_height", "kinetic_energy",
        "max_speed")


#: Tolerance = max(FACTOR * (max - min), absolute floor, relative floor * |centre|): the
#: accepted band reaches 1.5 spreads beyond each measured extreme.
FACTOR = 2.0
#: key -> (absolute floor, relative floor). Counts may be compared exactly when no
#: environment moved them; positions never tighter than 10 µm; energies and speeds never
#: tighter than 1e-5 relative (1e-9 J/m and 1e-6 m/s absolute, for a mass at rest).
FLOORS: dict[str, tuple[float, float]] = {
    "steps": (0.0, 0.0), "remeshes": (0.0, 0.0), "flow_solves": (0.0, 0.0),
    "t": (1e-9, 0.0), "front": (1e-5, 0.0), "max_height": (1e-5, 0.0),
    "kinetic_energy": (1e-9, 1e-5), "max_speed": (1e-6, 1e-5),
}


def _dolfinx_version() -> str:
    out = subprocess.run([sys.executable, "-c", "import dolfinx; print(dolfinx.__version__)"],
                         capture_output=True, text=True)
    return out.stdout.strip() or "unknown"


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def run(out: Path, envs: list[str], cases: list[str]) -> int:
    data = json.loads(out.read_text()) if out.exists() else {}
    data.setdefault("meta", {}).update({"dolfinx": _dolfinx_version(), "cpu": _cpu()})
    data.setdefault("runs", {})
    for env_name in envs:
        env = {**os.environ, **ENVIRONMENTS[env_name], "OMP_NUM_THREADS": "1"}
        env = {k: v for k, v in env.items() if v is not None}   # None: unset
        for case in cases:
            with tempfile.TemporaryDirectory() as tmp:
                values = Path(tmp) / "values.json"
                proc = subprocess.run(
                    [sys.executable, str(HERE / "record.py"), "--out", str(values), case],
                    env=env, capture_output=True, text=True)
                if proc.returncode == 0 and values.exists():
                    entry = json.loads(values.read_text())[case]
                else:
                    entry = {"failed": proc.returncode, "stderr": proc.stderr[-400:]}
            data["runs"].setdefault(env_name, {})[case] = entry
            print(env_name, case, {k: entry.get(k) for k in KEYS} if "failed" not in entry
                  else entry, flush=True)
            out.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    return 0


def spreads(files: list[Path]) -> dict[str, dict[str, tuple[float, float, list[str]]]]:
    """case -> key -> (min, max, [environment labels]) over every file's environments."""
    table: dict[str, dict[str, list]] = {}
    for f in files:
        data = json.loads(f.read_text())
        version = data.get("meta", {}).get("dolfinx", f.stem)
        for env_name, cases in data["runs"].items():
            for case, entry in cases.items():
                if "failed" in entry:
                    continue
                for key in KEYS:
                    if key in entry:  # a reported run may give only some quantities
                        table.setdefault(case, {}).setdefault(key, []).append(
                            (float(entry[key]), f"{version}/{env_name}"))
    return {case: {key: (min(v for v, _ in vals), max(v for v, _ in vals),
                         [label for _, label in vals])
                   for key, vals in keys.items()}
            for case, keys in table.items()}


def summary(files: list[Path], markdown: bool = False) -> int:
    if markdown:
        print("| case | runs | " + " | ".join(KEYS) + " |")
        print("| --- | --- |" + " --- |" * len(KEYS))
        for case, keys in sorted(spreads(files).items()):
            n = len({label for _, _, labels in keys.values() for label in labels})
            cells = [f"{keys[k][1] - keys[k][0]:.3g}" if k in keys else "–" for k in KEYS]
            print(f"| {case} | {n} | " + " | ".join(cells) + " |")
        return 0
    for case, keys in sorted(spreads(files).items()):
        n = len(next(iter(keys.values()))[2])
        print(f"{case} ({n} runs)")
        for key, (lo, hi, _) in keys.items():
            print(f"  {key:15s} min {lo:<22.12g} max {hi:<22.12g} spread {hi - lo:.3g}")
    return 0


def _versions(labels) -> set[str]:
    """The DOLFINx versions of run labels "version/environment" (values reported by other
    machines, ``other-machines``, are not a version of their own)."""
    return {label.split("/")[0] for label in labels} - {"other-machines"}


def version_margins(table: dict, statuses: dict[str, set[str]]) -> tuple[dict[str, float], set[str]]:
    """(key -> relative margin, every version measured): for a case not measured on every
    version (a new case before the chroots ran it), FACTOR × the largest relative spread
    |max − min|/|centre| of that key over the cases that were, among those that end at
    ``end_time`` (a run to rest ends on a speed and energy near zero: their relative spread
    means nothing). Measured 2026-12-07 from the files of that day: kinetic energy 5.9e-4
    and max speed 7.9e-4 (mu_i_collapse_short, whose 0.5.2 kernels agree to 1e-14 but whose
    0.9/0.11 runs do not), fixed-point iterations 0.19 (bagnold_short)."""
    labels = {case: {label for _, _, key_labels in keys.values() for label in key_labels}
              for case, keys in table.items()}
    everywhere = set().union(*(_versions(v) for v in labels.values())) if labels else set()
    margins: dict[str, float] = {}
    for case, keys in table.items():
        if _versions(labels[case]) != everywhere or statuses.get(case) != {"end_time"}:
            continue
        for key, (lo, hi, _) in keys.items():
            centre = abs(0.5 * (lo + hi))
            if centre > 0:
                margins[key] = max(margins.get(key, 0.0), FACTOR * (hi - lo) / centre)
    return margins, everywhere


def tolerances(files: list[Path], write: Path) -> int:
    """Write the reference file of test_regression.py from the measured ranges."""
    statuses: dict[str, set[str]] = {}
    for f in files:
        for cases in json.loads(f.read_text())["runs"].values():
            for case, entry in cases.items():
                if "failed" not in entry and "status" in entry:
                    statuses.setdefault(case, set()).add(entry["status"])
    table = spreads(files)
    margins, everywhere = version_margins(table, statuses)
    cases = {}
    for case, keys in sorted(table.items()):
        if len(statuses[case]) != 1:
            print(f"spread: {case} ends in different states {sorted(statuses[case])}: "
                  "no reference can be set", file=sys.stderr)
            return 1
        value, tolerance, measured = {}, {}, {}
        labels = set()
        for key, (lo, hi, key_labels) in keys.items():
            labels.update(key_labels)
            centre = 0.5 * (lo + hi)
            absolute, relative = FLOORS[key]
            value[key] = centre
            tolerance[key] = max(FACTOR * (hi - lo), absolute, relative * abs(centre))
            measured[key] = [lo, hi]
        missing = everywhere - _versions(labels)
        if missing:   # not measured there: the largest relative spread the others showed
            for key in keys:
                tolerance[key] = max(tolerance[key], margins.get(key, 0.0) * abs(value[key]))
        cases[case] = {"status": statuses[case].pop(), "value": value, "tolerance": tolerance,
                       "measured": measured, "runs": sorted(labels)}
        if missing:
            cases[case]["unmeasured"] = sorted(missing)
    doc = {
        "about": "written by tests/regression/spread.py tolerances from " +
                 ", ".join(f.name for f in files) +
                 f"; tolerance = max({FACTOR:g} x measured spread, floors)",
        "floors": {k: list(v) for k, v in FLOORS.items()},
        "cases": cases,
    }
    write.write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n")
    print(f"wrote {write} ({len(cases)} cases)")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run the cases under the environments")
    r.add_argument("--out", type=Path, required=True)
    r.add_argument("--envs", default=",".join(ENVIRONMENTS),
                   help=f"comma-separated, of {list(ENVIRONMENTS)}")
    r.add_argument("--cases", default="",
                   help="comma-separated (default: every case of record.py, the full run last)")
    s = sub.add_parser("summary", help="min, max and spread over files")
    s.add_argument("files", nargs="+", type=Path)
    s.add_argument("--markdown", action="store_true", help="one table row per case")
    t = sub.add_parser("tolerances", help="write the reference file from the measured ranges")
    t.add_argument("files", nargs="+", type=Path)
    t.add_argument("--write", type=Path, required=True)
    args = ap.parse_args(argv)
    if args.command == "summary":
        return summary(args.files, args.markdown)
    if args.command == "tolerances":
        return tolerances(args.files, args.write)
    sys.path.insert(0, str(HERE))
    from record import CASES, FULL  # noqa: E402  (record.py imports nothing from tests)

    cases = args.cases.split(",") if args.cases else list(CASES) + list(FULL)
    envs = args.envs.split(",")
    unknown = [e for e in envs if e not in ENVIRONMENTS] + [
        c for c in cases if c not in {**CASES, **FULL}]
    if unknown:
        print(f"spread: unknown environment or case: {', '.join(unknown)}", file=sys.stderr)
        return 2
    return run(args.out, envs, cases)


if __name__ == "__main__":
    sys.exit(main())
