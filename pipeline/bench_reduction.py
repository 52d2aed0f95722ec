"""Benchmark of assembly, cyclic matrices and Craig-Bampton: times, peak memory, backends,
and the speed/accuracy table of mesh size and element order (DESIGN.md §7).

    python -m pipeline.bench_reduction                      # default blisk sector
    python -m pipeline.bench_reduction --refine 0.5         # finer mesh (sizes x 0.5)
    python -m pipeline.bench_reduction --accuracy           # mesh size / order vs error
Performance figures live here, never in timed tests.
"""

from __future__ import annotations

import argparse
import resource
import time
from collections.abc import Sequence

import numpy as np

from pipeline import cyclic, fem, linalg, reduction

STEEL = fem.Material(2.0e11, 0.3, 7850.0)


def peak_memory_mb() -> float:
    """Peak resident memory of this process so far [MB] (Linux ru_maxrss is in kB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def blisk_mesh(refine: float):
    """The default blisk sector, tet sizes scaled by ``refine`` (< 1: finer)."""
    from geometry.blisk import BliskParameters, blisk_sector

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


def _table(title: str, header: Sequence[str], rows: list[Sequence[object]]) -> None:
    widths = [max(len(str(x)) for x in col) for col in zip(header, *rows, strict=True)]
    print(f"\n{title}")
    print(_row(header, widths))
    for r in rows:
        print(_row(r, widths))


def bench_reduction(mesh, nds: Sequence[int], n_modes: int, backends: Sequence[str],
                    order: int = 2) -> None:
    """Assembly table and the per-ND cyclic + CB table for every backend."""
    bodies = blisk_bodies(mesh)
    models, rows = {}, []
    for name in bodies:
        t = time.perf_counter()
        models[name] = fem.assemble(mesh, name, STEEL, order)
        rows.append([name, order, models[name].n_dofs, f"{time.perf_counter() - t:.2f}",
                     f"{peak_memory_mb():.0f}"])
    _table("assembly", ["body", "order", "DOFs", "time [s]", "peak RSS [MB]"], rows)

    rows = []
    boundary = mesh.cyclic["blisk"]
    for backend in backends:
        for name, spec in bodies.items():
            for h in (nds if name == "blisk" else [0]):
                t0 = time.perf_counter()
                model = cyclic.sector_model(models[name], spec["clamped"],
                                            boundary if name == "blisk" else None, h)
                t1 = time.perf_counter()
                tm: dict = {}
                red = reduction.craig_bampton(model, spec["masters"], n_modes, backend=backend,
                                              timings=tm)
                t2 = time.perf_counter()
                rows.append([backend, name, h, model.n_free, red.n_masters, n_modes,
                             f"{t1 - t0:.2f}", f"{tm['factorize']:.2f}",
                             f"{tm['static_modes']:.2f}", f"{tm['eigen']:.2f}",
                             f"{tm['projection']:.2f}", f"{t2 - t0:.2f}",
                             f"{peak_memory_mb():.0f}", f"{red.frequencies(7)[-1]:.1f}"])
    _table("cyclic matrices + Craig-Bampton per ND (times in s; peak RSS is the process's)",
           ["backend", "body", "ND", "free DOFs", "masters", "modes", "cyclic", "factor",
            "static", "eigen", "project", "total", "peak MB", "f7 [Hz]"], rows)


def bench_accuracy(refines: Sequence[float], nd: int, n_freq: int = 6) -> None:
    """Mesh size and element order against the error of the first blisk frequencies.

    Reference: the finest P2 mesh of the list. Unreduced sector, clamped bore, damper absent.
    """
    results = []
    for refine in refines:
        mesh = blisk_mesh(refine)
        clamped = fem.node_set(mesh, "blisk/bore")
        for order in (1, 2):
            t = time.perf_counter()
            body = fem.assemble(mesh, "blisk", STEEL, order)
            model = cyclic.sector_model(body, clamped, mesh.cyclic["blisk"], nd)
            lam, _ = linalg.lowest_modes(model.stiffness, model.mass, n_freq)
            results.append((refine, order, body.n_dofs, np.sqrt(lam) / (2 * np.pi),
                            time.perf_counter() - t))
    ref = min((r for r in results if r[1] == 2), key=lambda r: r[0])[3]
    rows = [[f"{r:g}", o, n, f"{np.abs(f / ref - 1).max():.2e}", f"{t:.2f}"]
            for r, o, n, f, t in results]
    _table(f"speed/accuracy (blisk sector, ND {nd}, first {n_freq} frequencies vs the finest "
           f"P2 mesh; f_ref = {np.array2string(ref, precision=1)} Hz)",
           ["size factor", "order", "DOFs", "max rel error", "time [s]"], rows)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="bench_reduction", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--refine", type=float, default=1.0,
                        help="scale of the blisk tet sizes (0.5: twice finer)")
    parser.add_argument("--nds", default="0,1,2,3",
                        help="nodal diameters, comma-separated (default: 0..3)")
    parser.add_argument("--modes", type=int, default=reduction.DEFAULT_MODES)
    parser.add_argument("--backends", default=",".join(linalg.available_backends()))
    parser.add_argument("--order", type=int, default=2)
    parser.add_argument("--accuracy", action="store_true",
                        help="print the mesh-size/order speed-accuracy table instead")
    parser.add_argument("--accuracy-refines", default="2,1.4,1,0.7")
    args = parser.parse_args(argv)
    if args.accuracy:
        bench_accuracy([float(x) for x in args.accuracy_refines.split(",")], nd=1)
        return 0
    backends = [linalg.check_backend(b) for b in args.backends.split(",")]
    t = time.perf_counter()
    mesh = blisk_mesh(args.refine)
    print(f"blisk sector, size factor {args.refine:g}: {len(mesh.points)} nodes, "
          f"{len(mesh.tetrahedra)} tets, meshed in {time.perf_counter() - t:.2f} s")
    nds = [int(x) for x in args.nds.split(",")]
    bench_reduction(mesh, nds, args.modes, backends, args.order)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
