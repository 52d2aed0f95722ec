"""Every shipped case solved both ways, its Newton steps by dense LUs and by the structured
Jacobian (``[solver] jacobian``), and the two results files compared number by number.

    microslip bench solvers                                   # every case in cases/
    microslip bench solvers cases/11_blisk_quick.toml --rtol 1e-8

Per case, in this process at one BLAS thread: both runs from scratch (the shared mesh and
reduction cache serve both), their times, and per group of datasets the largest difference
relative to the dataset's largest entry (and that entry): the solutions (parameter values,
responses, unknowns), the stability verdicts, the located bifurcations, the Floquet
multipliers, the rest (contact maps, dissipation...); curves that took a different number
of points are named as such. Not compared: the case text and hash (the key that differs)
and the final residual norms (both below the tolerance: rounding). Exit 0 when the
solutions and verdicts of every case agree to --rtol and the same bifurcations are found, 1
otherwise (Floquet
multipliers and the rest are printed: where a contact changes state at a sample, the
sampled law's Jacobian, and with it a multiplier, jumps for a change of the solution at
the tolerance; a quantity that is zero to rounding, the dissipation of a stuck contact,
has no relative difference).
"""

from __future__ import annotations

import argparse
import copy
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

#: What is not compared: the case's text and hash (they differ by the [solver] jacobian
#: key) and the final residual norms (below the tolerance, both runs' are rounding).
NOT_COMPARED = ("@case_hash", "/case@json", "/residual")
#: The datasets that are a branch's solutions: the parameter, the responses, the unknowns.
SOLUTIONS = {"omega", "parameter", "amplitude", "response", "coefficients", "unknowns",
             "values", "peak", "peak_omega"}
#: The cases a plain ``bench solvers`` runs: every shipped one (the folder of the repository).
CASES = Path(__file__).resolve().parents[2] / "cases"


def run_with(path: Path, jacobian: str, out: Path) -> float:
    """Seconds to run the case at ``path`` with ``[solver] jacobian`` set, into ``out``."""
    from microslip.app.run import run_case
    from microslip.case.loading import load
    from microslip.case.validated import Case

    case = load(path)
    data = copy.deepcopy(case.data)
    data.setdefault("solver", {})["jacobian"] = jacobian
    t0 = time.perf_counter()
    run_case(Case(data, case.source, case.renamed), out, progress=lambda *a, **k: None,
             cache=False)
    return time.perf_counter() - t0


def largest_differences(old: Path, new: Path) -> dict[str, tuple[float | str, float]]:
    """Per numeric dataset present in both files: (max |new - old| / max |old| (0 where old
    is all zero and new equal), or a text where the shapes or the NaNs differ; max |old|)."""
    out: dict[str, tuple[float | str, float]] = {}

    def visit(name, a):
        if not isinstance(a, h5py.Dataset) or name not in fb:
            return
        b = fb[name]
        if a.dtype.kind not in "fiucb" or b.dtype.kind not in "fiucb":
            return
        x, y = np.asarray(a[()], dtype=complex), np.asarray(b[()], dtype=complex)
        if x.shape != y.shape:
            out[name] = (f"shape {x.shape} -> {y.shape}", np.nan)
            return
        if not np.array_equal(np.isnan(x), np.isnan(y)):
            out[name] = ("NaN in other places", np.nan)
            return
        x, y = x[~np.isnan(x)], y[~np.isnan(y)]  # NaN: 'not defined there' in both
        scale = float(np.max(np.abs(x))) if x.size else 0.0
        diff = float(np.max(np.abs(y - x))) if x.size else 0.0
        out[name] = (diff / scale if scale > 0 else (0.0 if diff == 0 else np.inf), scale)

    with h5py.File(old / "results.h5", "r") as fa, h5py.File(new / "results.h5", "r") as fb:
        fa.visititems(visit)
    return out


