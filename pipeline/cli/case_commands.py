"""Commands on a case file before a run: ``check``, ``mesh``, and the ``demo``."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from microslip.cli.shared import load_case, output_folder, shared_cache


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


def mesh(argv: list[str]) -> int:
    """Mesh the [geometry] of a case file; write .msh, .vtu and PNG previews."""
    from microslip.app.stages import mesh_geometry, say_units
    from microslip.geometry import GeometryBuildError

    parser = argparse.ArgumentParser(prog="microslip mesh", description=mesh.__doc__)
    parser.add_argument("case", type=Path, help="case file (TOML) with a [geometry] table")
    parser.add_argument("--out", type=Path, default=None, help="output folder (default: "
                        "out/<case name>)")
    parser.add_argument("--no-pictures", action="store_true", help="skip the PNG previews")
    args = parser.parse_args(argv)
    c = load_case("mesh", args.case)
    if c is None:
        return 2
    if "geometry" not in c.data:
        print(f"microslip mesh: {args.case} has no [geometry] table", file=sys.stderr)
        return 2
    out = args.out or Path("out") / args.case.stem
    shared = shared_cache("mesh")
    if shared is None or not output_folder("mesh", out, args.out is not None):
        return 2
    try:
        mesh_geometry(c.geometry_table, out, progress=print, pictures=not args.no_pictures,
                      cache=shared)
        say_units(c.data, print)
    except (TypeError, ValueError, GeometryBuildError) as err:  # values Gmsh cannot build
        print(f"microslip mesh: [geometry.parameters]: {err}", file=sys.stderr)
        return 2
    return 0


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
