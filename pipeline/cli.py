"""The ``microslip`` command."""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

BENCHES = {
    "core": "microslip.bench.core",
    "mesh": "microslip.bench.meshing",
    "reduction": "microslip.bench.reduction_cost",
    "teaching": "microslip.bench.teaching",
    "assembly": "microslip.bench.assembly_scale",
    "trade": "microslip.bench.trade",
    "convergence": "microslip.bench.convergence",
    "elements": "microslip.bench.element_orders",
    "cluster": "microslip.bench.cluster",
    "solvers": "microslip.bench.solvers",
}


def demo(argv: list[str]) -> int:
    """Frequency response of the single-DOF Jenkins oscillator, as a table."""
    from microslip.app.running import ticker
    from microslip.bench.demos import jenkins_oscillator
    from microslip.case.checks import samples_rule
    from microslip.solve.linear import OperatingPoint
    from microslip.solve.response import sweep

    parser = argparse.ArgumentParser(prog="microslip demo", description=demo.__doc__)
    parser.add_argument("--harmonics", type=int, default=7, help="highest harmonic H (>= 1)")
    parser.add_argument("--samples", type=int, default=256,
                        help="time samples per period: a power of 2 >= 16 (H + 1)")
    args = parser.parse_args(argv)
    faults: list[str] = []
    if args.harmonics < 1:
        faults.append(f"--harmonics = {args.harmonics}: expected an integer >= 1")
    else:  # the rule of case files (harmonics.samples): another count gives a wrong peak
        samples_rule("--samples", args.samples, args.harmonics, faults)
    if faults:
        print(f"microslip demo: {faults[0]}", file=sys.stderr)
        return 2
    seconds, fault = _demo_estimate(args.harmonics, args.samples)
    if fault:  # before any work, as a case's check and run do
        print(f"microslip demo: {fault}", file=sys.stderr)
        return 2
    if seconds > DEMO_SAY_S:
        print(f"estimated ~{seconds:.0f} s (rough: within about 2x)", file=sys.stderr)
    hb = jenkins_oscillator(args.harmonics, args.samples)
    t = time.perf_counter()
    tick = ticker(lambda m: print(m, file=sys.stderr, flush=True), "demo", 0.5, 2.5) \
        if seconds > DEMO_SAY_S else None  # a quick demo prints its table only
    r = sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(0.5), progress=tick)
    elapsed = time.perf_counter() - t
    amp = r.amplitude([0])[:, 0]
    print("Single-DOF Jenkins oscillator: m=1 kg, c=0.02 N s/m, k=1 N/m, kt=3 N/m, "
          f"mu N=0.05 N, P=0.1 N; H={args.harmonics}, {args.samples} samples")
    print(f"{'w rad/s':>10} {'max|x| m':>12} {'state':>12} {'W_fric J':>12} {'iter':>5}")
    for i in np.unique(np.linspace(0, len(r) - 1, 25).astype(int)):
        c = r.contacts(i)[0]
        print(f"{r.omega[i]:10.4f} {amp[i]:12.6f} {c.state_names[0]:>12} "
              f"{c.dissipation[0]:12.5f} {r.branch.iterations[i]:5d}")
    w, a = r.peak(0)
    print(f"peak max|x| = {a:.6f} m at w = {w:.6f} rad/s; {len(r)} points in "
          f"{elapsed * 1e3:.0f} ms ({r.branch.status})")
    return 0 if r.branch.complete else 1


#: The demo says its estimate above this [s], and refuses above DEMO_MAX_S (a case file
#: runs longer sweeps, with --dry-run, progress and results kept).
DEMO_SAY_S = 5.0
DEMO_MAX_S = 120.0


