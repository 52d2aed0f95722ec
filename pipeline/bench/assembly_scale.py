"""Speed of the coupled harmonic balance at full scale: the blisk sector with its wedge damper,
contact grids from 2 x 24 to 2 x 240 node pairs, harmonics 0-1 and 0-3.

    microslip bench assembly                                 # the whole table
    microslip bench assembly --grids 6x4,9x4 --harmonics 1 --points 10

Per configuration, in a fresh process (its own peak memory) at --threads BLAS threads: the
mesh and the reduced bodies (cached under --cache), the assembly model, the first point
(linear guesses, scales, Newton from cold) and then --points arclength points from there.
Printed: unknowns, time before the first point, median time per point, Newton iterations
per point, GMRES iterations per Newton solve and preconditioners made (the structured
Newton, where hbm.structured_by_default picks it), peak memory, and the dense LU of the unknowns
at this machine's measured rate (a 400 x 400 LU in the same process): what every Newton
iteration paid before the structured Newton, and "x LU" the time per point over it. Last,
the growth exponent of time per point against the number of unknowns (3 is the LU's). A
configuration whose one unavoidable factorization (:func:`factorization_seconds`) would take
longer than --budget seconds is not run.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import multiprocessing
import resource
import time
from pathlib import Path

import numpy as np

from .core import reference_unit

GRIDS = ((6, 4), (9, 4), (12, 5), (12, 6), (15, 8), (24, 10))  # (axial, along the flank)
LU_400_FLOP = 2.0 / 3.0 * 400**3


def unknowns(n_axial: int, n_flank: int, H: int) -> int:
    """2 patches x pairs x 2 nodes x 3 DOFs, times the coefficients of orders 0..H."""
    return 12 * n_axial * n_flank * (2 * H + 1)


def factorization_seconds(n: int, H: int, rate: float) -> float:
    """The one factorization a configuration cannot avoid, at ``rate`` flop/s: the dense LU
    of the n unknowns where hbm.structured_by_default says dense, else the per-order LU and
    inverse (order 0 real, H complex orders of n / (2H + 1) DOFs, 4 real flops per complex
    one; in single precision, counted as double)."""
    from microslip.solve.hbm import structured_by_default

    nd = n / (2 * H + 1)
    if not structured_by_default(round(nd), 2 * H + 1):
        return 2.0 / 3.0 * n**3 / rate
    return 2.0 * (1 + 4 * H) * nd**3 / rate  # LU (2/3) and inverse (4/3) per order


def run_one(n_axial: int, n_flank: int, H: int, points: int, cache: str,
            threads: int = 1) -> dict:
    """One configuration (run in a child process, ``threads`` BLAS threads)."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(threads):
        return _run_one(n_axial, n_flank, H, points, cache)


