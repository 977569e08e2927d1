"""The loader fuzz (issue 26): seeded mutations of valid scene files, trajectories, MJCF files and
meshes, each loaded in a forked child under a memory cap, end only in the loader's documented
error, never in a crash, a timeout or the cap. ``python -m signorini.fuzz_files N SEED`` runs more."""
import os
import signal
import sys
import time

import numpy as np
import pytest

from signorini import fuzz_files

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="fork, RLIMIT_AS and /proc are Linux's")
pytest.importorskip("trimesh")


@pytest.mark.slow
def test_mutated_files_end_only_in_their_loaders_documented_errors():
    # 240 files, 40 of each kind (about 15 s on one core)
    summary = fuzz_files.run(240, seed=26)
    assert summary.failures == [], summary.line()
    assert all(summary.tried[k] == 40 for k in fuzz_files.KINDS), summary.tried
    # each loader was driven to its error, and some mutated files still load
    assert summary.errors["SceneFileError"] > 10 and summary.errors["MJCFError"] > 10, summary.line()
    assert summary.errors["ValueError"] > 60 and summary.loaded > 0, summary.line()
    assert set(summary.errors) <= {"SceneFileError", "MJCFError", "ValueError"}
    assert 0 < summary.peak_kb < fuzz_files.CAP_MB * 1024


def test_mutations_depend_only_on_seed_and_index():
    sample = fuzz_files._MJCF.encode()
    assert fuzz_files.mutate_file(sample, "mjcf", 3, 17) == fuzz_files.mutate_file(sample, "mjcf", 3, 17)
    assert fuzz_files.mutate_file(sample, "mjcf", 3, 17) != fuzz_files.mutate_file(sample, "mjcf", 3, 18)


def _crash(kind, path):
    os.kill(os.getpid(), signal.SIGSEGV)


def _hang(kind, path):
    time.sleep(60)


def _hog(kind, path):
    np.ones(2**31)  # 16 GiB: over the cap


def _stray(kind, path):
    raise RecursionError("maximum recursion depth exceeded")


@pytest.mark.parametrize("load, outcome, kind", [(_crash, "crash", None), (_hang, "timeout", None),
                                                 (_hog, "error", "MemoryError"), (_stray, "error", "RecursionError")])
def test_the_child_reports_what_would_be_a_failure(monkeypatch, tmp_path, load, outcome, kind):
    # the harness can fail: a crash, a hang, memory past the cap and a stray error are all seen
    monkeypatch.setattr(fuzz_files, "_load", load)
    result = fuzz_files.load_in_child("scene", tmp_path / "x.toml", cap_mb=256, timeout=2)
    assert result["outcome"] == outcome
    if kind is not None:
        assert result["type"] == kind
    if kind == "MemoryError":
        assert result["memory"]


def test_the_command_line_prints_its_figures(capsys):
    assert fuzz_files.main(["12", "5"]) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert line.startswith("files tried 12 (scene 2, trajectory 2, mjcf 2, obj 2, stl 2, npz_mesh 2)")
    assert "crashes 0" in line and "peak memory of a child" in line