def _demo_estimate(harmonics: int, samples: int) -> tuple[float, str]:
    """(rough seconds of the demo's sweep, "" or why it is refused: more memory than is
    available, or longer than DEMO_MAX_S)."""
    from microslip.bench.demos import jenkins_case
    from microslip.case.estimate import memory_faults, task_seconds
    from microslip.case.kinds import shipped

    data = jenkins_case(harmonics, samples)
    found: list[str] = []
    memory_faults(data, found)
    seconds = task_seconds(data, shipped().spec(data["analysis"][0], 0))
    if found:
        return seconds, f"--harmonics {harmonics} --samples {samples}: " + found[0].split(
            ": ", 1)[1]
    if seconds > DEMO_MAX_S:
        return seconds, (f"--harmonics {harmonics} --samples {samples}: ~{seconds / 60:.1f} "
                         f"min estimated, the demo takes at most {DEMO_MAX_S / 60:.0f} min; "
                         "lower them, or run a case file (cases/01_sdof_wall.toml is this "
                         "oscillator: microslip run --dry-run estimates it, and a run shows "
                         "progress and keeps its results)")
    return seconds, ""


INTERRUPTED = 130  # Ctrl-C (128 + SIGINT), for every command
MAX_THREADS = 256  # --threads at most (a sanity bound: no machine here has more cores)
TERMINATED = 143  # SIGTERM during `run` (128 + SIGTERM, what a shell reports for a kill)
BROKEN_PIPE = 141  # stdout closed early, e.g. `| head` (128 + SIGPIPE, as for other tools)


def _load_case(command: str, path):
    """The validated case, or None after printing its faults (one line when one fault)."""
    from microslip.case import CaseError, load

    try:
        case = load(path)
    except CaseError as err:
        print(f"microslip {command}: {err}", file=sys.stderr)
        return None
    for note in case.renamed:  # the user has something to do: rename the table
        print(f"{path}: note: {note}")
    return case


def _output_folder(command: str, out: Path, given: bool) -> bool:
    """Whether ``out`` is a folder we can write (created if missing), checked before any
    heavy work; else prints one line saying why and returns False."""
    what = f"--out {out}" if given else f"output folder {out}"
    if out.exists() and not out.is_dir():
        problem = "exists and is not a folder"
    else:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            problem = f"cannot create the folder ({err.strerror})"
        else:
            try:  # a real write (a nameless file): permissions and read-only mounts show here
                with tempfile.TemporaryFile(dir=out):
                    return True
            except OSError as err:
                problem = f"cannot write in the folder ({err.strerror})"
    print(f"microslip {command}: {what}: {problem}; give a writable folder", file=sys.stderr)
    return False


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


def run(argv: list[str]) -> int:
    """Run a case end to end: results.h5 and PNG pictures in the output folder."""
    from microslip.app.folder import FolderBusy, NoSpace
    from microslip.app.run import run_case
    from microslip.case import InputError

    args = _run_parser().parse_args(argv)
    if not 1 <= args.threads <= MAX_THREADS:
        print(f"microslip run: --threads {args.threads}: must be an integer in "
              f"[1, {MAX_THREADS}]", file=sys.stderr)
        return 2
    c = _load_case("run", args.case)
    if c is None:
        return 2
    fault = _workers_fault(args.workers, args.scheduler)
    if fault:
        print(f"microslip run: {fault}", file=sys.stderr)
        return 2
    out = args.out or Path("out") / args.case.stem
    shared = None  # only a meshed case keeps anything in the shared cache
    if "geometry" in c.data:
        shared = _shared_cache("run")
        if shared is None:
            return 2
    if args.dry_run:
        return _dry_run(c, args, out, shared)
    if not _output_folder("run", out, args.out is not None):
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
        except InputError as err:  # found once the mesh exists: before any heavy work
            print(f"microslip run: {args.case}: {err}", file=sys.stderr)
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
                  "partial", file=sys.stderr)
            return TERMINATED if received else INTERRUPTED
    if status == "complete":
        return 0
    why = "terminated (SIGTERM); " if received else ""
    print(f"microslip run: {why}{status}: {message}", file=sys.stderr)
    if message.startswith("interrupted"):  # a curve caught the interrupt and saved itself
        return TERMINATED if received else INTERRUPTED
    return 1


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


