"""Element shapes and orders against a converged cantilever: frequency error, DOFs, time.

    microslip bench elements [--repeats 3]

The 1 x 0.1 x 0.1 m steel cantilever (clamped at x = 0) on structured grids of
hexahedra, wedges (each cell split in two) and tetrahedra (each cell in six), linear and
quadratic (``geometry.structured``). The reference is the quadratic hexahedra on the
finest grid; the table gives, per shape, order and grid, the DOFs, the median time to
assemble K and M over ``--repeats`` runs, and the relative error of the first four
frequencies (two bendings, torsion, the next bending). Every shape is scikit-fem's element
(the 15-node wedge is ours), so this is what each shape costs in accuracy per DOF on the
same geometry, not the price of a substitute element.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Sequence

import numpy as np

from microslip.fe import eigen, fem
from microslip.geometry.structured import block

STEEL = fem.Material(2.0e11, 0.3, 7850.0)
GRIDS = ((10, 1, 1), (20, 2, 2), (40, 4, 4))
REFERENCE_GRID = (80, 8, 8)
MODES = 4


def frequencies(shape: str, order: int, cells: tuple[int, int, int], repeats: int = 1
                ) -> tuple[np.ndarray, int, float]:
    """(first MODES frequencies [Hz], free DOFs, median assembly time [s]) of the cantilever."""
    mesh = block(shape, cells=cells)
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        body = fem.assemble(mesh, "block", STEEL, order)
        times.append(time.perf_counter() - t)
    clamp = body.set_dofs(mesh.node_sets["block/clamp"])
    free = np.setdiff1d(np.arange(body.n_dofs), clamp)
    K = body.stiffness[free][:, free].tocsc()
    M = body.mass[free][:, free].tocsc()
    lam, _ = eigen.lowest_modes(K, M, MODES)
    return np.sqrt(lam) / (2 * np.pi), len(free), statistics.median(times)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="microslip bench elements", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=3, help="assemblies timed per row")
    args = ap.parse_args(argv)
    if args.repeats < 1:
        ap.error(f"--repeats = {args.repeats}: expected an integer >= 1")
    ref, n_ref, _ = frequencies("hexahedron", 2, REFERENCE_GRID)
    print(f"reference: quadratic hexahedra on {REFERENCE_GRID} cells, {n_ref} DOFs; f [Hz] "
          + " ".join(f"{f:.2f}" for f in ref))
    head = f"{'shape':>11} {'order':>5} {'grid':>12} {'DOFs':>7} {'assembly':>9}  " + "  ".join(
        f"{'err f' + str(i + 1):>9}" for i in range(MODES))
    print(head)
    for shape in ("hexahedron", "wedge", "tetra"):
        for order in (1, 2):
            for cells in GRIDS:
                f, n, t = frequencies(shape, order, cells, args.repeats)
                err = "  ".join(f"{100 * e:8.3f}%" for e in f / ref - 1.0)
                print(f"{shape:>11} {order:>5} {str(cells):>12} {n:>7} {t:>8.3f}s  {err}",
                      flush=True)
    return 0
