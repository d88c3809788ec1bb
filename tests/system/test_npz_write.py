"""A checkpoint write that fails on a full disk raises one OSError and leaves nothing
behind: no temporary file, and no ``ZipFile.__del__`` traceback printed later (issue 30:
the run's exit-5 line used to be followed by a 9-line traceback)."""

from __future__ import annotations

import gc

import numpy as np
import pytest

from dpcollapse.io.checkpoint import write_npz_atomic
from tests.system.test_faults import small_disk  # noqa: F401  (a fixture: 100 kB tmpfs)


@pytest.mark.filterwarnings("error::pytest.PytestUnraisableExceptionWarning")
def test_a_failed_checkpoint_write_prints_nothing_later(small_disk, capfd):  # noqa: F811
    path = small_disk / "checkpoint.npz"
    write_npz_atomic(path, {"a": np.arange(3.0)})
    with pytest.raises(OSError) as info:
        write_npz_atomic(path, {"a": np.arange(3.0), "b": np.zeros(50_000)})
    assert "No space left on device" in str(info.value)
    gc.collect()
    err = capfd.readouterr().err
    assert "Exception ignored" not in err and "Traceback" not in err, err
    assert not [p for p in small_disk.iterdir() if "tmp" in p.name]
    with np.load(path) as data:                  # the previous checkpoint is intact
        assert list(data["a"]) == [0.0, 1.0, 2.0]
