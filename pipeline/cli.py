"""The ``microslip`` command."""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

BENCHES = {
    "core": "microslip.pipeline.bench.core",
    "mesh": "microslip.pipeline.bench.meshing",
    "reduction": "microslip.pipeline.bench.reduction",
    "teaching": "microslip.pipeline.bench.teaching",
    "coupled": "microslip.pipeline.bench.coupled",
}


def demo(argv: list[str]) -> int:
    """Frequency response of the single-DOF Jenkins oscillator, as a table."""
    from microslip.pipeline.bench.demos import jenkins_oscillator
    from microslip.pipeline.solve.hbm import OperatingPoint
    from microslip.pipeline.solve.response import sweep

    parser = argparse.ArgumentParser(prog="microslip demo", description=demo.__doc__)
    parser.add_argument("--harmonics", type=int, default=7, help="highest harmonic H (>= 1)")
    parser.add_argument("--samples", type=int, default=256, help="time samples per period")
    args = parser.parse_args(argv)
    hb = jenkins_oscillator(args.harmonics, args.samples)
    t = time.perf_counter()
    r = sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(0.5))
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


def _load_case(command: str, path):
    """The validated case, or None after printing its faults."""
    from microslip.pipeline.app import case as cs

    try:
        return cs.load(path)
    except cs.CaseError as err:
        print(f"microslip {command}: {err}", file=sys.stderr)
        return None


def run(argv: list[str]) -> int:
    """Run a case end to end: results.h5 and PNG pictures in the output folder."""
    from pathlib import Path

    from microslip.pipeline.app.run import run_case

    parser = argparse.ArgumentParser(prog="microslip run", description=run.__doc__)
    parser.add_argument("case", type=Path, help="case file (TOML)")
    parser.add_argument("--out", type=Path, default=None,
                        help="output folder (default: out/<case name>)")
    args = parser.parse_args(argv)
    c = _load_case("run", args.case)
    if c is None:
        return 2
    out = args.out or Path("out") / args.case.stem
    t = time.perf_counter()
    try:
        path = run_case(c, out, progress=lambda msg: print(msg, flush=True))
    except KeyboardInterrupt:
        print("microslip run: interrupted; the results file keeps what finished, marked "
              "partial", file=sys.stderr)
        return 130
    import h5py

    from microslip.pipeline.app.results import summary

    print(summary(path))
    print(f"wrote {out} in {time.perf_counter() - t:.1f} s")
    with h5py.File(path, "r") as f:
        status, message = str(f.attrs["status"]), str(f.attrs["message"])
    if status == "complete":
        return 0
    print(f"microslip run: {status}: {message}", file=sys.stderr)
    return 130 if message.startswith("interrupted") else 1


def check(argv: list[str]) -> int:
    """Validate a case file without running it."""
    from pathlib import Path

    from microslip.pipeline.app import case as cs

    parser = argparse.ArgumentParser(prog="microslip check", description=check.__doc__)
    parser.add_argument("case", type=Path, nargs="+", help="case file(s) (TOML)")
    args = parser.parse_args(argv)
    bad = 0
    for path in args.case:
        try:
            c = cs.load(path)
            print(f"{path}: ok ({len(c.analyses)} analyses: "
                  f"{', '.join(str(a.get('name', a['type'])) for a in c.analyses)})")
        except cs.CaseError as err:
            print(err, file=sys.stderr)
            bad += 1
    return 2 if bad else 0


def show(argv: list[str]) -> int:
    """Summarise a results file (or the results.h5 of an output folder)."""
    from pathlib import Path

    from microslip.pipeline.app.results import summary

    parser = argparse.ArgumentParser(prog="microslip show", description=show.__doc__)
    parser.add_argument("path", type=Path, help="results.h5 or its folder")
    args = parser.parse_args(argv)
    target = args.path / "results.h5" if args.path.is_dir() else args.path
    if not target.is_file():
        print(f"microslip show: no results file at {target}", file=sys.stderr)
        return 2
    print(summary(target))
    return 0


def mesh(argv: list[str]) -> int:
    """Mesh the [geometry] of a case file; write .msh, .vtu and PNG previews."""
    from pathlib import Path

    from microslip.pipeline.app.run import mesh_geometry

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
    out.mkdir(parents=True, exist_ok=True)
    try:
        mesh_geometry(c.data["geometry"], out, progress=print, pictures=not args.no_pictures)
    except (TypeError, ValueError) as err:
        print(f"microslip mesh: [geometry.parameters]: {err}", file=sys.stderr)
        return 2
    return 0


def bench(argv: list[str]) -> int:
    """Benchmarks that print measured figures."""
    if not argv or argv[0] not in BENCHES:
        print(f"usage: microslip bench {{{','.join(BENCHES)}}} [options]", file=sys.stderr)
        return 2
    import importlib

    return importlib.import_module(BENCHES[argv[0]]).main(argv[1:])


COMMANDS = {"demo": demo, "run": run, "check": check, "show": show, "mesh": mesh,
            "bench": bench}


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if not argv or argv[0] in ("-h", "--help") or argv[0] not in COMMANDS:
        print("usage: microslip {demo,run,check,show,mesh,bench} ...\n\n"
              "  demo             frequency response of the single-DOF Jenkins oscillator\n"
              "  run CASE.toml    run a case: results.h5 and pictures in out/<case>\n"
              "  check CASE.toml  validate a case file without running it\n"
              "  show DIR         summarise a results file\n"
              "  mesh CASE.toml   mesh a case's geometry: .msh, .vtu, PNG previews\n"
              "  bench core       speed and accuracy of the numerical core\n"
              "  bench mesh       meshing time and size over a mesh-size sweep\n"
              "  bench reduction  assembly, cyclic matrices and Craig-Bampton: time, memory\n"
              "  bench teaching   harmonic balance against time integration; the teaching set\n"
              "  bench coupled    coupled blisk + damper: time per point against contact grid",
              file=sys.stderr)
        return 0 if argv and argv[0] in ("-h", "--help") else 2
    from microslip.pipeline.fe.linalg import retain_freed_memory

    retain_freed_memory()  # a command is one process doing large numerical work
    return COMMANDS[argv[0]](argv[1:])


if __name__ == "__main__":
    raise SystemExit(main())
