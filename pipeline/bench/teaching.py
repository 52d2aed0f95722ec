"""``microslip bench teaching``: harmonic balance against direct time integration
on the 9-DOF blade-damper-blade FRF, and the regeneration time of the teaching set.

FRF (``cases/06_blade_damper.toml``, the coupled curve of analysis ``fig16``: orders
0 and 1, arclength over its frequency window). Accuracy is the peak max|x2_l|
at the HBM's peak frequency against a converged reference: the DTI at 256, 512
and 1024 steps per period, Richardson-extrapolated at the observed order. The
DTI is run at growing steps per period; the matched row is the coarsest whose
error is at most the HBM's (if none is, the steps are extrapolated at the
observed order and the time scaled linearly with the steps). A DTI FRF is timed
as a sweep over the HBM's own points (same resolution), each frequency started
from the previous steady state (the cheapest DTI sweep): the median time per
frequency over ``--dti-points`` of them times the number of HBM points. Because
the HBM happens to be very accurate here (H = 1 at the onset of slip), the table
also gives the ratio at a looser 0.1 % accuracy.

Teaching set: ``microslip run`` of every ``cases/*.toml`` with an [[analysis]],
each in a fresh process (imports and JIT caches included, as a user sees it),
median of ``--set-repeat`` runs. Timings of the FRF are medians of ``--repeat``
runs after a warm-up (JIT compile excluded), also in reference units (a dense
400 x 400 LU, see :mod:`microslip.bench.core`).
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np

from microslip.app.analyses.direct_integration import Dti
from microslip.app.analyses.frf import Frf
from microslip.case import Case, load, lumped_model, settings
from microslip.solve import dti
from microslip.solve.linear import OperatingPoint
from microslip.solve.response import sweep

from .core import median_time, reference_unit

#: The source checkout (this file is pipeline/bench/teaching.py): its cases/ are benchmarked.
ROOT = Path(__file__).resolve().parents[2]
CASES = ROOT / "cases"
CASE = CASES / "06_blade_damper.toml"
OUTPUT = "x2_l"
SPP_REF = (256, 512, 1024)
SPP_TABLE = (32, 64, 128, 256, 512, 1024)
LOOSE = 1e-3  # the looser accuracy of the second comparison (0.1 %)


def _coupled(case: Case) -> tuple[Case, Frf]:
    """The case as the coupled-form curve of Fig. 16 sees it, and that frf."""
    spec = next(x for x in case.analysis_specs if x.name == "fig16")
    family = spec.family
    i = next(i for i, v in enumerate(family.values) if v.startswith("coupled"))
    return case.with_values(family.sets[i]), spec


def _loads(case: Case, hb) -> dti.LoadSteps:
    spec = next(x for x in case.analysis_specs if isinstance(x, Dti))
    return dti.LoadSteps.from_excitation(
        hb.excitation, hb.linear.n_dof, ramp_time=spec.ramp_time,
        settle_time=spec.settle_time, ramp_periods=spec.ramp_periods)


def frf_table(repeat: int, unit: float, dti_points: int) -> list[str]:
    base = load(CASE)
    case, spec = _coupled(base)
    hb = lumped_model(case)
    k = case.dofs.index(OUTPUT)
    keep = {}

    def hbm_frf():
        keep["r"] = sweep(hb, "frequency", spec.start, spec.stop, OperatingPoint(spec.start),
                          settings=settings(case))

    t_hbm = median_time(hbm_frf, repeat)
    r = keep["r"]
    t0 = time.perf_counter()
    w_p, a_h = r.peak(k)
    t_refine = time.perf_counter() - t0
    n_pts = len(r)

    tm = dti.TimeModel.from_harmonic_balance(hb)
    loads = _loads(base, hb)
    cv = dti.step_convergence(tm, loads, w_p, dof=k, steps_per_period=SPP_REF, tol=1e-10)
    a_ref = cv.extrapolated
    order = cv.order[-1] if cv.order.size and np.isfinite(cv.order[-1]) else 2.0
    e_h = abs(a_h - a_ref) / a_ref

    lines = [
        f"9-DOF blade-damper-blade FRF ({CASE.name}, coupled HBM, orders "
        f"{list(hb.harmonics.orders)}, {hb.harmonics.n_samples} samples), w = "
        f"{spec.start:g}..{spec.stop:g} rad/s",
        f"  HBM: {n_pts} points (arclength), {t_hbm:.3f} s ({t_hbm / unit:.0f} ref units), "
        f"{t_hbm / n_pts * 1e3:.2f} ms/point; peak refinement {t_refine:.3f} s",
        f"  reference: DTI at {', '.join(map(str, SPP_REF))} steps/period, Richardson (order "
        f"{order:.2f}): peak max|{OUTPUT}| = {a_ref:.8e} m at w = {w_p:.4f} rad/s",
        f"  HBM peak {a_h:.8e} m: error {e_h:.1e}",
        "",
        f"  {'DTI steps/period':>17} {'peak error':>11} {'s/frequency':>12} "
        f"{'periods':>8} {'FRF s (x' + str(n_pts) + ')':>14} {'DTI/HBM':>9}",
    ]
    rows = []
    for spp in SPP_TABLE:
        t0 = time.perf_counter()
        s = dti.steady_state(tm, loads, w_p, steps_per_period=spp, tol=1e-10)
        t_one = time.perf_counter() - t0
        err = abs(s.amplitude[k] - a_ref) / a_ref
        rows.append((spp, err, t_one))
        lines.append(f"  {spp:17d} {err:11.1e} {t_one:12.3f} {s.periods:8d} "
                     f"{t_one * n_pts:14.1f} {t_one * n_pts / t_hbm:9.0f}")
    lines.append("  (s/frequency here: from the load steps, tol 1e-10; the FRF column "
                 "scales it by the HBM's point count)")

    def matched(target: float) -> tuple[int, bool]:
        for spp, err, _ in rows:
            if err <= target:
                return spp, False
        spp, err, _ = rows[-1]
        return int(np.ceil(spp * (err / target) ** (1.0 / order))), True

    # the DTI FRF at the matched step: a sequential sweep over a subset of the HBM points
    lines.append("")
    for label, target in (("HBM's accuracy", e_h), (f"{LOOSE:.0e}", max(LOOSE, e_h))):
        spp, extrapolated = matched(target)
        spp_run = min(spp, SPP_TABLE[-1])
        idx = np.unique(np.linspace(0, n_pts - 1, dti_points).round().astype(int))
        fr = dti.frequency_response(tm, loads, r.omega[idx], steps_per_period=spp_run)
        per = float(np.median(fr.seconds[1:] if fr.seconds.size > 1 else fr.seconds))
        per *= spp / spp_run
        t_dti = per * n_pts
        note = (f" (extrapolated at order {order:.2f} from {spp_run}; time scaled by the "
                "steps)" if extrapolated else "")
        lines.append(
            f"  matched at {label} ({target:.1e}): {spp} steps/period{note}; DTI sweep "
            f"{per:.3f} s/frequency (median over {idx.size - 1} sequential points), "
            f"{t_dti:.1f} s for {n_pts} points; HBM {t_hbm:.3f} s; HBM faster "
            f"{t_dti / t_hbm:.0f}x (goal >= 100x)")
    return lines


def case_names(path: Path) -> set[str]:
    """The names a shipped case answers to: its file stem, and the stem without its place
    in the learning order (``02_hysteresis_loops``, ``hysteresis_loops``)."""
    return {path.stem, re.sub(r"^\d+_", "", path.stem)}


def teaching_cases(only: list[str] | None = None) -> list[Path]:
    """The shipped cases with an [[analysis]] (of the names in ``only``, when given), in
    their learning order."""
    out = []
    for path in sorted(CASES.glob("*.toml")):
        if only is not None and not case_names(path) & set(only):
            continue
        with open(path, "rb") as f:
            if tomllib.load(f).get("analysis"):
                out.append(path)
    return out


def _status(results: Path) -> str:
    try:
        import h5py

        with h5py.File(results, "r") as f:
            return str(f.attrs.get("status", "?"))
    except (OSError, ImportError):
        return "no results"


def set_table(repeat: int, only: list[str] | None = None) -> list[str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + [p for p in (
        env.get("PYTHONPATH", ""),) if p])
    code = "import sys; from microslip.cli import main; sys.exit(main(sys.argv[1:]))"
    lines = [f"Teaching set: microslip run of every case with an [[analysis]] (fresh process "
             f"each, median of {repeat})",
             f"  {'case':<26} {'time s':>8} {'status':>10}"]
    total = 0.0
    with tempfile.TemporaryDirectory(prefix="microslip_bench_") as tmp:
        for path in teaching_cases(only):
            times, status = [], "?"
            for j in range(repeat):
                out = Path(tmp) / f"{path.stem}_{j}"
                t0 = time.perf_counter()
                p = subprocess.run([sys.executable, "-c", code, "run", str(path), "--out",
                                    str(out)], env=env, cwd=ROOT, capture_output=True,
                                   text=True)
                times.append(time.perf_counter() - t0)
                status = _status(out / "results.h5") if p.returncode == 0 else \
                    f"exit {p.returncode}"
            t = float(np.median(times))
            total += t
            lines.append(f"  {path.name:<26} {t:8.1f} {status:>10}")
    lines.append(f"  {'total':<26} {total:8.1f}   (goal < 120 s)")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="microslip bench teaching", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=3, help="HBM runs per median (>= 1)")
    parser.add_argument("--dti-points", type=int, default=8,
                        help="frequencies of the timed DTI sweep (>= 2)")
    parser.add_argument("--set-repeat", type=int, default=1,
                        help="runs of each teaching case per median (>= 1)")
    parser.add_argument("--skip-frf", action="store_true", help="skip the HBM/DTI table")
    parser.add_argument("--skip-set", action="store_true", help="skip the teaching set")
    parser.add_argument("--cases", default=None, metavar="NAMES",
                        help="comma-separated case names (file stems, with or without "
                             "their number) of the teaching set; "
                             "default: every case with an [[analysis]]")
    args = parser.parse_args(argv)
    only = [c.strip() for c in args.cases.split(",")] if args.cases else None
    problem = "" if args.skip_frf or CASE.is_file() else \
        f"the cases are read from the source checkout: {CASE} not found"
    unknown = sorted(set(only or ()) - set().union(*map(case_names, teaching_cases())))
    if unknown and not problem:
        problem = (f"--cases {args.cases}: no case {', '.join(unknown)} in {CASES} (allowed: "
                   f"{', '.join(p.stem for p in teaching_cases())})")
    if problem:
        print(f"microslip bench teaching: {problem}", file=sys.stderr)
        return 2
    for name in ("repeat", "set_repeat"):
        if getattr(args, name) < 1:
            parser.error(f"--{name.replace('_', '-')} must be >= 1")
    if args.dti_points < 2:
        parser.error("--dti-points must be >= 2")
    unit = reference_unit()
    print(f"reference unit (400x400 dense LU): {unit * 1e3:.2f} ms")
    if not args.skip_frf:
        print()
        print("\n".join(frf_table(args.repeat, unit, args.dti_points)), flush=True)
    if not args.skip_set:
        print()
        print("\n".join(set_table(args.set_repeat, only)), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