def _run_one(n_axial: int, n_flank: int, H: int, points: int, cache: str) -> dict:
    from microslip import geometry
    from microslip.app import structure
    from microslip.assembly.join import join
    from microslip.assembly.spec import AssemblySpec, NodalLoad, Output, PatchFriction
    from microslip.fourier import Harmonics
    from microslip.solve import continuation as cont
    from microslip.solve.linear import OperatingPoint
    from microslip.solve.response import solve_point, sweep

    t0 = time.perf_counter()
    mesh = geometry.blisk_sector(contact_n_axial=n_axial, contact_n_flank=n_flank)
    red = structure.reduce_structure(
        mesh, {"engine_order": 12, "harmonics": H, "damping": {"modal_ratios": 0.001}},
        Path(cache) / f"{n_axial}x{n_flank}", range(H + 1), progress=lambda s: None)
    spec = AssemblySpec(
        contacts=(PatchFriction("damper_left", 0.5), PatchFriction("damper_right", 0.5)),
        engine_order=12, loads=(NodalLoad("blisk/excitation", "tangential", 5.0),),
        outputs=(Output("tip", "blisk/response", "tangential"),), centrifugal=("damper",),
        mass_bodies=("damper",))
    hb = join(mesh, red.models, red.patch_stiffness, spec, Harmonics.up_to(H, 64)).hb
    setup = time.perf_counter() - t0
    w0 = 0.96 * 2 * np.pi * red.frequencies["blisk", 12][0]
    base = OperatingPoint(w0, mass_multiplier=25.0)
    t1 = time.perf_counter()
    first = solve_point(hb, base)  # what a curve's start costs: guesses, scales, Newton
    t_first = time.perf_counter() - t1
    times, its = [], []

    def tick(n, value, iterations):
        times.append(time.perf_counter())
        its.append(iterations)

    t2 = time.perf_counter()
    pc = hb.preconditioner
    counters = ("solves", "iterations", "refreshes", "dense_solves")
    before = [getattr(pc, c) for c in counters]
    r = sweep(hb, "frequency", w0, 1.1 * w0, base, x0=first.x,
              settings=cont.Settings(max_points=points + 1), progress=tick)
    steps = np.diff([t2, *times])[1:]  # the first is the start point again
    solves, krylov, refreshes, dense = (getattr(pc, c) - b for c, b in zip(counters, before))
    return {"unknowns": hb.n_unknowns, "setup": setup, "first": t_first,
            "structured": hb.structured, "krylov": krylov / solves if solves else float("nan"),
            "refreshes": refreshes, "dense": dense,
            "per_point": float(np.median(steps)) if len(steps) else float("nan"),
            "iterations": float(np.mean(its[1:])) if len(its) > 1 else float("nan"),
            "points": len(r) - 1, "status": r.branch.status,
            "memory_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def _grids(text: str) -> list[tuple[int, int]]:
    out = []
    for item in text.split(","):
        a, _, b = item.partition("x")
        out.append((int(a), int(b)))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="microslip bench assembly", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--grids", type=_grids, default=list(GRIDS),
                        help="contact grids per patch, e.g. 6x4,9x4 (axial x flank)")
    parser.add_argument("--harmonics", default="1,3", help="highest orders H, e.g. 1,3")
    parser.add_argument("--points", type=int, default=10, help="arclength points timed")
    parser.add_argument("--budget", type=float, default=60.0,
                        help="skip a configuration whose one factorization (the dense LU "
                             "where hbm.structured_by_default says dense, else the "
                             "preconditioner's per-order ones) would take longer [s]")
    parser.add_argument("--threads", type=int, default=1,
                        help="BLAS threads of each configuration (default 1)")
    parser.add_argument("--cache", default=".microslip-cache/bench-assembly",
                        help="where the reduced bodies are kept between runs")
    args = parser.parse_args(argv)
    if args.points < 2:
        parser.error(f"--points must be >= 2, got {args.points}")
    Hs = [int(h) for h in args.harmonics.split(",")]
    unit = reference_unit()
    rate = LU_400_FLOP / unit
    print(f"reference: 400 x 400 LU {unit * 1e3:.2f} ms ({rate / 1e9:.1f} GFLOP/s); "
          f"{args.threads} BLAS thread(s) per configuration; 'gmres': Krylov iterations per "
          "Newton solve (LU: dense), 'new P': preconditioners made over the points, 'dense': "
          "the structured solves' dense fallbacks (GMRES failed) over the points")
    header = (f"{'grid':>9} {'H':>2} {'unknowns':>8} {'setup s':>8} {'first s':>8} "
              f"{'s/point':>8} {'its/pt':>6} {'gmres':>5} {'new P':>5} {'dense':>5} "
              f"{'LU s':>7} {'x LU':>5} {'peak MB':>8}  status")
    print(header)
    rows: dict[int, list[tuple[int, float]]] = {}
    ctx = multiprocessing.get_context("spawn")
    for H in Hs:
        for na, nf in args.grids:
            n = unknowns(na, nf, H)
            grid = f"2x{na * nf}"
            cost = factorization_seconds(n, H, rate)
            if cost > args.budget:
                print(f"{grid:>9} {H:>2} {n:>8}  skipped: one factorization ~{cost:.0f} s "
                      "> --budget", flush=True)
                continue
            with cf.ProcessPoolExecutor(1, mp_context=ctx) as pool:
                res = pool.submit(run_one, na, nf, H, args.points, args.cache,
                                  args.threads).result()
            lu = 2.0 / 3.0 * res["unknowns"] ** 3 / rate
            gm = f"{res['krylov']:5.1f}" if res["structured"] else f"{'LU':>5}"
            print(f"{grid:>9} {H:>2} {res['unknowns']:>8} {res['setup']:8.1f} "
                  f"{res['first']:8.2f} {res['per_point']:8.3f} {res['iterations']:6.1f} "
                  f"{gm} {res['refreshes']:5d} {res['dense']:5d} "
                  f"{lu:7.3f} {res['per_point'] / lu:5.2f} {res['memory_mb']:8.0f}  "
                  f"{res['status']} ({res['points']} points)", flush=True)
            rows.setdefault(H, []).append((res["unknowns"], res["per_point"]))
    for H, pts in rows.items():
        if len(pts) >= 2:
            n, t = np.log(np.array(pts)).T
            slope = np.polyfit(n, t, 1)[0]
            print(f"H = {H}: time per point ~ unknowns^{slope:.2f} over "
                  f"{min(p[0] for p in pts)}..{max(p[0] for p in pts)} unknowns")
    return 0
