"""``python -m studies wellposed --quick`` (two slopes × two meshes, < 60 s alone): the classes the
measurement tells apart at that size, the CSV and PNG, and bad input → exit 2 in one line."""

import csv
import subprocess

import pytest

from tests.helpers import ROOT, studies_cmd


@pytest.fixture(scope="module")
def quick_map(tmp_path_factory):
    out = tmp_path_factory.mktemp("wellposed")
    proc = subprocess.run(studies_cmd() + ["wellposed", "--quick", "--out", str(out)],
                          capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    with (out / "stability_mui.csv").open() as f:
        rows = list(csv.DictReader(f))
    return out, rows


def _rates(rows, case):
    picked = sorted((r for r in rows if r["case"] == case), key=lambda r: int(r["cells"]))
    return picked, [float(r["growth_rate"]) for r in picked]


def test_quick_classes(quick_map):
    """θ = 22° (I = 0.17, inside the window): the noise decays on both meshes, faster on the
    finer one: well posed. θ = 17.9° (I = 0.0043 < I_min = 0.0136): it decays on 5 cells
    across, where the unstable short waves do not fit, and grows on 10: ill posed."""
    out, rows = quick_map
    inside, r_in = _rates(rows, "inside")
    below, r_below = _rates(rows, "below")
    assert [r["inside_window"] for r in inside] == ["1", "1"]
    assert [r["inside_window"] for r in below] == ["0", "0"]
    assert all(r["class"] == "well_posed" for r in inside), r_in
    assert r_in[1] < r_in[0] < 0
    assert all(r["class"] == "ill_posed" for r in below), r_below
    assert r_below[1] > 0 and r_below[1] > r_below[0]
    assert (out / "stability_mui.png").stat().st_size > 10_000


@pytest.mark.parametrize("args, key", [(["--cells", "5,x"], "--cells"),
                                       (["--cells", "1"], "--cells"),
                                       (["--steps", "3"], "--steps"),
                                       (["--diffusion-number", "-1"], "--diffusion-number"),
                                       (["--config", "configs/rigid.yaml"], "material.rheology")])
def test_bad_input_exit_2(args, key, tmp_path):
    proc = subprocess.run(studies_cmd() + ["wellposed", "--quick", "--out", str(tmp_path),
                                              *args],
                          capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert key in proc.stderr and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