def _shared_cache(command: str):
    """The shared cache of meshes and reduced models (``app.cache``), or None after one
    line saying why it cannot be used (a bad setting, a folder that cannot be written)."""
    from microslip.app.cache import CacheSettingError, SharedCache

    try:
        shared = SharedCache.from_environment()
    except CacheSettingError as err:
        print(f"microslip {command}: {err}", file=sys.stderr)
        return None
    fault = shared.check_writable()
    if fault:
        print(f"microslip {command}: the shared cache of meshes and reduced models: {fault}; "
              "set MICROSLIP_CACHE to a writable folder", file=sys.stderr)
        return None
    return shared


def cache(argv: list[str]) -> int:
    """The cache of meshes and reduced models every run shares: where it is, what it holds
    and its bound (MICROSLIP_CACHE, MICROSLIP_CACHE_SIZE); --clear empties it."""
    from microslip.app.folder import size_text

    parser = argparse.ArgumentParser(prog="microslip cache", description=cache.__doc__)
    parser.add_argument("--clear", action="store_true",
                        help="remove every kept mesh and reduced model (runs make them again)")
    args = parser.parse_args(argv)
    shared = _shared_cache("cache")
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


def check(argv: list[str]) -> int:
    """Validate a case file without running it."""
    from pathlib import Path

    from microslip.case import CaseError, load, notes, sizes
    from microslip.case.geometry_table import imported_contents
    from microslip.case.units import case_unit_lines

    parser = argparse.ArgumentParser(prog="microslip check", description=check.__doc__)
    parser.add_argument("case", type=Path, nargs="+", help="case file(s) (TOML)")
    args = parser.parse_args(argv)
    bad = 0
    for path in args.case:
        try:
            c = load(path)
            largest = max(sizes(c.data), key=lambda s: s.nbytes, default=None)
            size = f"; largest analysis: {largest}" if largest else ""
            names = ', '.join(str(a.get('name', a['type'])) for a in c.analyses)
            print(f"{path}: ok ({len(c.analyses)} analyses: {names}{size})" if c.analyses
                  else f"{path}: ok (no analysis: the mesh" + (
                      " and its reduction)" if "reduction" in c.data else ")"))
            units, implausible = case_unit_lines(c.data)
            contents = imported_contents(c.data)
            for line in contents:
                print(f"{path}: {line}")
            if contents and "reduction" in c.data:
                from microslip.app.plan import reduction_estimate
                from microslip.solve.memory import memory_text

                seconds, nbytes = reduction_estimate(c.geometry_table.build(),
                                                     c.reduction_table)
                print(f"{path}: reduction ~{seconds:.0f} s (two quiet cores) and "
                      f"{memory_text(nbytes)} peak memory in one process, none cached (rough: "
                      "within about 2x; `run --dry-run` says what the caches hold)")
            for note in (*c.renamed, *units, *notes(c.data)):
                print(f"{path}: note: {note}")
            for line in implausible:
                print(f"{path}: warning: {line}")
        except CaseError as err:
            print(err, file=sys.stderr)
            bad += 1
    return 2 if bad else 0


def show(argv: list[str]) -> int:
    """Summarise a results file (or the results.h5 of an output folder)."""
    from microslip.results.writer import ResultsError, leftover, summary

    parser = argparse.ArgumentParser(prog="microslip show", description=show.__doc__)
    parser.add_argument("path", type=Path, help="results.h5 or its folder")
    args = parser.parse_args(argv)
    if not args.path.exists():
        print(f"microslip show: {args.path}: no such file or folder", file=sys.stderr)
        return 2
    target = args.path / "results.h5" if args.path.is_dir() else args.path
    tmp = target.with_name(target.name + ".tmp")  # what a killed run leaves
    if not target.is_file():
        if not tmp.is_file():
            print(f"microslip show: no results file at {target}", file=sys.stderr)
            return 2
        print(leftover(tmp))
        print(f"microslip show: no {target.name} in {target.parent}, only the leftover "
              f"{tmp.name} of an unfinished run (above)", file=sys.stderr)
        return 1
    try:
        print(summary(target))
    except ResultsError as err:
        print(f"microslip show: {err}", file=sys.stderr)
        return 2
    if tmp.is_file():
        print(f"note: {leftover(tmp)}")
    return 0


