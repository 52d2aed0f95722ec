"""``microslip run`` (with ``--dry-run``, the workers, SIGTERM as Ctrl-C) and
``microslip cache``."""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import time
from collections.abc import Iterator
from pathlib import Path

from microslip.cli.shared import (
    INTERRUPTED,
    MAX_THREADS,
    TERMINATED,
    load_case,
    output_folder,
    shared_cache,
)


def run(argv: list[str]) -> int:
    """Run a case end to end: results.h5 and PNG pictures in the output folder."""
    from microslip.app.folder import FolderBusy, NoSpace
    from microslip.app.run import run_case
    from microslip.case import InputError
    from microslip.geometry import GeometryBuildError

    args = _run_parser().parse_args(argv)
    if not 1 <= args.threads <= MAX_THREADS:
        print(f"microslip run: --threads {args.threads}: must be an integer in "
              f"[1, {MAX_THREADS}]", file=sys.stderr)
        return 2
    c = load_case("run", args.case)
    if c is None:
        return 2
    fault = _workers_fault(args.workers, args.scheduler)
    if fault:
        print(f"microslip run: {fault}", file=sys.stderr)
        return 2
    out = args.out or Path("out") / args.case.stem
    shared = None  # only a meshed case keeps anything in the shared cache
    if "geometry" in c.data:
        shared = shared_cache("run")
        if shared is None:
            return 2
    if args.dry_run:
        try:
            return _dry_run(c, args, out, shared)
        except (InputError, GeometryBuildError) as err:  # found meshing: nothing computed
            print(f"microslip run: {args.case}: {_input_fault(err)}", file=sys.stderr)
            return 2
    if not output_folder("run", out, args.out is not None):
        return 2
    executor, fault = _executor(args.workers, args.scheduler)
    if fault:  # an unreachable scheduler, workers without microslip
        print(f"microslip run: {fault}", file=sys.stderr)
        return 2
    executor.threads = args.threads
    t = time.perf_counter()
    with _sigterm_as_interrupt() as received, contextlib.closing(executor):
        try:
            path = run_case(c, out, progress=lambda msg: print(msg, flush=True),
                            cache=not args.no_cache, executor=executor, shared=shared)
            status, message = _report_run(path, out, t)
            if not args.no_report and not _write_page(path, status, received):
                return TERMINATED if received else INTERRUPTED
        except (InputError, GeometryBuildError) as err:  # found meshing: before heavy work
            print(f"microslip run: {args.case}: {_input_fault(err)}", file=sys.stderr)
            return 2
        except FolderBusy as err:  # before any work: nothing of the other run is touched
            print(f"microslip run: {err}", file=sys.stderr)
            return 2
        except NoSpace as err:  # what finished is kept (partial)
            print(f"microslip run: {err}", file=sys.stderr)
            return 2 if err.before_work else 1
        except KeyboardInterrupt:  # Terminated too
            why = "terminated (SIGTERM)" if received else "interrupted"
            print(f"microslip run: {why}; the results file keeps what finished, marked "
                  f"partial (`microslip report {out}` writes its page)", file=sys.stderr)
            return TERMINATED if received else INTERRUPTED
    if status == "complete":
        return 0
    why = "terminated (SIGTERM); " if received else ""
    print(f"microslip run: {why}{status}: {message}", file=sys.stderr)
    if message.startswith("interrupted"):  # a curve caught the interrupt and saved itself
        return TERMINATED if received else INTERRUPTED
    return 1


def _input_fault(err: Exception) -> str:
    """The line of a fault found only by meshing: the case's own words, or the parameters
    of a model that Gmsh could not build (its parts overlap or do not join)."""
    from microslip.geometry import GeometryBuildError

    return f"[geometry.parameters]: {err}" if isinstance(err, GeometryBuildError) else str(err)


def _write_page(results: Path, status: str, terminated: list | None = None) -> bool:
    """The results folder's page (report.html); a page that cannot be written is said in
    one line, the run's results stand. False: the user interrupted it (no page is left
    half written: it is written whole or not at all)."""
    from microslip.report import write_report

    later = f"`microslip report {results.parent}` writes it later"
    try:
        print(f"wrote {write_report(results, drawn=True)}", flush=True)
    except OSError as err:
        print(f"microslip run: the page report.html was not written ({err}); the results "
              f"are {status} as said: {later}", file=sys.stderr)
    except KeyboardInterrupt:
        why = "terminated (SIGTERM)" if terminated else "interrupted"
        print(f"microslip run: {why} while writing the page report.html; the results "
              f"are {status} as said: {later}", file=sys.stderr)
        return False
    return True


