"""The `microslip` command on a user's mistakes and on signals: one line naming the
problem and exit 2, never a traceback; SIGTERM and Ctrl-C keep what finished."""

import os
import signal
import subprocess
import sys
import textwrap

import h5py
import numpy as np
import pytest

from microslip.app import run as app_run
from microslip.cli import main
from microslip.results.writer import ResultsWriter

CLI = [sys.executable, "-m", "microslip.cli"]
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"

# One FRF curve of tiny steps: the sweep takes ~30 s, so a signal lands inside it.
SLOW_CASE = textwrap.dedent("""\
    title = "slow single DOF"
    [model]
    dofs = ["x"]
    mass = [1.0]
    stiffness = [1.0]
    damping = [0.02]
    [[contacts]]
    name = "wall"
    law = "A"
    kt = 3.0
    mu = 1.0
    n0 = 0.05
    u = { x = 1.0 }
    [[loads]]
    dof = "x"
    amplitude = 0.1
    harmonic = 1
    [harmonics]
    max = 7
    samples = 256
    [solver]
    step = 1e-5
    max_step = 1e-5
    max_points = 100000
    [[analysis]]
    name = "slow"
    type = "frf"
    parameter = "frequency"
    start = 0.5
    stop = 2.5
    """)


def one_line(err: str) -> str:
    assert "Traceback" not in err
    assert err.strip() and "\n" not in err.strip(), err
    return err.strip()


@pytest.fixture
def no_run(monkeypatch):
    """run_case must not start: the input is rejected before any heavy work."""
    def fail(*args, **kwargs):
        raise AssertionError("run_case started")
    monkeypatch.setattr(app_run, "run_case", fail)


def write_results(folder, *, finished=True):
    """A small results file; unfinished: flushed but never renamed, as a killed run."""
    w = ResultsWriter(folder / "results.h5", title="tiny", source="tiny.toml",
                      case_hash="0" * 64, case={})
    g = w.analysis("frf_a", {"type": "frf"})
    w.write_group(g, "curve_000", {"parameter": np.linspace(0.0, 1.0, 7),
                                   "amplitude": np.full((7, 1), 0.25)},
                  {"label": "", "status": "complete", "message": ""})
    if finished:
        return w.close("complete")
    w.file.close()
    return w.tmp