def _render_options(args) -> tuple[object, list[str]]:
    """The pictures.Options of `render`'s arguments, and one line per bad one."""
    from matplotlib.colors import is_color_like

    from microslip.app.analyses.frf import MAP_TYPES
    from microslip.draw import maps, pictures
    from microslip.laws.states import STATE_NAMES

    faults: list[str] = []
    colours = dict(maps.STATE_COLOURS)
    for item in args.colour:
        state, _, colour = item.partition("=")
        if state not in STATE_NAMES:
            faults.append(f"--colour {item}: {state!r} is not a state; states: "
                          f"{list(STATE_NAMES)}")
        elif not is_color_like(colour):
            faults.append(f"--colour {item}: {colour!r} is not a colour (a name like 'gold' "
                          "or #rrggbb)")
        else:
            colours[STATE_NAMES.index(state)] = colour
    panel = maps.PANEL
    if args.size is not None:
        w, _, h = args.size.partition("x")
        if not (w.isdigit() and h.isdigit() and 100 <= int(w) <= 4000
                and 100 <= int(h) <= 4000):
            faults.append(f"--size {args.size}: expected WIDTHxHEIGHT in pixels of one map, "
                          "each 100..4000 (e.g. 800x600)")
        else:
            panel = (int(w), int(h))
    kinds = None
    if args.maps is not None:
        kinds = tuple(k for k in args.maps.split(",") if k)
        bad = [k for k in kinds if k not in MAP_TYPES]
        if bad:
            faults.append(f"--maps {args.maps}: {bad} not among {list(MAP_TYPES)}")
    return pictures.Options(colours, panel, args.at, kinds), faults


def render(argv: list[str]) -> int:
    """Redraw the pictures of a results folder from its results.h5 alone (FRFs, peak
    curves, contact-status and static-load maps, deformed shapes): other colours, another
    point, another size. Nothing is recomputed."""
    from microslip.draw import pictures
    from microslip.results.writer import ResultsError

    parser = argparse.ArgumentParser(prog="microslip render", description=render.__doc__)
    parser.add_argument("path", type=Path, help="results folder (or its results.h5)")
    parser.add_argument("--out", type=Path, default=None,
                        help="folder of the pictures (default: the results folder)")
    parser.add_argument("--at", type=float, default=None, metavar="VALUE",
                        help="draw the maps at the computed point nearest this parameter "
                        "value (rad/s for a frequency sweep) of every curve (deformed "
                        "shapes exist at the case's own map points only)")
    parser.add_argument("--size", default=None, metavar="WxH",
                        help=f"pixels of one map or shape panel (default {maps_panel()})")
    parser.add_argument("--colour", action="append", default=[], metavar="STATE=COLOUR",
                        help="colour of a contact state in the status maps, e.g. "
                        "'open=gold' or 'stick-slip=#777777' (repeatable)")
    parser.add_argument("--maps", default=None, metavar="TYPES",
                        help="which maps: status, normal_load, shape (deformed sector and "
                        "full disk), comma-separated (default: the case's)")
    parser.add_argument("--analysis", action="append", default=None, metavar="NAME",
                        help="only this analysis (repeatable)")
    args = parser.parse_args(argv)
    target = args.path / "results.h5" if args.path.is_dir() else args.path
    if not target.is_file():
        print(f"microslip render: no results file at {target}", file=sys.stderr)
        return 2
    options, faults = _render_options(args)
    try:
        faults += _analysis_faults(target, args.analysis)
    except ResultsError as err:
        print(f"microslip render: {err}", file=sys.stderr)
        return 2
    if faults:
        print("\n".join(f"microslip render: {f}" for f in faults), file=sys.stderr)
        return 2
    out = args.out or target.parent
    if not _output_folder("render", out, args.out is not None):
        return 2
    try:
        paths = pictures.render(target, out, options, args.analysis)
    except ResultsError as err:
        print(f"microslip render: {err}", file=sys.stderr)
        return 2
    for p in paths:
        print(f"wrote {p}")
    if not paths:
        print(f"microslip render: {target} has no analysis with pictures to redraw"
              + (f" among {args.analysis}" if args.analysis else ""), file=sys.stderr)
        return 1
    return 0


