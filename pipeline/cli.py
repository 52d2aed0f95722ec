"""The ``microslip`` command."""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

BENCHES = {
    "core": "pipeline.bench",
}


def demo(argv: list[str]) -> int:
    """Frequency response of the single-DOF Jenkins oscillator, as a table."""
    from .demos import jenkins_oscillator
    from .hbm import OperatingPoint
    from .response import sweep

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


def bench(argv: list[str]) -> int:
    """Benchmarks that print measured figures."""
    if not argv or argv[0] not in BENCHES:
        print(f"usage: microslip bench {{{','.join(BENCHES)}}} [options]", file=sys.stderr)
        return 2
    import importlib

    return importlib.import_module(BENCHES[argv[0]]).main(argv[1:])


COMMANDS = {"demo": demo, "bench": bench}


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if not argv or argv[0] in ("-h", "--help") or argv[0] not in COMMANDS:
        print("usage: microslip {demo,bench} ...\n\n"
              "  demo             frequency response of the single-DOF Jenkins oscillator\n"
              "  bench core       speed and accuracy of the numerical core", file=sys.stderr)
        return 0 if argv and argv[0] in ("-h", "--help") else 2
    return COMMANDS[argv[0]](argv[1:])


if __name__ == "__main__":
    raise SystemExit(main())
