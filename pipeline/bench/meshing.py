"""Meshing benchmark: nodes, tets and meshing time per model over a mesh-size factor sweep.

    microslip bench mesh [--factors 2 1.5 1 0.75 0.5] [--repeats 3]

A factor f multiplies every tet size of the model's defaults and divides the contact
grid spacing (n -> round((n - 1) / f) + 1 nodes per direction), so f < 1 is finer.
Time = median wall time of ``--repeats`` complete builds (Gmsh session, CAD, meshing,
extraction and validation of the Mesh). Goal: default blisk sector + damper < 10 s.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import replace

from microslip.geometry.blisk import BliskParameters, blisk_sector
from microslip.geometry.mesh import Mesh
from microslip.geometry.quality import sicn
from microslip.geometry.root_joint import RootJointParameters, root_joint

SIZE_FIELDS = ("size", "blade_size")
GRID_FIELDS = ("contact_n_axial", "contact_n_flank")


def scaled(params, factor: float):
    """Parameters with every size multiplied by ``factor`` and grids refined by 1/factor."""
    sizes = {k: getattr(params, k) * factor for k in SIZE_FIELDS}
    grids = {k: max(2, round((getattr(params, k) - 1) / factor) + 1) for k in GRID_FIELDS}
    return replace(params, **sizes, **grids)


MODELS: dict[str, tuple[Callable[..., Mesh], object]] = {
    "blisk_sector": (blisk_sector, BliskParameters()),
    "root_joint": (root_joint, RootJointParameters()),
}


def time_build(build: Callable[[], Mesh], repeats: int) -> tuple[Mesh, float]:
    """(last mesh, median wall time in s) of ``repeats`` builds."""
    times, mesh = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        mesh = build()
        times.append(time.perf_counter() - t0)
    return mesh, statistics.median(times)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="microslip bench mesh",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("--factors", type=float, nargs="+", default=[2.0, 1.5, 1.0, 0.75, 0.5])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS))
    args = ap.parse_args(argv)
    if args.repeats < 1:
        ap.error("--repeats must be >= 1")
    header = (f"{'model':<14}{'factor':>7}{'grid':>8}{'nodes':>9}{'tets':>9}"
              f"{'min SICN':>10}{'time [s]':>10}")
    print(header)
    print("-" * len(header))
    for name in args.models:
        build, defaults = MODELS[name]
        for f in args.factors:
            p = scaled(defaults, f)
            mesh, t = time_build(lambda p=p, build=build: build(p), args.repeats)
            grid = f"{p.contact_n_axial}x{p.contact_n_flank}"
            q = sicn(mesh.points, mesh.tetrahedra).min()
            print(f"{name:<14}{f:>7.2f}{grid:>8}{len(mesh.points):>9}"
                  f"{len(mesh.tetrahedra):>9}{q:>10.3f}{t:>10.2f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