def _analysis_faults(target: Path, names: list[str] | None) -> list[str]:
    """A line per ``--analysis`` NAME the results file does not hold."""
    from microslip.results.writer import analysis_names

    if not names:
        return []
    held = analysis_names(target)
    return [f"--analysis {n}: {target} has no analysis of that name; its analyses: {held}"
            for n in names if n not in held]


def maps_panel() -> str:
    from microslip.draw import maps, shapes

    return (f"{maps.PANEL[0]}x{maps.PANEL[1]} per map, {shapes.PANEL[0]}x{shapes.PANEL[1]} "
            "per shape panel")


def mesh(argv: list[str]) -> int:
    """Mesh the [geometry] of a case file; write .msh, .vtu and PNG previews."""
    from microslip.app.stages import mesh_geometry, say_units

    parser = argparse.ArgumentParser(prog="microslip mesh", description=mesh.__doc__)
    parser.add_argument("case", type=Path, help="case file (TOML) with a [geometry] table")
    parser.add_argument("--out", type=Path, default=None, help="output folder (default: "
                        "out/<case name>)")
    parser.add_argument("--no-pictures", action="store_true", help="skip the PNG previews")
    args = parser.parse_args(argv)
    c = _load_case("mesh", args.case)
    if c is None:
        return 2
    if "geometry" not in c.data:
        print(f"microslip mesh: {args.case} has no [geometry] table", file=sys.stderr)
        return 2
    out = args.out or Path("out") / args.case.stem
    shared = _shared_cache("mesh")
    if shared is None or not _output_folder("mesh", out, args.out is not None):
        return 2
    try:
        mesh_geometry(c.geometry_table, out, progress=print, pictures=not args.no_pictures,
                      cache=shared)
        say_units(c.data, print)
    except (TypeError, ValueError) as err:
        print(f"microslip mesh: [geometry.parameters]: {err}", file=sys.stderr)
        return 2
    return 0


def compare(argv: list[str]) -> int:
    """Compare two results files (or folders) dataset by dataset: exit 0 when every number
    agrees to --rtol, 1 when some differ (listed)."""
    from microslip.results.compare import report, results_path
    from microslip.results.writer import ResultsError, open_results

    parser = argparse.ArgumentParser(prog="microslip compare", description=compare.__doc__)
    parser.add_argument("old", type=Path, help="results.h5 or the output folder holding it")
    parser.add_argument("new", type=Path, help="results.h5 or the output folder holding it")
    parser.add_argument("--rtol", type=float, default=1e-12,
                        help="largest difference of a dataset, relative to its largest "
                        "entry (default 1e-12)")
    args = parser.parse_args(argv)
    if not (np.isfinite(args.rtol) and args.rtol >= 0):
        print(f"microslip compare: --rtol = {args.rtol}: expected a number >= 0",
              file=sys.stderr)
        return 2
    for given in (args.old, args.new):
        if not results_path(given).is_file():
            print(f"microslip compare: no results file at {results_path(given)}",
                  file=sys.stderr)
            return 2
        try:  # a file that is not a results file is bad input, not a difference
            open_results(results_path(given)).close()
        except ResultsError as err:
            print(f"microslip compare: {err}", file=sys.stderr)
            return 2
    try:
        same, text = report(args.old, args.new, args.rtol)
    except OSError as err:
        print(f"microslip compare: cannot read a results file: {err}", file=sys.stderr)
        return 2
    print(text)
    return 0 if same else 1