def _run_parser() -> argparse.ArgumentParser:
    """The arguments of ``microslip run``."""
    from microslip.app.tasks import BLAS_THREADS

    parser = argparse.ArgumentParser(prog="microslip run", description=run.__doc__)
    parser.add_argument("case", type=Path, help="case file (TOML)")
    parser.add_argument("--out", type=Path, default=None,
                        help="output folder (default: out/<case name>)")
    parser.add_argument("--no-cache", action="store_true",
                        help="compute every curve afresh (by default a curve whose inputs "
                        "did not change since a run into the same folder is reused)")
    parser.add_argument("--no-report", action="store_true",
                        help="do not write the folder's page, report.html (microslip report "
                        "writes it later)")
    parser.add_argument("--dry-run", action="store_true",
                        help="list the stages the run would compute and those it would read "
                        "from the caches, with rough time and memory; compute nothing")
    parser.add_argument("--workers", type=int, default=None,
                        help="independent curves (family members, swept peaks, uncertainty "
                        "samples) on a local Dask cluster of this many worker processes, "
                        "started when an analysis has two or more to compute (default: the "
                        "machine's cores, and only for analyses estimated to take over "
                        "10 s in one process); 0: in this process, one after another")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="run the independent curves on the Dask cluster whose scheduler "
                        "is at ADDRESS (e.g. tcp://host:8786; its workers need microslip "
                        "installed as here)")
    parser.add_argument("--threads", type=int, default=BLAS_THREADS, metavar="N",
                        help="BLAS (and contact-kernel) threads of every stage, in this "
                        f"process and on each worker (default {BLAS_THREADS}: fastest here "
                        "and the same numbers everywhere; more threads help a single large "
                        "factorization on an idle machine)")
    return parser


def _dry_run(c, args: argparse.Namespace, out: Path, shared) -> int:
    """``run --dry-run``: the stages, cached or not, with rough time and memory."""
    from microslip.app import plan

    factor = plan.machine_factor()
    stages = plan.scaled(plan.plan(c, out, cache=not args.no_cache, shared=shared), factor)
    print(f"{args.case} into {out} (dry run: nothing computed)")
    print(plan.text(stages, factor))
    return 0


class Terminated(KeyboardInterrupt):
    """SIGTERM during `microslip run`: raised like Ctrl-C so the run saves what finished."""


@contextlib.contextmanager
def _sigterm_as_interrupt() -> Iterator[list[int]]:
    """For the duration, SIGTERM raises Terminated (once: a repeat while the results are
    being saved is ignored; SIGKILL still kills). Yields a list that gets the signal number.
    The previous handler is restored afterwards."""
    received: list[int] = []

    def handler(signum, frame):
        if not received:
            received.append(signum)
            raise Terminated

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread (main() called from a thread): leave SIGTERM
        yield received
        return
    try:
        yield received
    finally:
        signal.signal(signal.SIGTERM, previous)


def _report_run(path: Path, out: Path, start: float) -> tuple[str, str]:
    """Print the summary of a finished run; its (status, message)."""
    import h5py

    from microslip.results.writer import summary

    print(summary(path))
    print(f"wrote {out} in {time.perf_counter() - start:.1f} s")
    with h5py.File(path, "r") as f:
        return str(f.attrs["status"]), str(f.attrs["message"])


def _workers_fault(workers: int | None, scheduler: str | None) -> str:
    """"" when --workers and --scheduler are allowed (checked before the case runs), else
    one line saying why."""
    from microslip.app.tasks import workers_fault

    if workers is not None and scheduler is not None:
        return (f"--workers {workers} with --scheduler {scheduler}: give one (the workers of "
                "a scheduler are its own)")
    if scheduler is not None and not scheduler.strip():
        return "--scheduler '': expected an address such as tcp://host:8786"
    return workers_fault(workers) if workers is not None else ""


def _executor(workers: int | None, scheduler: str | None):
    """(where the independent curves run, "") or (None, why not): in this process (0
    workers), a local cluster started on first need (by default one worker per core, for
    analyses whose curves are worth it: tasks.WORTH_S), or the cluster at ``scheduler``,
    connected now."""
    from microslip.app.tasks import (
        WORTH_S,
        Distributed,
        Serial,
        connect,
        machine_cores,
    )

    if scheduler is not None:
        client, fault = connect(scheduler)
        return Distributed(address=scheduler, client=client), fault
    if workers is None:
        return Distributed(workers=machine_cores(), worth_s=WORTH_S), ""
    return (Serial() if workers == 0 else Distributed(workers=workers)), ""


def cache(argv: list[str]) -> int:
    """The cache of meshes and reduced models every run shares: where it is, what it holds
    and its bound (MICROSLIP_CACHE, MICROSLIP_CACHE_SIZE); --clear empties it."""
    from microslip.app.folder import size_text

    parser = argparse.ArgumentParser(prog="microslip cache", description=cache.__doc__)
    parser.add_argument("--clear", action="store_true",
                        help="remove every kept mesh and reduced model (runs make them again)")
    args = parser.parse_args(argv)
    shared = shared_cache("cache")
    if shared is None:
        return 2
    if args.clear:
        files, nbytes = shared.clear()
        print(f"removed {files} files ({size_text(nbytes)}) from {shared.root}")
        return 0
    usage = shared.usage()
    total = sum(b for _, b in usage.values())
    print(f"{shared.root}: {size_text(total)} of at most {size_text(shared.limit)} "
          "(MICROSLIP_CACHE_SIZE; the least recently used go first)")
    for kind, (files, nbytes) in usage.items():
        print(f"  {kind}: {files} files, {size_text(nbytes)}")
    return 0
