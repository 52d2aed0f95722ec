"""``microslip bench core``: speed and accuracy of the numerical core, measured.

Every timing is the median of ``repeat`` runs after one warm-up (JIT compile
excluded). So that figures compare across machines, each table also gives
times as multiples of a fixed reference workload run in the same process (a
dense 400 x 400 LU factorisation, "ref units").
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np
import scipy.linalg as sla

from microslip.fourier import Harmonics
from microslip.laws.coulomb import ContactElements
from microslip.solve.linear import OperatingPoint
from microslip.solve.response import sweep

from .demos import jenkins_oscillator


def median_time(fn: Callable[[], object], repeat: int) -> float:
    """Median wall time of ``fn`` over ``repeat`` runs, after one warm-up, s."""
    fn()
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def reference_unit(repeat: int = 5) -> float:
    """Time of the reference workload (dense 400 x 400 LU), s."""
    A = np.random.default_rng(0).normal(size=(400, 400))
    return median_time(lambda: sla.lu_factor(A), repeat)


def frf_table(repeat: int, unit: float) -> list[str]:
    hb = jenkins_oscillator()
    out = {}

    def run():
        out["r"] = sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(0.5))

    t = median_time(run, repeat)
    r = out["r"]
    n = len(r)
    w, a = r.peak(0)
    return [
        "Single-DOF Jenkins FRF, w = 0.5..2.5 rad/s, H = 7, 256 samples, arclength",
        f"  points {n}, steps {r.branch.steps}, mean Newton iterations "
        f"{r.branch.iterations.mean():.2f}, status {r.branch.status}",
        f"  whole curve     {t * 1e3:9.2f} ms   ({t / unit:8.1f} ref units)",
        f"  per point       {t / n * 1e3:9.3f} ms   (goal <= 2 ms)",
        f"  peak max|x| = {a:.6f} at w = {w:.6f} rad/s",
    ]


def contact_points(P: int, H: int = 3, n_samples: int = 128, seed: int = 0):
    """P law-D points in a mix of stick, slip and lift-off, and their motion."""
    rng = np.random.default_rng(seed)
    h = Harmonics.up_to(H, n_samples)
    el = ContactElements.create("D", kt=rng.uniform(1, 3, P), kn=rng.uniform(1, 3, P),
                                mu=0.5, interference=rng.uniform(0.05, 0.5, P), coupled=True)
    g = rng.normal(size=(P, 3, h.n_coeffs)) * rng.uniform(0.05, 1.0, (P, 1, 1))
    return el, g, h


def contact_table(repeat: int, unit: float) -> list[str]:
    lines = ["Residual + Jacobian of law-D points (coupled), H = 3, 128 samples"]
    lines.append(f"  {'points':>8} {'time ms':>10} {'us/point':>10} {'ref units':>10}  states")
    for P in (100, 1000, 10000):
        el, g, h = contact_points(P)
        t = median_time(lambda el=el, g=g, h=h: el.evaluate(g, h), repeat)
        st = np.bincount(el.evaluate(g, h, jacobian=False).state, minlength=5)
        lines.append(f"  {P:8d} {t * 1e3:10.2f} {t / P * 1e6:10.2f} {t / unit:10.1f}  "
                     f"stick {st[0]}, stick-slip {st[1]}, gross {st[2]}, lift-off {st[3]}, "
                     f"open {st[4]}")
    lines.append("  goal: 1,000 points <= 20 ms")
    return lines


def accuracy_table(repeat: int, unit: float) -> list[str]:
    """Peak error against a converged reference, and FRF time, per (H, samples)."""
    ref_hb = jenkins_oscillator(31, 2048)
    ref = sweep(ref_hb, "frequency", 0.9, 1.1, OperatingPoint(0.9))
    w_ref, a_ref = ref.peak(0)
    Hs, samples = (1, 3, 5, 7, 15), (32, 64, 128, 256, 1024)
    lines = [
        "Speed/accuracy, single-DOF FRF: relative peak error | whole-curve time (ms)",
        f"  reference H = 31, 2048 samples: peak {a_ref:.7f} at w = {w_ref:.7f} rad/s",
        "  " + f"{'H':>4} " + "".join(f"{f'ns={ns}':>22}" for ns in samples),
    ]
    for H in Hs:
        row = f"  {H:4d} "
        for ns in samples:
            if ns <= 2 * H:
                row += f"{'-':>22}"
                continue
            hb = jenkins_oscillator(H, ns)
            keep = {}

            def run(hb=hb, keep=keep):
                keep["r"] = sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(0.5))

            t = median_time(run, max(1, repeat // 2))
            r = keep["r"]
            if not r.branch.complete:
                row += f"{'stopped':>22}"
                continue
            err = abs(r.peak(0)[1] - a_ref) / a_ref
            row += f"{err:>12.1e} | {t * 1e3:7.1f}"
        lines.append(row)
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="microslip bench core", description=__doc__)
    parser.add_argument("--repeat", type=int, default=5, help="runs per median (>= 1)")
    parser.add_argument("--skip-accuracy", action="store_true", help="skip the H x samples table")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error(f"--repeat must be >= 1, got {args.repeat}")
    unit = reference_unit()
    print(f"reference unit (400x400 dense LU): {unit * 1e3:.2f} ms")
    for table in (frf_table, contact_table) + (() if args.skip_accuracy else (accuracy_table,)):
        print()
        print("\n".join(table(args.repeat, unit)), flush=True)
    return 0
