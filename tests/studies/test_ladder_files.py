"""The ladder never touches what it did not write (issue 47): ``--work`` clears only the run
directories it made (a marker file in each; in them only the files a run writes), a user's
folder of a case's name is refused before any run; ``--plot-only`` leaves ladder.csv as it
is (a column the user added stays); a CSV that is not the ladder's is bad input (one line,
exit 2) for ``--plot-only`` and ``--two-phase``, not "Unknown format code 'g'"."""

from __future__ import annotations

import csv
import shutil

import pytest

from studies import ladder
from studies.cli import main
from tests.helpers import ROOT

FIGURES = ROOT / "docs" / "figures"


def _line(capsys) -> str:
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.mark.parametrize("two_phase", [False, True])
def test_a_users_folder_with_a_cases_name_is_refused_and_left_alone(tmp_path, capsys, two_phase):
    work, out = tmp_path / "work", tmp_path / "out"
    mine = work / ("column_a2_quick_tp" if two_phase else "column_a2_quick")
    mine.mkdir(parents=True)
    (mine / "thesis.tex").write_text("years of work")
    (mine / "run.json").write_text("{}")            # even one that looks like a run
    args = ["ladder", "--quick", "--only", "column_a2_quick", "--work", str(work), "--out", str(out)]
    assert main(args + (["--two-phase"] if two_phase else [])) == 2
    line = _line(capsys)
    assert f"{mine.name} exists and was not made by the ladder" in line
    assert (mine / "thesis.tex").read_text() == "years of work" and (mine / "run.json").exists()
    assert not out.exists() or not (out / "ladder.csv").exists()


def test_the_ladders_own_folder_loses_only_the_files_a_run_writes(tmp_path):
    run_dir = tmp_path / "column_a2_quick"
    ladder.claim_work_dir(run_dir)                  # new: made, marked
    assert (run_dir / ladder.WORK_MARK).is_file()
    for name in ("run.json", "diagnostics.csv", "config.yaml"):
        (run_dir / name).write_text("old run")
    (run_dir / "notes.txt").write_text("mine")
    ladder.claim_work_dir(run_dir)                  # again: its run files go, nothing else
    assert sorted(p.name for p in run_dir.iterdir()) == [ladder.WORK_MARK, "notes.txt"]
    link = tmp_path / "link"
    link.symlink_to(run_dir)                        # a link is never the ladder's
    with pytest.raises(ladder.ConfigError, match="was not made by the ladder"):
        ladder.claim_work_dir(link)
    empty = tmp_path / "empty"
    empty.mkdir()
    ladder.claim_work_dir(empty)                    # an empty folder holds nothing to lose


def _copy_tables(out):
    out.mkdir()
    for name in ("ladder.csv", "ladder_series.csv"):
        shutil.copy(FIGURES / name, out / name)


def test_plot_only_leaves_the_csv_and_a_users_column(tmp_path):
    out = tmp_path / "out"
    _copy_tables(out)
    with (out / "ladder.csv").open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    for i, r in enumerate(rows):
        r["my_note"] = f"note {i}"
    with (out / "ladder.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    before = (out / "ladder.csv").read_bytes()
    assert main(["ladder", "--plot-only", "--out", str(out), "--work", str(tmp_path / "w")]) == 0
    assert (out / "ladder.csv").read_bytes() == before
    assert (out / "ladder.png").stat().st_size > 10_000
    assert not (tmp_path / "w").exists()


def test_rewriting_the_table_keeps_a_users_column(tmp_path):
    rows = ladder.read_rows(FIGURES / "ladder.csv")[:2]
    rows[0]["my_note"] = "checked by hand"
    ladder.write_results(tmp_path, rows, [])
    again = ladder.read_rows(tmp_path / "ladder.csv")
    assert again[0]["my_note"] == "checked by hand" and again[1]["my_note"] == ""
    assert [r["case"] for r in again] == [r["case"] for r in rows]


def _garbage_tables(tmp_path):
    """ladder.csv files that are not the ladder's: only some columns; a number column with
    text in it; a K group half filled."""
    with (FIGURES / "ladder.csv").open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    fields = list(rows[0])
    cases = {"columns": "case,runout_2d\nrigid,bar\n"}
    for name, column, value in (("text", "mesh_size_2d", "abc"), ("k_half", "k_act", "")):
        broken = [dict(r) for r in rows]
        broken[3][column] = value
        path = tmp_path / f"{name}.csv"
        with path.open("w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=fields)
            w.writeheader()
            w.writerows(broken)
        cases[name] = path.read_text()
    return cases


@pytest.mark.parametrize("mode", ["--plot-only", "--two-phase"])
def test_a_csv_that_is_not_the_ladders_is_bad_input(tmp_path, capsys, mode):
    for name, text in _garbage_tables(tmp_path).items():
        out = tmp_path / f"out_{name}"
        out.mkdir()
        (out / "ladder.csv").write_text(text)
        assert main(["ladder", mode, "--out", str(out), "--work", str(tmp_path / "w")]) == 2, name
        assert f"{out / 'ladder.csv'}: not a ladder table" in _line(capsys)
        assert (out / "ladder.csv").read_text() == text     # left as it was