def peak_differences(old: Path, new: Path) -> list[str]:
    """Per curve whose two runs took different numbers of points (a step path that parted
    at a different iteration count): its peak, the largest amplitude and the parameter
    value there, in both, relative. A text per such curve."""
    out = []

    def visit(name, a):
        if not (isinstance(a, h5py.Group) and "amplitude" in a and name in fb):
            return
        b = fb[name]
        if "amplitude" not in b or a["amplitude"].shape == b["amplitude"].shape:
            return
        key = "omega" if "omega" in a else "parameter"
        if key not in a or key not in b:
            return
        peaks = []
        for g in (a, b):
            amp = np.max(np.abs(g["amplitude"][()]), axis=tuple(range(1, g["amplitude"].ndim)))
            i = int(np.argmax(amp))
            peaks.append((float(amp[i]), float(g[key][()][i])))
        (a0, w0), (a1, w1) = peaks
        out.append(f"{name}: {a['amplitude'].shape[0]} and {b['amplitude'].shape[0]} points; "
                   f"peak {a0:.6g} at {w0:.8g} and {a1:.6g} at {w1:.8g} (differences "
                   f"{abs(a1 - a0) / abs(a0):.1e}, {abs(w1 - w0) / abs(w0):.1e}; the sampled "
                   "peaks of two point sets, not the refined one)")

    with h5py.File(old / "results.h5", "r") as fa, h5py.File(new / "results.h5", "r") as fb:
        fa.visititems(visit)
    return out


def _kind(name: str) -> str:
    """Which group of the summary a dataset belongs to."""
    parts = name.split("/")
    if "bifurcations" in parts:
        return "bifurcations"
    return {"stable": "verdicts", "floquet": "floquet"}.get(
        parts[-1], "solutions" if parts[-1] in SOLUTIONS else "other")


def compare_case(path: Path, rtol: float) -> tuple[bool, list[str]]:
    """(whether the two runs' solutions, verdicts and bifurcations agree to rtol, the lines
    to print)."""
    with tempfile.TemporaryDirectory() as tmp:
        dense, structured = Path(tmp) / "dense", Path(tmp) / "structured"
        t_dense = run_with(path, "dense", dense)
        t_struct = run_with(path, "structured", structured)
        largest = {k: v for k, v in largest_differences(dense, structured).items()
                   if not ("/" + k).endswith(NOT_COMPARED)}
        peaks = peak_differences(dense, structured)
    groups: dict[str, list[tuple[str, float | str, float]]] = {}
    for name, (rel, scale) in largest.items():
        groups.setdefault(_kind(name), []).append((name, rel, scale))

    def worst(kind):
        rows = groups.get(kind, [])
        texts = [r for r in rows if isinstance(r[1], str)]
        if texts:
            return texts[0], False
        top = max(rows, key=lambda r: r[1], default=None)
        return top, top is None or top[1] <= rtol

    lines = [f"{path.stem}: dense {t_dense:.1f} s, structured {t_struct:.1f} s"]
    ok = True
    for kind in ("solutions", "verdicts", "bifurcations", "floquet", "other"):
        top, agree = worst(kind)
        if top is None:
            continue
        # located bifurcations: the same ones (a count or shape differing fails); where
        # they lie is found to a fraction of a step (bifurcation.LOCATED), not to rtol
        ok &= agree or kind in ("floquet", "other") or (
            kind == "bifurcations" and not isinstance(top[1], str))
        size = top[1] if isinstance(top[1], str) else f"{top[1]:.1e}"
        lines.append(f"  {kind:12s} {len(groups[kind]):4d} datasets, largest difference "
                     f"{size} of max |old| = {top[2]:.3g} ({top[0]})")
    lines += [f"  {p}" for p in peaks]
    return ok, lines


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
    if not paths:  # (an installed wheel holds no cases/)
        print(f"microslip bench solvers: no case given, and none in {CASES} (the shipped "
              "cases are read from the source checkout): name case files", file=sys.stderr)
        return 2
    ok = True
    with threadpool_limits(1):
        for path in paths:
            agree, lines = compare_case(path, args.rtol)
            ok &= agree
            print("\n".join(lines), flush=True)
    return 0 if ok else 1
