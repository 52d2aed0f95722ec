"""Benchmark of assembly, cyclic matrices and Craig-Bampton: times, peak memory, backends,
and the speed/accuracy table of mesh size and element order (a speed/accuracy trade).

    microslip bench reduction                      # default blisk sector
    microslip bench reduction --refine 0.36 --modes 30 --nds 0,1 --backends pardiso
                                                            # ~150,000 DOFs per ND
    microslip bench reduction --accuracy --nds 0,1 # mesh size / order vs error
    microslip bench reduction --cb blisk --nds 0,1,12,24   # CB error vs modes/cut-off
Peak memory is the process's ru_maxrss: run one backend per process to compare backends.
Performance figures live here, never in timed tests.
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from collections.abc import Sequence

import numpy as np

from microslip.fe import craig_bampton, cyclic, eigen, fem, linalg, reduced_model

STEEL = fem.Material(2.0e11, 0.3, 7850.0)


def peak_memory_mb() -> float:
    """Peak resident memory of this process so far [MB] (Linux ru_maxrss is in kB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def blisk_mesh(refine: float):
    """The default blisk sector, tet sizes scaled by ``refine`` (< 1: finer)."""
    from microslip.geometry.blisk import BliskParameters, blisk_sector

    p = BliskParameters()
    return blisk_sector(size=p.size * refine, blade_size=p.blade_size * refine)


def blisk_bodies(mesh) -> dict[str, dict]:
    """Per body: clamped nodes and masters (every contact node + excitation + response)."""
    blisk_masters = fem.node_sets_union(mesh, [
        "contact/damper_left/blisk", "contact/damper_right/blisk",
        "blisk/excitation", "blisk/response"])
    damper_masters = fem.node_sets_union(mesh, [
        "contact/damper_left/damper", "contact/damper_right/damper"])
    return {
        "blisk": {"clamped": fem.node_set(mesh, "blisk/bore"), "masters": blisk_masters},
        "damper": {"clamped": np.empty(0, np.int64), "masters": damper_masters},
    }


def _row(cells: Sequence[object], widths: Sequence[int]) -> str:
    return "  ".join(str(c).rjust(w) for c, w in zip(cells, widths, strict=True))


def _progress(text: str) -> None:
    """A long bench's sign of life, on stderr: the tables (stdout) hold each row once."""
    print(text, file=sys.stderr, flush=True)


def _runs(repeat: int) -> str:
    return "single run" if repeat == 1 else f"median of {repeat} runs"


def _table(title: str, header: Sequence[str], rows: list[Sequence[object]]) -> None:
    widths = [max(len(str(x)) for x in col) for col in zip(header, *rows, strict=True)]
    print(f"\n{title}")
    print(_row(header, widths))
    for r in rows:
        print(_row(r, widths))


def _modes(text: str) -> int | str:
    return text if text == "auto" else int(text)


def bench_reduction(mesh, nds: Sequence[int], n_modes: int | str, backends: Sequence[str],
                    order: int = 2, eigen: str = "block",
                    bodies: Sequence[str] = ("blisk", "damper"), repeat: int = 1) -> None:
    """Assembly table and the per-ND cyclic + CB table for every backend."""
    specs = {k: v for k, v in blisk_bodies(mesh).items() if k in bodies}
    models, rows = {}, []
    for name in specs:
        t = time.perf_counter()
        models[name] = fem.assemble(mesh, name, STEEL, order)
        rows.append([name, order, models[name].n_dofs, f"{time.perf_counter() - t:.2f}",
                     f"{peak_memory_mb():.0f}"])
    _table("assembly", ["body", "order", "DOFs", "time [s]", "peak RSS [MB]"], rows)

    rows = []
    boundary = mesh.cyclic["blisk"]
    disk_models: list = []  # the damper's f_max is the top of the range the disk NDs resolve
    f_max = None
    for backend in backends:
        for name, spec in specs.items():
            for h in (nds if name == "blisk" else [0]):
                runs = []
                for _ in range(repeat):
                    t0 = time.perf_counter()
                    model = cyclic.sector_model(models[name], spec["clamped"],
                                                boundary if name == "blisk" else None, h)
                    t1 = time.perf_counter()
                    tm: dict = {}
                    red = craig_bampton.craig_bampton(model, spec["masters"], n_modes,
                                                  backend=backend, timings=tm,
                                                  f_max=f_max if name != "blisk" else None,
                                                  eigen_method=eigen)
                    t2 = time.perf_counter()
                    runs.append([t1 - t0, tm["factorize"], tm["static_modes"], tm["eigen"],
                                 tm["projection"], t2 - t0])
                if name == "blisk":
                    disk_models.append(red)
                    f_max = reduced_model.reference_frequency(disk_models)
                times = np.median(np.array(runs), axis=0)
                rows.append([backend, name, h, model.n_free, red.n_masters, red.n_modes,
                             *(f"{x:.2f}" for x in times), f"{peak_memory_mb():.0f}",
                             f"{red.frequencies(7)[-1]:.1f}"])
                _progress(f"  {backend} {name} ND {h}: {times[-1]:.2f} s")
    _table(f"cyclic matrices + Craig-Bampton per ND (eigen: {eigen}; times in s, "
           f"{_runs(repeat)}; peak RSS is the process's; the damper's modes up to cutoff x the "
           "disk's highest 10th fixed-interface frequency, as a case does)",
           ["backend", "body", "ND", "free DOFs", "masters", "modes", "cyclic", "factor",
            "static", "eigen", "project", "total", "peak MB", "f7 [Hz]"], rows)


def bench_cb(model_name: str, nds: Sequence[int], cutoffs: Sequence[float],
             counts: Sequence[int] = (10, 30)) -> None:
    """CB error of the first ten frequencies per ND against fixed counts and cut-offs.

    model_name: "blisk" (default blisk sector, masters = contact + excitation + response
    nodes) or "annular" (the test model of tests/test_reduction.py). Reference: the
    unreduced sector model.
    """
    from microslip import geometry

    if model_name == "annular":
        sectors = 6
        mesh = geometry.annular_sector(sectors=sectors, r_inner=0.05, r_outer=0.12, width=0.01,
                                       size=0.015)
        body = fem.assemble(mesh, "disk", fem.Material(2.1e11, 0.3, 7800.0))
        rim = fem.node_set(mesh, "disk/rim")
        theta = np.arctan2(mesh.points[rim, 1], mesh.points[rim, 0])
        masters = rim[np.abs(theta) < np.pi / sectors / 3]
        clamped, boundary = fem.node_set(mesh, "disk/bore"), mesh.cyclic["disk"]
    else:
        mesh = blisk_mesh(1.0)
        spec = blisk_bodies(mesh)["blisk"]
        body = fem.assemble(mesh, "blisk", STEEL)
        masters, clamped, boundary = spec["masters"], spec["clamped"], mesh.cyclic["blisk"]
    rows = []
    for h in nds:
        model = cyclic.sector_model(body, clamped, boundary, h)
        lam, _ = eigen.lowest_modes(model.stiffness, model.mass, 10)
        f_ref = np.sqrt(lam) / (2 * np.pi)
        runs: list[tuple[str, dict]] = [(f"{n} modes", {"n_modes": n}) for n in counts]
        runs += [(f"cutoff {c:g}", {"n_modes": "auto", "cutoff": c}) for c in cutoffs]
        for label, kwargs in runs:
            t = time.perf_counter()
            red = craig_bampton.craig_bampton(model, masters, **kwargs)
            err = np.abs(red.frequencies(10) / f_ref - 1)
            rows.append([h, label, red.n_modes, f"{err.max():.1e}",
                         " ".join(f"{e:.0e}" for e in err), f"{time.perf_counter() - t:.1f}"])
            _progress(f"  ND {h} {label}: {time.perf_counter() - t:.1f} s")
    _table(f"Craig-Bampton error of the first ten frequencies per ND ({model_name}; cutoff c: "
           f"modes below c x the 10th fixed-interface frequency; default "
           f"{reduced_model.DEFAULT_MODES!r}, c = {reduced_model.CUTOFF:g})",
           ["ND", "selection", "modes", "max error", "errors f1..f10", "time [s]"], rows)


def bench_accuracy(refines: Sequence[float], nds: Sequence[int], n_freq: int = 6,
                   reference: float | None = None) -> None:
    """Mesh size and element order against the error of the first blisk frequencies.

    Reference: P2 on the mesh with size factor ``reference`` (default: the finest of the list).
    Unreduced sector, clamped bore, damper absent; time = assembly + cyclic + eigen-solve.
    """
    ref_factor = reference if reference is not None else min(refines)
    cases = sorted(set(refines) | {ref_factor}, reverse=True)
    results = {}
    for refine in cases:
        mesh = blisk_mesh(refine)
        clamped = fem.node_set(mesh, "blisk/bore")
        for order in (1, 2) if refine in refines else (2,):
            t = time.perf_counter()
            body = fem.assemble(mesh, "blisk", STEEL, order)
            t_asm = time.perf_counter() - t
            for h in nds:
                t = time.perf_counter()
                model = cyclic.sector_model(body, clamped, mesh.cyclic["blisk"], h)
                lam, _ = eigen.lowest_modes(model.stiffness, model.mass, n_freq)
                results[refine, order, h] = (body.n_dofs, np.sqrt(lam) / (2 * np.pi),
                                             t_asm + time.perf_counter() - t)
                _progress(f"  size factor {refine:g} P{order} ND {h}: "
                          f"{results[refine, order, h][2]:.1f} s")
    rows = []
    for (refine, order, h), (n, f, t) in results.items():
        if refine not in refines:
            continue
        err = np.abs(f / results[ref_factor, 2, h][1] - 1)
        rows.append([f"{refine:g}", f"P{order}", h, n, f"{err.max():.1e}",
                     " ".join(f"{e:.0e}" for e in err), f"{t:.1f}"])
    refs = "; ".join(f"ND {h}: " + np.array2string(results[ref_factor, 2, h][1], precision=0)
                     for h in nds)
    _table(f"speed/accuracy (blisk sector, first {n_freq} frequencies vs P2 at size factor "
           f"{ref_factor:g}, {results[ref_factor, 2, nds[0]][0]} DOFs; f_ref [Hz] {refs})",
           ["size factor", "order", "ND", "DOFs", "max rel error", "errors", "time [s]"], rows)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="microslip bench reduction", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--refine", type=float, default=1.0,
                        help="scale of the blisk tet sizes (0.36: about 150,000 DOFs)")
    parser.add_argument("--nds", default="0,1,2,3",
                        help="nodal diameters, comma-separated (default: 0..3)")
    parser.add_argument("--modes", type=_modes, default=reduced_model.DEFAULT_MODES,
                        help="fixed-interface modes: an integer or 'auto' (cut-off, default)")
    parser.add_argument("--eigen", default="block", choices=("block", "arpack"))
    parser.add_argument("--backends", default=",".join(linalg.available_backends()))
    parser.add_argument("--bodies", default="blisk,damper")
    parser.add_argument("--order", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=1,
                        help="runs per ND; the tables give medians (default 1: single run)")
    parser.add_argument("--accuracy", action="store_true",
                        help="print the mesh-size/order speed-accuracy table instead")
    parser.add_argument("--accuracy-refines", default="2,1.4,1,0.7")
    parser.add_argument("--accuracy-reference", type=float, default=None,
                        help="size factor of the P2 reference (default: the finest)")
    parser.add_argument("--cb", choices=("blisk", "annular"), default=None,
                        help="print the CB error table (modes / cut-off per ND) instead")
    parser.add_argument("--cutoffs", default="3,3.5,4,5")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error(f"--repeat must be >= 1, got {args.repeat}")
    linalg.retain_freed_memory()
    nds = [int(x) for x in args.nds.split(",")]
    if args.accuracy:
        bench_accuracy([float(x) for x in args.accuracy_refines.split(",")], nds,
                       reference=args.accuracy_reference)
        return 0
    if args.cb:
        bench_cb(args.cb, nds, [float(x) for x in args.cutoffs.split(",")])
        return 0
    backends = [linalg.check_backend(b) for b in args.backends.split(",")]
    t = time.perf_counter()
    mesh = blisk_mesh(args.refine)
    print(f"blisk sector, size factor {args.refine:g}: {len(mesh.points)} nodes, "
          f"{len(mesh.tetrahedra)} tets, meshed in {time.perf_counter() - t:.2f} s")
    bench_reduction(mesh, nds, args.modes, backends, args.order, args.eigen,
                    args.bodies.split(","), args.repeat)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
