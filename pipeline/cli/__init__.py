"""The ``microslip`` command: ``main`` reads the command name and hands the rest to it.

run_command       ``run`` (dry run, workers, SIGTERM) and ``cache``
case_commands     ``check``, ``mesh`` and the ``demo``: a case file before a run
results_commands  ``show``, ``render``, ``report``, ``compare``: a results folder
shared            exit codes, a case loaded or refused in one line, the output folder
"""

from __future__ import annotations

import os
import sys

from microslip.cli.case_commands import check, demo, mesh
from microslip.cli.results_commands import compare, render, report, show
from microslip.cli.run_command import cache, run
from microslip.cli.shared import BROKEN_PIPE, INTERRUPTED

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
            "report": report, "compare": compare, "mesh": mesh, "cache": cache, "bench": bench}


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
        print("usage: microslip [--version] {demo,run,check,show,render,report,compare,mesh,"
              "cache,bench} ...\n\n"
              "  demo             frequency response of the single-DOF Jenkins oscillator\n"
              "  run CASE.toml    run a case: results.h5 and pictures in out/<case>\n"
              "  check CASE.toml  validate a case file without running it\n"
              "  show DIR         summarise a results file\n"
              "  render DIR       redraw a results folder's pictures from results.h5\n"
              "  report DIR       write a results folder's page, report.html (--index: a "
              "course)\n"
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
              "  bench solvers    every case by dense LUs and the structured Jacobian, compared\n"
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