# ------------------------------------------------------------------ signals
def test_sigterm_during_run_saves_a_partial_results_file(tmp_path):
    (tmp_path / "slow.toml").write_text(SLOW_CASE)
    out = tmp_path / "o"
    p = subprocess.Popen([*CLI, "run", "slow.toml", "--out", str(out)], cwd=tmp_path,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    seen = []
    for line in p.stdout:  # the ticker's second line: the curve is well under way
        seen.append(line)
        if "point" in line and "point 1," not in line:
            break
    assert p.poll() is None, "".join(seen) + p.stderr.read()
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 143, err
    assert "terminated (SIGTERM)" in err and "Traceback" not in err
    assert not (out / "results.h5.tmp").exists()
    with h5py.File(out / "results.h5", "r") as f:
        assert f.attrs["status"] == "partial"
        assert str(f.attrs["message"]).startswith("interrupted")
        curve = f["slow"]["curve_000"]
        assert curve.attrs["status"] == "interrupted"
        assert curve["parameter"].shape[0] > 1  # what finished is kept


def test_ctrl_c_in_any_command_exits_130_without_traceback(tmp_path, monkeypatch, capsys):
    from microslip.results import writer as results

    write_results(tmp_path)

    def interrupt(path):
        raise KeyboardInterrupt
    monkeypatch.setattr(results, "summary", interrupt)
    assert main(["show", str(tmp_path)]) == 130
    assert one_line(capsys.readouterr().err) == "microslip show: interrupted"


def test_sigterm_handler_only_during_run(tmp_path, monkeypatch, capsys):
    before = signal.getsignal(signal.SIGTERM)
    during = []

    def interrupted_run(*args, **kwargs):
        during.append(signal.getsignal(signal.SIGTERM))
        raise KeyboardInterrupt
    monkeypatch.setattr(app_run, "run_case", interrupted_run)
    case = tmp_path / "c.toml"
    case.write_text(SLOW_CASE)
    assert main(["run", str(case), "--out", str(tmp_path / "o")]) == 130
    assert during[0] is not before and callable(during[0])
    assert signal.getsignal(signal.SIGTERM) is before
    assert "microslip run: interrupted; the results file keeps what finished" in \
        one_line(capsys.readouterr().err)


# ------------------------------------------------------------------ run --out
@pytest.fixture
def case(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(SLOW_CASE)
    return path


def test_run_out_naming_a_file(tmp_path, case, no_run, capsys):
    (tmp_path / "afile").write_text("x")
    assert main(["run", str(case), "--out", str(tmp_path / "afile")]) == 2
    msg = one_line(capsys.readouterr().err)
    assert msg == f"microslip run: --out {tmp_path / 'afile'}: exists and is not a folder; " \
                  "give a writable folder"


@pytest.mark.parametrize("threads", ["0", "-2", "1000"])
def test_run_threads_out_of_range(case, no_run, capsys, threads):
    assert main(["run", str(case), "--threads", threads]) == 2
    msg = one_line(capsys.readouterr().err)
    assert msg == f"microslip run: --threads {threads}: must be an integer in [1, 256]"


def test_threads_reach_every_task():
    """The BLAS threads a task computes with are the executor's (``--threads``)."""
    from microslip.app.tasks import Serial, Task

    seen = []
    task = Task(_blas_threads, (seen,))
    for threads in (1, 2):
        list(Serial(threads).run([task], None, print))
    assert seen == [1, 2]


def _blas_threads(models, seen, progress, live):
    from threadpoolctl import threadpool_info

    from microslip.app.tasks import Outcome

    seen.append(max((i["num_threads"] for i in threadpool_info()
                     if i["user_api"] == "blas"), default=0))
    return Outcome({}, {}, "complete")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes in any folder")
def test_run_out_unwritable_folder(tmp_path, case, no_run, capsys):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        assert main(["run", str(case), "--out", str(locked)]) == 2
    finally:
        locked.chmod(0o700)
    msg = one_line(capsys.readouterr().err)
    assert "cannot write in the folder (Permission denied)" in msg


def test_run_out_where_writing_fails(tmp_path, case, no_run, monkeypatch, capsys):
    """The same refusal as root can see it: the probe write fails (read-only mount)."""
    import tempfile

    def refuse(*args, **kwargs):
        raise OSError(30, "Read-only file system")
    monkeypatch.setattr(tempfile, "TemporaryFile", refuse)
    assert main(["run", str(case), "--out", str(tmp_path / "o")]) == 2
    msg = one_line(capsys.readouterr().err)
    assert msg.endswith("cannot write in the folder (Read-only file system); give a writable "
                        "folder")


def test_run_out_under_proc(case, no_run, capsys):
    assert main(["run", str(case), "--out", "/proc/microslip_out"]) == 2
    msg = one_line(capsys.readouterr().err)
    assert msg.startswith("microslip run: --out /proc/microslip_out: cannot create the folder")


def test_mesh_out_naming_a_file(tmp_path, capsys):
    case = tmp_path / "beam.toml"
    case.write_text('[geometry]\nmodel = "beam"\n')
    (tmp_path / "afile").write_text("x")
    assert main(["mesh", str(case), "--out", str(tmp_path / "afile")]) == 2
    assert "exists and is not a folder" in one_line(capsys.readouterr().err)


# ------------------------------------------------------------------ case files
@pytest.mark.parametrize("command", ["run", "check", "mesh"])
def test_binary_case_file(tmp_path, command, no_run, capsys):
    path = tmp_path / "results.h5"  # a results file given as the case: a common slip
    path.write_bytes(HDF5_SIGNATURE + bytes(64))
    assert main([command, str(path)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert "not a text file: byte 0x89 at offset 0 is not UTF-8" in err
    if command != "check":  # check lists faults its own way (one per line, under the file)
        assert one_line(err).startswith(f"microslip {command}: {path}: not a text file")


def test_latin1_case_file(tmp_path, no_run, capsys):
    path = tmp_path / "c.toml"
    path.write_bytes('title = "Düse"\n'.encode("latin-1"))
    assert main(["run", str(path)]) == 2
    assert "byte 0xfc at offset 10 is not UTF-8" in one_line(capsys.readouterr().err)


# ------------------------------------------------------------------ show
def test_show_a_file_that_is_not_hdf5(tmp_path, capsys):
    path = tmp_path / "notes.txt"
    path.write_text("hello")
    assert main(["show", str(path)]) == 2
    assert one_line(capsys.readouterr().err) == \
        f"microslip show: {path}: cannot open as HDF5 (not an HDF5 file)"


def test_show_an_hdf5_file_that_is_not_results(tmp_path, capsys):
    path = tmp_path / "other.h5"
    h5py.File(path, "w").close()
    assert main(["show", str(path)]) == 2
    assert "an HDF5 file but not a microslip results file (no root attribute title" in \
        one_line(capsys.readouterr().err)


def test_show_a_missing_folder(tmp_path, capsys):
    assert main(["show", str(tmp_path / "nowhere")]) == 2
    assert one_line(capsys.readouterr().err) == \
        f"microslip show: {tmp_path / 'nowhere'}: no such file or folder"


def test_show_only_a_leftover_tmp(tmp_path, capsys):
    write_results(tmp_path, finished=False)
    assert main(["show", str(tmp_path)]) == 1
    cap = capsys.readouterr()
    assert f"{tmp_path / 'results.h5.tmp'}: left by a run that was killed" in cap.out
    assert "frf_a: frf [partial]" in cap.out and "curve_000: 7 points" in cap.out
    assert one_line(cap.err) == (f"microslip show: no results.h5 in {tmp_path}, only the "
                                 "leftover results.h5.tmp of an unfinished run (above)")


def test_show_an_unreadable_leftover_tmp(tmp_path, capsys):
    (tmp_path / "results.h5.tmp").write_bytes(HDF5_SIGNATURE + bytes(88))  # killed early
    assert main(["show", str(tmp_path)]) == 1
    cap = capsys.readouterr()
    assert "left by a run that was killed" in cap.out and "unreadable: " in cap.out
    assert "only the leftover results.h5.tmp" in one_line(cap.err)


def test_show_final_results_and_a_leftover(tmp_path, capsys):
    write_results(tmp_path)
    write_results(tmp_path, finished=False)  # a later run, killed
    assert main(["show", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("tiny  [complete]")
    assert f"note: {tmp_path / 'results.h5.tmp'}: left by a run that was killed" in out


def test_show_into_a_closed_pipe(tmp_path):
    write_results(tmp_path)
    p = subprocess.Popen([*CLI, "show", str(tmp_path)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE)
    p.stdout.close()  # `| head` that has already quit
    err = p.communicate(timeout=60)[1].decode()
    assert p.returncode == 141
    assert err == "", err  # no traceback, no "Exception ignored"


@pytest.mark.parametrize("command", [["run"], ["run", "--dry-run"], ["mesh"]])
def test_a_geometry_gmsh_cannot_build_is_one_line(tmp_path, monkeypatch, capsys, command):
    """Parameters that give no valid solid (a shroud that misses its neighbour at too few
    sectors, say) fail in Gmsh, found only by meshing: one line naming the table, exit 2."""
    from pathlib import Path

    from microslip import geometry

    def no_solid(**parameters):
        raise geometry.GeometryBuildError("the blisk is not one solid: [(3, 1), (3, 2)]")

    monkeypatch.setitem(geometry.MODELS, "blisk_sector", no_solid)
    monkeypatch.setenv("MICROSLIP_CACHE", str(tmp_path / "cache"))  # nothing meshed before
    case = Path(__file__).parents[1] / "cases" / "11_blisk_quick.toml"
    args = [command[0], str(case), "--out", str(tmp_path / "o"), *command[1:]]
    assert main(args) == 2
    assert one_line(capsys.readouterr().err).endswith(
        "[geometry.parameters]: the blisk is not one solid: [(3, 1), (3, 2)]")