def bench(argv: list[str]) -> int:
    """Benchmarks that print measured figures."""
    if not argv or argv[0] not in BENCHES:
        asked = bool(argv) and argv[0] in ("-h", "--help")
        print(f"usage: microslip bench {{{','.join(BENCHES)}}} [options]\n"
              "  (microslip bench NAME --help: the options of one)",
              file=sys.stdout if asked else sys.stderr)
        return 0 if asked else 2
    import importlib

    return importlib.import_module(BENCHES[argv[0]]).main(argv[1:])


COMMANDS = {"demo": demo, "run": run, "check": check, "show": show, "render": render,
            "compare": compare, "mesh": mesh, "cache": cache, "bench": bench}


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("microslip")
    except PackageNotFoundError:  # run from a source tree that was never installed
        return "unknown"


def main(argv: list[str] | None = None) -> int:
    """The ``microslip`` command; returns the exit code (see the README's Commands)."""
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] in ("-V", "--version"):
        print(f"microslip {_version()}")
        return 0
    if argv and argv[0] not in COMMANDS and argv[0] not in ("-h", "--help"):
        print(f"microslip: {argv[0]!r} is not a command; the commands: {', '.join(COMMANDS)} "
              "(microslip --help: what each does)", file=sys.stderr)
        return 2
    if not argv or argv[0] in ("-h", "--help"):
        asked = bool(argv)
        print("usage: microslip [--version] {demo,run,check,show,render,compare,mesh,cache,"
              "bench} ...\n\n"
              "  demo             frequency response of the single-DOF Jenkins oscillator\n"
              "  run CASE.toml    run a case: results.h5 and pictures in out/<case>\n"
              "  check CASE.toml  validate a case file without running it\n"
              "  show DIR         summarise a results file\n"
              "  render DIR       redraw a results folder's pictures from results.h5\n"
              "  compare OLD NEW  compare two results files' numbers, dataset by dataset\n"
              "  mesh CASE.toml   mesh a case's geometry: .msh, .vtu, PNG previews\n"
              "  cache            the meshes and reduced models every run shares (--clear)\n"
              "  bench core       speed and accuracy of the numerical core\n"
              "  bench mesh       meshing time and size over a mesh-size sweep\n"
              "  bench reduction  assembly, cyclic matrices and Craig-Bampton: time, memory\n"
              "  bench teaching   harmonic balance against time integration; the teaching set\n"
              "  bench assembly   blisk + damper assembly: time per point against contact grid\n"
              "  bench trade      the blisk-damper study's knobs: accuracy against time\n"
              "  bench convergence  mesh convergence of the linear limits, then the grid\n"
              "  bench elements   element shapes and orders: frequency error, DOFs, time\n"
              "  bench cluster    Dask: overhead per task, speed-up and memory of studies\n"
              "\n"
              "microslip COMMAND --help: the options of a command; --version: the version",
              file=sys.stdout if asked else sys.stderr)
        return 0 if asked else 2
    from microslip.fe.linalg import retain_freed_memory

    retain_freed_memory()  # a command is one process doing large numerical work
    try:
        code = COMMANDS[argv[0]](argv[1:])
        sys.stdout.flush()  # a closed pipe shows here, while it can still be handled
        return code
    except KeyboardInterrupt:  # `run` saves its results first; elsewhere nothing to keep
        print(f"microslip {argv[0]}: interrupted", file=sys.stderr)
        return INTERRUPTED
    except BrokenPipeError:  # stdout closed early (`| head`): no traceback, quietly stop
        _stdout_to_devnull()
        return BROKEN_PIPE


def _stdout_to_devnull() -> None:
    """Point stdout at /dev/null so the interpreter's final flush cannot fail again."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # a replaced stdout (tests): nothing to do
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, fd)
    os.close(devnull)


if __name__ == "__main__":
    raise SystemExit(main())
