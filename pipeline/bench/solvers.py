"""Every shipped case solved both ways, its Newton steps by dense LUs and by the structured
Jacobian (``[solver] jacobian``), and the two results files compared number by number.

    microslip bench solvers                                   # every case in cases/
    microslip bench solvers cases/blisk_quick.toml --rtol 1e-8

Per case, in this process at one BLAS thread: both runs from scratch (the shared mesh and
reduction cache serve both), their times, and per results file the datasets that differ by
more than --rtol of their largest entry (``microslip compare``), each with its largest
relative difference; curves that took a different number of points are named as such. Not
compared: the case text and hash (the key that differs) and the final residual norms.
Exit 0 when every case agrees, 1 otherwise.
"""

from __future__ import annotations

import argparse
import copy
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

#: What is not compared: the case's text and hash (they differ by the [solver] jacobian
#: key) and the final residual norms (below the tolerance, both runs' are rounding).
NOT_COMPARED = ("@case_hash", "/case@json", "/residual")
#: The cases a plain ``bench solvers`` runs: every shipped one (the folder of the repository).
CASES = Path(__file__).resolve().parents[2] / "cases"


def run_with(path: Path, jacobian: str, out: Path) -> float:
    """Seconds to run the case at ``path`` with ``[solver] jacobian`` set, into ``out``."""
    from microslip.pipeline.app.run import run_case
    from microslip.pipeline.case.file import load
    from microslip.pipeline.case.validated import Case

    case = load(path)
    data = copy.deepcopy(case.data)
    data.setdefault("solver", {})["jacobian"] = jacobian
    t0 = time.perf_counter()
    run_case(Case(data, case.source, case.renamed), out, progress=lambda *a, **k: None,
             cache=False)
    return time.perf_counter() - t0


def largest_differences(old: Path, new: Path) -> dict[str, float | str]:
    """Per numeric dataset present in both files: max |new - old| / max |old| (0 where
    old is all zero and new equal), or a text where the shapes differ."""
    out: dict[str, float | str] = {}

    def visit(name, a):
        if not isinstance(a, h5py.Dataset) or name not in fb:
            return
        b = fb[name]
        if a.dtype.kind not in "fiuc" or b.dtype.kind not in "fiuc":
            return
        x, y = np.asarray(a[()], dtype=complex), np.asarray(b[()], dtype=complex)
        if x.shape != y.shape:
            out[name] = f"shape {x.shape} -> {y.shape}"
            return
        if not np.array_equal(np.isnan(x), np.isnan(y)):
            out[name] = "NaN in other places"
            return
        x, y = x[~np.isnan(x)], y[~np.isnan(y)]  # NaN: 'not defined there' in both
        scale = float(np.max(np.abs(x))) if x.size else 0.0
        diff = float(np.max(np.abs(y - x))) if x.size else 0.0
        out[name] = diff / scale if scale > 0 else (0.0 if diff == 0 else np.inf)

    with h5py.File(old / "results.h5", "r") as fa, h5py.File(new / "results.h5", "r") as fb:
        fa.visititems(visit)
    return out


def compare_case(path: Path, rtol: float) -> tuple[bool, list[str]]:
    """(whether the two runs agree to rtol, the lines to print)."""
    from microslip.pipeline.results.compare import differences

    with tempfile.TemporaryDirectory() as tmp:
        dense, structured = Path(tmp) / "dense", Path(tmp) / "structured"
        t_dense = run_with(path, "dense", dense)
        t_struct = run_with(path, "structured", structured)
        found = [d for d in differences(dense, structured, rtol)
                 if not d.added and not d.path.endswith(NOT_COMPARED)]
        largest = largest_differences(dense, structured)
    numeric = {k: v for k, v in largest.items()
               if isinstance(v, float) and not ("/" + k).endswith(NOT_COMPARED)}
    worst = max(numeric, key=numeric.get, default="")
    at = f"{numeric[worst]:.1e} ({worst})" if worst else "0"
    lines = [f"{path.stem}: dense {t_dense:.1f} s, structured {t_struct:.1f} s; "
             f"{len(numeric)} numeric datasets, largest relative difference {at}; "
             f"{len(found)} differ by more than {rtol:g}"]
    for d in found[:20]:
        lines.append(f"  {d.path}: {d.what}")
    if len(found) > 20:
        lines.append(f"  ... and {len(found) - 20} more")
    return not found, lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="microslip bench solvers", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("cases", type=Path, nargs="*",
                        help="case files (default: every case in cases/)")
    parser.add_argument("--rtol", type=float, default=1e-8,
                        help="tolerance relative to each dataset's largest entry")
    args = parser.parse_args(argv)
    from threadpoolctl import threadpool_limits

    paths = args.cases or sorted(CASES.glob("*.toml"))
    ok = True
    with threadpool_limits(1):
        for path in paths:
            agree, lines = compare_case(path, args.rtol)
            ok &= agree
            print("\n".join(lines), flush=True)
    return 0 if ok else 1
