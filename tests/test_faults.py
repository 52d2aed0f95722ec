"""Faults a run meets outside its numbers: a disk that fills, a second run into the same
folder. Each is one line, keeps what finished and leaves no stray file."""

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import h5py
import pytest

from microslip.app.folder import LOCK_NAME, FolderBusy, FolderLock
from microslip.cli import main

CASES = Path(__file__).parents[1] / "cases"


def _can_mount_tmpfs(tmp_path: Path) -> bool:
    """Whether this machine lets a user namespace mount a tmpfs (the full disk's stand-in)."""
    if shutil.which("unshare") is None:
        return False
    (tmp_path / "probe").mkdir()
    done = subprocess.run(["unshare", "--user", "--map-root-user", "--mount", "sh", "-c",
                           f"mount -t tmpfs -o size=64k none {tmp_path / 'probe'}"],
                          capture_output=True)
    return done.returncode == 0


def _run_on_tmpfs(tmp_path: Path, size: str) -> tuple[subprocess.CompletedProcess, str]:
    """``microslip run cases/01_sdof_wall.toml`` into a tmpfs of ``size`` (mounted in a user
    namespace: a real ENOSPC from the kernel), then ``show`` and a listing of every file
    left there, taken before the namespace (and its tmpfs) goes."""
    disk = tmp_path / "disk"
    disk.mkdir()
    out = disk / "o"
    script = (f"mount -t tmpfs -o size={size} none {disk} && "
              f"{sys.executable} -m microslip.cli run {CASES / '01_sdof_wall.toml'} "
              f"--out {out} --workers 0; echo \"exit=$?\" >&2; "
              f"{sys.executable} -m microslip.cli show {out} >&2; "
              f"find {disk} -type f >&2")
    env = {**os.environ, "MICROSLIP_RETAIN_MEMORY": "0"}
    done = subprocess.run(["unshare", "--user", "--map-root-user", "--mount", "sh", "-c",
                           script], capture_output=True, text=True, env=env, timeout=600)
    return done, str(out)


@pytest.mark.parametrize("size", [pytest.param("300k", marks=pytest.mark.slow), "700k"])
def test_a_disk_that_fills_keeps_what_finished_in_one_line(tmp_path, size):
    """The main job on a small disk (it writes ~1.1 MB): the run stops where the disk
    filled, says so in one line naming the folder and the space it had, exit 1; results.h5
    is a valid partial file with the curves that finished; no temporary file, no lock.
    (At 300 kB HDF5 itself met the full disk in a flush: its state corrupt, closing the file
    crashed the process; a write now stops before HDF5 would meet it.)"""
    if not _can_mount_tmpfs(tmp_path):
        pytest.skip("no user namespace with tmpfs mounts here")
    done, out = _run_on_tmpfs(tmp_path, size)
    err = done.stderr
    lines = err.splitlines()
    assert "exit=1" in lines, err
    said = [x for x in lines if x.startswith("microslip run:")]
    assert len(said) == 1 and "Traceback" not in err, err
    assert f"{out}: no space left on its device;" in said[0] and "were free when the run " \
        "started" in said[0] and "keeps the" in said[0], said
    assert "[partial]  no space left on the device" in err  # show reads the file
    if size == "700k":  # something finished and was kept
        assert " curve_000 " in err and "[complete]" in err
    files = [x for x in lines if x.startswith(str(tmp_path / "disk"))]
    assert f"{out}/results.h5" in files
    stray = [f for f in files if f.endswith((".tmp", ".part", ".tmp.png", LOCK_NAME))]
    assert not stray, files


def test_a_disk_with_no_room_is_refused_before_any_work(tmp_path):
    if not _can_mount_tmpfs(tmp_path):
        pytest.skip("no user namespace with tmpfs mounts here")
    done, out = _run_on_tmpfs(tmp_path, "64k")
    lines = done.stderr.splitlines()
    assert "exit=2" in lines, done.stderr
    said = [x for x in lines if x.startswith("microslip run:")]
    assert len(said) == 1 and f"{out}: no space left on its device" in said[0], lines


def test_a_second_run_into_a_folder_in_use_is_refused(tmp_path, capsys):
    """A run holds its folder: a second run into it is one line naming the first's process,
    exit 2, and touches nothing; once the first has finished the folder is free again."""
    out = tmp_path / "o"
    out.mkdir()
    with FolderLock(out):
        assert main(["run", str(CASES / "01_sdof_wall.toml"), "--out", str(out),
                     "--workers", "0"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "Traceback" not in err
        assert (f"microslip run: {out}: in use by another run (process {os.getpid()} on"
                in err), err
        assert sorted(p.name for p in out.iterdir()) == [LOCK_NAME]
    assert not (out / LOCK_NAME).exists()
    with FolderLock(out), pytest.raises(FolderBusy):
        FolderLock(out).__enter__()


@pytest.mark.slow  # (two processes, 6 s: the lock itself is held in process by the test above)
def test_two_runs_at_once_one_is_refused_and_the_other_complete(tmp_path):
    """Two `microslip run` processes into one folder: the one that comes second is refused
    (exit 2, one line); the first completes and its results file reads."""
    out = tmp_path / "o"
    command = [sys.executable, "-m", "microslip.cli", "run",
               str(CASES / "01_sdof_wall.toml"), "--out", str(out), "--workers", "0"]
    env = {**os.environ, "MICROSLIP_RETAIN_MEMORY": "0"}
    first = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                             text=True, env=env)
    deadline = time.monotonic() + 120
    while not (out / LOCK_NAME).exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    second = subprocess.run(command, capture_output=True, text=True, env=env, timeout=300)
    assert first.wait(timeout=600) == 0, first.stderr.read()
    assert second.returncode == 2, second.stderr
    assert second.stderr.count("\n") == 1 and "in use by another run (process " \
        f"{first.pid} on" in second.stderr, second.stderr
    with h5py.File(out / "results.h5", "r") as f:
        assert f.attrs["status"] == "complete"
    assert main(["show", str(out)]) == 0
