"""Mesh convergence of a full-scale case's linear limits, then its contact grid's own effect
at a converged mesh.

    microslip bench convergence                                  # blisk + dampers, ND 12
    microslip bench convergence --case cases/14_blade_root_joint.toml --start 1980 --stop 2060
    microslip bench convergence --factors 2 1.41 1 0.71 --grids 6x2 9x4 12x6 --out conv/

Mesh levels (of the case's mesh, with ``REFINED``'s knobs where the case leaves them at the
model's defaults): every element size of the case's geometry (``size``, ``blade_size``, the
contact faces' ``contact_size``) times a factor and every element count (``blade_layers``)
over it, the contact grid and the blade root's grading (``root_size``: the sharp corner's
singularity, converged on its own) held (each contact point
the average of its cell of the contact face's mesh, so refining the mesh does not refine
the grid). Per level, cold, in a fresh process: mesh, reduction, coupling, the free and
fully stuck linear peaks (their frequencies: the linear model) and the friction FRF's peak.
From the three finest levels (a constant factor r between them) Richardson's extrapolation
gives the observed order p = ln((w3 - w2) / (w2 - w1)) / ln r and the limit w1 + (w1 - w2) /
(r^p - 1) of each frequency; every level's error is printed against that limit, with the
half-power bandwidth 2 zeta w of the stuck peak as the yardstick.

Grid levels (``--grids``): at the mesh level ``--grid-factor``, the contact grid alone
varied: the stuck and friction peaks' changes against the finest grid.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from .trade import SIZES, check_window, cold, scaled_mesh, stop_with_signals

#: Element size of the contact faces at factor 1 [m], where the case gives none: finer
#: than the grid (2 x 36 points: cells 2.7 x 1.4 mm on the blisk's flanks).
CONTACT_SIZE = 0.002
#: The mesh the study refines, per model, where the case leaves a knob at the model's
#: default: the blade in prism layers (2 cells through its 4-5 mm at factor 1); on the
#: blisk a 1.5 mm root fillet meshed at 0.25 mm, on the root joint the sharp root's edges
#: graded to 0.125 mm (both held: measured on their own in the README)
REFINED = {
    "blisk_sector": {"blade_layers": 20, "blade_size": 0.002, "root_fillet": 0.0015,
                     "root_size": 0.00025},
    "root_joint": {"blade_layers": 20, "blade_size": 0.002, "root_size": 0.000125},
}
FACTORS = (2.0, math.sqrt(2.0), 1.0, math.sqrt(0.5), 0.5)
GRIDS = ("6x2", "9x4", "12x6", "18x8")
GRID = ("contact_n_axial", "contact_n_flank")
#: How far the two ratios of the three finest sizes may differ (factors typed as 1.41 and
#: 0.71 for sqrt 2 and its inverse: 0.3 %; the extrapolation's error from it is of that
#: order times the last change, far below what it extrapolates)
RATIO_TOL = 1e-2


def level_data(base: dict, factor: float, grid: tuple[int, int] | None, start: float,
               stop: float, contact_size: float) -> dict:
    """The case's table with every element size times ``factor`` (the contact faces'
    included), the grid ``grid`` (None: the case's), one FRF over start..stop."""
    data = copy.deepcopy(base)
    params = data["geometry"].setdefault("parameters", {})
    from microslip.geometry import PARAMETERS

    for name, value in REFINED.get(data["geometry"]["model"], {}).items():
        params.setdefault(name, value)
    scaled_mesh(data, factor, contact_size)
    if grid is None:
        defaults = PARAMETERS[data["geometry"]["model"]]()
        grid = tuple(params.get(k, getattr(defaults, k)) for k in GRID)
    params["contact_n_axial"], params["contact_n_flank"] = grid
    output = data["assembly"]["outputs"][0]["name"]
    data["analysis"] = [{"name": "frf", "type": "frf", "start": start, "stop": stop,
                         "outputs": [output], "measure": "vibration"}]
    return data


def richardson(h: np.ndarray, w: np.ndarray) -> tuple[float, float]:
    """(observed order p, extrapolated limit) from the three smallest sizes ``h`` (n,) and
    their values ``w`` (n,), the sizes in a constant ratio; (nan, nan) where the changes do
    not shrink monotonically (not yet in the asymptotic range)."""
    order = np.argsort(h)[:3]
    (h1, h2, h3), (w1, w2, w3) = h[order], w[order]
    r = h2 / h1
    if not np.isclose(h3 / h2, r, rtol=RATIO_TOL):
        raise ValueError("richardson: the three finest sizes must be in a constant ratio")
    d21, d32 = w2 - w1, w3 - w2
    if d21 == 0.0 or d32 / d21 <= 1.0:
        return float("nan"), float("nan")
    p = math.log(d32 / d21) / math.log(r)
    return p, w1 - d21 / (r**p - 1.0)


def mesh_table(rows: list[dict], limits: dict, zeta: float) -> str:
    """Markdown: per level its sizes, vertices, the three frequencies and their errors
    against the extrapolated limits (in % and in half-power bandwidths of the stuck peak)."""
    band = 2.0 * zeta * limits["stuck"][1]
    lines = ["| factor | size / blade / contact [mm] | vertices | free [rad/s] | error "
             "| stuck [rad/s] | error | error / bandwidth | friction peak [rad/s] | error "
             "| model [s] | memory [MB] |", "|" + "---|" * 12]
    for r in rows:
        s = r["sizes"]
        err = {k: 100.0 * (r[k] - limits[k][1]) / limits[k][1] for k in ("free", "stuck",
                                                                          "omega")}
        lines.append(
            f"| {r['factor']:.3g} | {' / '.join(f'{1e3 * v:.2f}' for v in s)} "
            f"| {r['nodes']} | {r['free']:.2f} | {err['free']:+.3f} % | {r['stuck']:.2f} | "
            f"{err['stuck']:+.3f} % | {(r['stuck'] - limits['stuck'][1]) / band:+.2f} | "
            f"{r['omega']:.2f} | {err['omega']:+.3f} % | {r['model_s']:.0f} | "
            f"{r['memory_mb']:.0f} |")
    lines.append("| limit (Richardson; nan: a peak on the window's edge, or changes not "
                 "shrinking) | | | " + " | ".join(
        f"{limits[k][1]:.2f} (p = {limits[k][0]:.2f}) | " for k in ("free", "stuck"))
        + f"| {limits['omega'][1]:.2f} (p = {limits['omega'][0]:.2f}) | | | |")
    return "\n".join(lines)


def grid_table(rows: list[dict]) -> str:
    """Markdown: per grid the stuck and friction peaks and their changes against the
    finest grid (the last row)."""
    ref = rows[-1]
    lines = ["| grid per flank | points | unknowns | stuck [rad/s] | change | friction peak "
             "[rad/s] | change | peak [mm] | change | FRF [s] |", "|" + "---|" * 10]
    for r in rows:
        lines.append(
            f"| {r['grid']} | {r['points_per_flank']} | {r['unknowns']} | {r['stuck']:.2f} | "
            f"{r['stuck'] - ref['stuck']:+.2f} | {r['omega']:.2f} | "
            f"{r['omega'] - ref['omega']:+.2f} | {1e3 * r['amplitude']:.4f} | "
            f"{100 * (r['amplitude'] / ref['amplitude'] - 1):+.2f} % | {r['frf_s']:.0f} |")
    return "\n".join(lines)


def _inside(omega: float, data: dict) -> float:
    """A peak frequency, or NaN where it sits within a hundredth of the FRF window of its
    edge (the linear peaks' search grid: the peak lies outside, or there is none, as the
    root joint's blade without its contacts, held by nothing: widen --start/--stop)."""
    a = data["analysis"][0]
    edge = min(abs(omega - a["start"]), abs(omega - a["stop"]))
    return float("nan") if edge < 0.01 * (a["stop"] - a["start"]) else omega


def _summary(r: dict, factor: float, data: dict) -> dict:
    p = data["geometry"]["parameters"]
    return {"factor": factor, "sizes": [p.get(k, 0.0) for k in SIZES], "nodes": r["nodes"],
            "free": _inside(r["free"][0], data), "stuck": _inside(r["stuck"][0], data),
            "omega": _inside(r["omega"], data),
            "amplitude": r["amplitude"], "unknowns": r["unknowns"], "status": r["status"],
            "model_s": r["mesh_s"] + r["reduction_s"] + r["coupling_s"], "frf_s": r["frf_s"],
            "memory_mb": r["memory_mb"],
            "grid": f"{p['contact_n_axial']}x{p['contact_n_flank']}",
            "points_per_flank": p["contact_n_axial"] * p["contact_n_flank"]}


def _grid(text: str) -> tuple[int, int]:
    a, _, b = text.partition("x")
    if not (a.isdigit() and b.isdigit() and int(a) >= 2 and int(b) >= 2):
        raise ValueError(f"--grids: {text!r} is not N1xN2 with N1, N2 >= 2")
    return int(a), int(b)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="microslip bench convergence", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--case", type=Path, default=Path("cases/15_blisk_damper.toml"))
    parser.add_argument("--start", type=float, default=3100.0, help="FRF start [rad/s]")
    parser.add_argument("--stop", type=float, default=3180.0, help="FRF stop [rad/s]")
    parser.add_argument("--factors", type=float, nargs="+", default=list(FACTORS),
                        help="element-size factors, coarse to fine (the three finest in a "
                             "constant ratio)")
    parser.add_argument("--contact-size", type=float, default=CONTACT_SIZE,
                        help="contact faces' element size at factor 1 where the case gives "
                             "none [m]")
    parser.add_argument("--grids", nargs="*", default=list(GRIDS),
                        help="contact grids per face, coarse to fine (none: no grid study)")
    parser.add_argument("--grid-factor", type=float, default=None,
                        help="the mesh level of the grid study (default: the finest)")
    parser.add_argument("--out", type=Path, default=None, help="folder for convergence.json")
    args = parser.parse_args(argv)
    from microslip.case import CaseError, check, load

    try:
        check_window(args.start, args.stop)
        grids = [_grid(g) for g in args.grids]
        factors = sorted(args.factors, reverse=True)
        if len(factors) < 3 or min(factors) <= 0:
            raise ValueError("--factors: three or more positive factors")
        f1, f2, f3 = factors[-1], factors[-2], factors[-3]
        if not np.isclose(f3 / f2, f2 / f1, rtol=RATIO_TOL):
            raise ValueError(f"--factors: the three finest ({f3:g}, {f2:g}, {f1:g}) must be in "
                             f"a constant ratio (within {RATIO_TOL:.0%}) for Richardson's "
                             "extrapolation")
        base = load(args.case).data
        zeta = float(np.atleast_1d(base["reduction"].get("damping", {}).get(
            "modal_ratios", 0.001))[0])
        meshes = [level_data(base, f, None, args.start, args.stop, args.contact_size)
                  for f in factors]
        g_factor = min(factors) if args.grid_factor is None else args.grid_factor
        grid_runs = [level_data(base, g_factor, g, args.start, args.stop, args.contact_size)
                     for g in grids]
        for d in meshes + grid_runs:
            check(d, str(args.case))
    except (ValueError, CaseError) as err:
        print(f"microslip bench convergence: {err}", file=sys.stderr)
        return 2
    print(f"{args.case}: {len(meshes)} mesh levels, then {len(grids)} grids at factor "
          f"{g_factor:g}; each cold in its own process", flush=True)
    stop_with_signals()
    rows, t0 = [], time.perf_counter()
    for k, (f, data) in enumerate(zip(factors, meshes)):
        rows.append(_summary(cold(data, str(args.case)), f, data))
        r = rows[-1]
        print(f"[mesh {k + 1}/{len(meshes)}] factor {f:.3g}: {r['nodes']} vertices, free "
              f"{r['free']:.2f}, stuck {r['stuck']:.2f}, friction peak {r['omega']:.2f} "
              f"rad/s ({r['status']}); model {r['model_s']:.0f} s, "
              f"{time.perf_counter() - t0:.0f} s so far", flush=True)
    h = np.array([r["sizes"][0] for r in rows])
    limits = {k: richardson(h, np.array([r[k] for r in rows])) for k in ("free", "stuck",
                                                                         "omega")}
    print("\nmesh convergence (grid held):")
    print(mesh_table(rows, limits, zeta))
    grid_rows = []
    for g, data in zip(grids, grid_runs):
        grid_rows.append(_summary(cold(data, str(args.case)), g_factor, data))
        print(f"[grid {g[0]}x{g[1]}] stuck {grid_rows[-1]['stuck']:.2f}, friction peak "
              f"{grid_rows[-1]['omega']:.2f} rad/s", flush=True)
    if grid_rows:
        print(f"\ncontact grid at mesh factor {g_factor:g}:")
        print(grid_table(grid_rows))
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "convergence.json").write_text(json.dumps(
            {"mesh": rows, "limits": limits, "grids": grid_rows}, indent=1))
    return 0 if all(r["status"] == "complete" for r in rows + grid_rows) else 1
