"""Run a case end to end: every analysis, ``results.h5`` and the pictures.

Progress goes to a callable (the CLI prints it). The structural stages come first
(``stages``: the mesh, the reduced models), then each analysis by its kind's runner
(``analyses``), sharing one :class:`running.Run`. Ctrl-C stops the run after saving the
branch computed so far; the results file is then marked partial.
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path

import h5py
from threadpoolctl import ThreadpoolController

from microslip.case import Case
from microslip.fe.linalg import load_backends
from microslip.laws import warm_up
from microslip.results.writer import ResultsWriter, is_disk_full

from .cache import SharedCache
from .folder import FolderLock, NoSpace, free_bytes, size_text
from .models import AssemblyModels, LumpedModels
from .running import Progress, Run, StageFailed
from .stages import draw_previews, mesh_geometry, say_units, write_mesh, write_structure
from .store import CurveStore
from .tasks import Distributed, Serial


def run_case(case: Case, out_dir: str | Path, progress: Progress = print,
             cache: bool = True, executor: Serial | Distributed | None = None,
             shared: SharedCache | None = None) -> Path:
    """Compute every analysis of ``case`` into ``out_dir``; returns results.h5.

    cache: reuse the curves kept in ``out_dir/cache`` whose inputs are unchanged (and keep
    the new ones); False computes everything afresh (and keeps nothing). executor: where
    the independent curves run (``tasks``; default: in this process, one after another);
    the caller closes it. shared: where meshes and reduced models are kept for every run
    (``cache``; default: the environment's, ``SharedCache.from_environment``)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    free = free_bytes(out)
    with FolderLock(out) as lock:  # FolderBusy: another run writes there
        try:
            if shared is None and "geometry" in case.data:
                shared = SharedCache.from_environment()
            return _run_case(case, out, progress, cache, executor, lock, shared)
        except OSError as err:
            if not is_disk_full(err):
                raise
            raise NoSpace(disk_full_text(out, free)) from None


def disk_full_text(out: Path, free: int) -> str:
    """The one line of a run whose disk filled: where, what was free, what was kept."""
    path = out / "results.h5"
    kept = ""
    if (out / "results.h5.tmp").is_file():  # the file could not be closed
        kept = "; what finished is in results.h5.tmp, which could not be closed (show reads it)"
    elif path.is_file():
        with h5py.File(path, "r") as f:
            curves = sum(1 for g in f.values() if isinstance(g, h5py.Group)
                         for c in g.values() if isinstance(c, h5py.Group)
                         and c.attrs.get("status") in ("complete", "stopped"))
        kept = f"; {path} keeps the {curves} curves that finished (partial)"
    return (f"{out}: no space left on its device; {size_text(free)} were free when the run "
            f"started and it needs more: free space there, or give --out on another "
            f"disk{kept}")


@contextlib.contextmanager
def run_threads(threads: int):
    """The block's BLAS threads (NumPy's, SciPy's, and PARDISO's MKL, loaded first so that
    the limit holds for it) and contact-kernel threads at most ``threads``."""
    load_backends()
    with ThreadpoolController().limit(limits=threads, user_api="blas"), \
            numba_threads(threads):
        yield


@contextlib.contextmanager
def numba_threads(threads: int):
    """The contact kernels' numba threads at most ``threads`` for the block (numba's own
    default is every core)."""
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    try:
        yield
    finally:
        numba.set_num_threads(before)


def _run_case(case: Case, out: Path, progress: Progress, cache: bool,
              executor: Serial | Distributed | None, lock: FolderLock,
              shared: SharedCache | None) -> Path:
    """run_case in the folder it holds."""
    store = CurveStore(out / "cache" / "curves" if cache else None)
    executor = executor or Serial()
    # every stage, the reduction's factorizations included, with the run's BLAS threads
    # (``--threads``): the same numbers here as on any worker
    with run_threads(executor.threads), \
            ResultsWriter(out / "results.h5", title=case.title, source=case.source,
                          case_hash=case.content_hash, case=case.data,
                          on_disk_full=lock.release_reserve) as writer:
        try:
            models, structure = _structural_stages(case, writer, out, progress, shared)
        except StageFailed as err:  # numerical: said, kept in the file, exit 1
            progress(f"[reduction] failed: {err}")
            return writer.close("failed", str(err))
        run = Run(writer, out, progress, models, store, executor, structure)
        stopped, unfinished = _analyses(case, run)
        if stopped:
            return writer.close("partial", stopped)
        if unfinished:  # a stopped or failed curve is not a complete run
            failed = [u for u in unfinished if u[1] == "failed"]
            status = "failed" if len(failed) == len(case.analyses) else "partial"
            return writer.close(status, "; ".join(f"analysis {n} {s}: {m}".rstrip(": ")
                                             for n, s, m in unfinished))
    return out / "results.h5"


def _structural_stages(case: Case, writer: ResultsWriter, out: Path, progress: Progress,
                       shared: SharedCache | None):
    """(models, structure) of a case: the mesh of its [geometry] (written, its previews
    drawn) and the reduced models of its [reduction] (StageFailed: a numerical failure);
    a lumped case's models otherwise."""
    models: LumpedModels | AssemblyModels = LumpedModels()
    if "geometry" not in case.data:
        return models, None
    t = time.perf_counter()
    m = mesh_geometry(case.geometry_table, out, progress, pictures=False, cache=shared)
    say_units(case.data, progress)
    write_mesh(writer, m, time.perf_counter() - t)
    draw_previews(writer.file, m.content_hash, out, progress)
    if "reduction" not in case.data:
        return models, None
    result = write_structure(writer, m, case, out, progress, shared)
    if "assembly" in case.data:
        models = AssemblyModels(m, result)
    return models, (m, result)


def _analyses(case: Case, run: Run) -> tuple[str, list[tuple[str, str, str]]]:
    """Every analysis by its kind's runner, its status and time kept in its group; (why
    the run stopped, or "", and (name, status, why) of each analysis not complete)."""
    kinds, progress = case.known_kinds, run.progress
    unfinished: list[tuple[str, str, str]] = []
    for spec in case.analysis_specs:
        name, kind = spec.name, kinds.of(spec)
        t = time.perf_counter()
        group: h5py.Group = run.writer.analysis(name, spec.record())
        progress(f"[{name}] {spec.type} ...")
        if kind.kernels and (case.contacts_enabled() or "assembly" in case.data):
            warm_up(progress)  # says so when a first run compiles the contact kernels
        status, message = kind.run(case, spec, group, run)
        group.attrs["status"] = status
        group.attrs["message"] = message
        group.attrs["elapsed_s"] = time.perf_counter() - t
        run.writer.flush()
        progress(f"[{name}] {status} in {time.perf_counter() - t:.2f} s {message}".rstrip())
        if status == "interrupted":
            return f"interrupted by the user in analysis {name}", unfinished
        if status != "complete":
            unfinished.append((name, status, message))
    return "", unfinished
