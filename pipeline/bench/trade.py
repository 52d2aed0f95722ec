"""Speed against accuracy at full scale: what each knob of the blisk-damper case buys and
costs. The knobs: contact grid per damper flank, harmonics, fixed-interface modes kept per
body, mesh size.

    microslip bench trade                       # every setting of SETTINGS (~1 h)
    microslip bench trade --only mesh-2,quick   # some of them
    microslip bench trade --out trade/          # also trade.json and trade.png

Each setting runs cold in a fresh process: mesh, Craig-Bampton reduction of every body and
nodal diameter, coupling, and one arclength FRF of the blade tip over --start..--stop at
the case's damper mass. The peak is refined by Brent's method, as the case's peak maps are.
Printed per setting:
- the peak frequency and vibration amplitude, their change against the finest setting, and
  the FRF error (below);
- the change of the fully stuck peak's frequency (the linear model's share: mesh, modes)
  and of the peak over the stuck peak (the friction's share: contact grid, harmonics), each
  against the finest setting;
- the time of the model (mesh + reduction + coupling) and of the FRF, their sum, and the
  peak memory of its process.
A design sweep pays the FRF time once per value, the model time once.

The FRF error is the largest difference between a setting's FRF and the finest one's over
the range, in % of the finest peak: it counts a shifted peak as well as a lower one. The
PNG plots it against the total time, one marker per setting, with the Pareto front: the
settings that no other setting beats in both.
"""

from __future__ import annotations

import argparse
import copy
import json
import multiprocessing
import resource
import signal
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from .assembly_scale import unknowns

#: The element sizes a mesh factor scales, and the element counts it divides (the blade
#: root's grading, ``root_size``, is the sharp corner's own knob: held, its convergence
#: measured on its own)
SIZES = ("size", "blade_size", "contact_size")
COUNTS = ("blade_layers",)


@dataclass(frozen=True)
class Setting:
    """One combination of the knobs.

    grid: contact points per flank (axial, along the flank); harmonics: highest order H
    (orders 0..H, static included); modes: fixed-interface modes per body ("auto": every
    one below 4x the 10th); mesh: the factor of every element size of the case's mesh (1:
    the case's, converged; 2: twice as coarse), the contact grid apart from it."""

    name: str
    grid: tuple[int, int]
    harmonics: int
    modes: str | int
    mesh: float

    @property
    def pairs(self) -> int:
        """Node pairs per flank."""
        return self.grid[0] * self.grid[1]

    def describe(self) -> str:
        return (f"2x{self.pairs} points, H 0-{self.harmonics}, modes {self.modes}, "
                f"mesh x{self.mesh:g}")


# The finest setting first: every other is measured against it. The grids and H of the case
# around it one at a time on the case's (converged) mesh, then the modes, then the mesh
# alone at the case's grid and H, then the cheap corners (the README's quick case: the mesh
# twice as coarse, 2 x 12 points).
SETTINGS = (
    Setting("finest", (12, 6), 3, "auto", 1.0),
    Setting("grid-72-H1", (12, 6), 1, "auto", 1.0),
    Setting("grid-36-H3", (9, 4), 3, "auto", 1.0),
    Setting("case", (9, 4), 1, "auto", 1.0),
    Setting("grid-12-H3", (6, 2), 3, "auto", 1.0),
    Setting("grid-12-H1", (6, 2), 1, "auto", 1.0),
    Setting("modes-20", (9, 4), 1, 20, 1.0),
    Setting("modes-8", (9, 4), 1, 8, 1.0),
    Setting("mesh-1.4", (9, 4), 1, "auto", 1.41),
    Setting("mesh-2", (9, 4), 1, "auto", 2.0),
    Setting("quick", (6, 2), 1, "auto", 2.0),
    Setting("cheapest", (6, 2), 1, 8, 2.0),
)


def scaled_mesh(data: dict, factor: float, contact_size: float = 0.0) -> None:
    """Every element size of the case's geometry parameters times ``factor`` and every
    element count over it, in place (``contact_size`` [m]: the contact faces' size at factor
    1 where the case gives none; 0: keep the grid as the mesh)."""
    from microslip.geometry import PARAMETERS

    params = data["geometry"].setdefault("parameters", {})
    defaults = PARAMETERS[data["geometry"]["model"]]()
    for name in SIZES:
        value = params.get(name, getattr(defaults, name, None))
        if name == "contact_size" and not value:
            value = contact_size
        if value:
            params[name] = value * factor
    for name in COUNTS:
        if params.get(name):
            params[name] = max(1, round(params[name] / factor))


def check_window(start: float, stop: float) -> None:
    """ValueError naming --start and --stop unless 0 < start < stop [rad/s]."""
    if not 0 < start < stop:
        raise ValueError(f"--start {start:g}, --stop {stop:g}: expected 0 < start < stop")


def case_data(base: dict, s: Setting, start: float, stop: float) -> dict:
    """The base case's table with the setting's knobs and one FRF analysis (no maps, no
    pictures: the bench reads the refined peak itself)."""
    data = copy.deepcopy(base)
    scaled_mesh(data, s.mesh)
    data["geometry"]["parameters"].update(contact_n_axial=s.grid[0], contact_n_flank=s.grid[1])
    data["reduction"]["modes"] = s.modes
    data["reduction"].pop("harmonics", None)  # the NDs follow [harmonics] max
    data["harmonics"] = {**data.get("harmonics", {}), "max": s.harmonics}
    output = data["assembly"]["outputs"][0]["name"]
    data["analysis"] = [{"name": "frf", "type": "frf", "start": start, "stop": stop,
                         "outputs": [output], "measure": "vibration"}]
    return data


def measure(data: dict, source: str) -> dict:
    """One setting, cold, in this process: times [s], peak, sizes and peak memory [MB]."""
    from microslip.app.limits import linear_peak
    from microslip.app.models import AssemblyModels
    from microslip.app.solutions import map_solutions, response_at
    from microslip.app.stages import mesh_geometry
    from microslip.app.structure import reduce_structure
    from microslip.case import (
        Case,
        harmonics,
        operating_point,
        settings,
    )
    from microslip.laws import warm_up
    from microslip.solve.response import response_measure, sweep

    def quiet(_: str) -> None:
        pass

    warm_up(quiet)  # the contact kernels load from numba's cache: not the setting's cost
    case = Case(data, source)
    spec = case.analysis_specs[0]
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        mesh = mesh_geometry(case.geometry_table, Path(tmp), quiet, pictures=False)
        t1 = time.perf_counter()
        structure = reduce_structure(mesh, data["reduction"], Path(tmp) / "models",
                                     harmonics(case).orders, quiet)
        t2 = time.perf_counter()
        models = AssemblyModels(mesh, structure)
        hb = models.model(case)
        rows = models.selection(case, list(spec.outputs))
        t3 = time.perf_counter()
        base = operating_point(case, spec.start)
        r = sweep(hb, "frequency", spec.start, spec.stop, base, settings=settings(case))
        found = map_solutions(r, ["peak"], rows, "vibration", settings(case))
        t4 = time.perf_counter()
        # the fully stuck and free linear peaks of the same model (not timed): they split
        # a setting's change into the linear model's (mesh, modes) and the friction's
        cm = models.assembly(case)
        window = (spec.start, spec.stop)
        stuck = linear_peak(cm, base, "stuck", spec.outputs[0], window, True)
        free = linear_peak(cm, base, "free", spec.outputs[0], window, True)
    omega, amplitude = float("nan"), float("nan")
    if found:
        _, omega, x = found[0]
        amplitude = float(response_at(hb, x, base.set("frequency", omega), rows,
                                       "vibration")[0])
    lam = np.append(r.values, omega) if found else r.values
    shown = response_measure(hb.harmonics, r.coefficients(rows), "vibration")[:, 0].tolist() \
        + ([amplitude] if found else [])
    modes = {body: max(m.n_modes for m in per_nd.values())
             for body, per_nd in structure.models.items()}
    return {"omega": omega, "amplitude": amplitude, "status": r.branch.status,
            "curve": [lam.tolist(), shown], "stuck": list(stuck), "free": list(free),
            "points": len(r), "unknowns": int(hb.n_unknowns), "nodes": int(mesh.points.shape[0]),
            "modes": modes, "mesh_s": t1 - t0, "reduction_s": t2 - t1, "coupling_s": t3 - t2,
            "frf_s": t4 - t3, "total_s": t4 - t0,
            "memory_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def _measured(conn, data: dict, source: str) -> None:
    """The child's side of :func:`cold`: its result or its error, through the pipe."""
    try:
        conn.send(("ok", measure(data, source)))
    except BaseException as err:  # (sent, not raised: the parent says it)
        conn.send(("error", f"{type(err).__name__}: {err}"))


def cold(data: dict, source: str) -> dict:
    """:func:`measure` in a fresh process (spawned: nothing cached from this one), ended
    with this one: Ctrl-C or SIGTERM here (``stop_with_signals``) terminates it too, and a
    child that dies (out of memory) is a RuntimeError, not a hang."""
    ctx = multiprocessing.get_context("spawn")
    here, there = ctx.Pipe(duplex=False)
    child = ctx.Process(target=_measured, args=(there, data, source), daemon=True)
    child.start()
    there.close()
    try:
        kind, value = here.recv()
    except EOFError:
        kind, value = "error", f"the setting's process ended (exit code {child.exitcode})"
    finally:
        if child.is_alive():
            child.terminate()
        child.join()
    if kind != "ok":
        raise RuntimeError(value)
    return value


def stop_with_signals() -> None:
    """SIGTERM as Ctrl-C: unwinds this process (and :func:`cold`'s child with it)."""
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))


def weight(s: Setting) -> float:
    """A setting's rough cost relative to the case's model (2 x 36 pairs, H 0-1, mesh
    factor 1): the model, falling as the mesh factor^-1.3, plus the FRF, 5 % of it at the
    case's unknowns and growing as their square (measured on the converged blisk mesh:
    model 83 s at factor 2 against 217 s; FRF 11 s at 1,296 unknowns, ~380 s at 6,048 with
    H 0-3's extra points)."""
    return s.mesh ** -1.3 + 0.05 * (unknowns(*s.grid, s.harmonics) / 1296.0) ** 2


def pareto_front(cost: np.ndarray, error: np.ndarray) -> np.ndarray:
    """Indices of the settings no other beats in both cost and error (ties kept), by cost.

    cost, error: (n,), smaller is better; NaN errors never enter the front."""
    cost, error = np.asarray(cost, float), np.asarray(error, float)
    front, best = [], np.inf
    for i in np.lexsort((error, cost)):
        if np.isfinite(error[i]) and error[i] < best:
            front.append(int(i))
            best = error[i]
    return np.array(front, dtype=int)


FRF_GRID = 2001  # frequencies on which two FRFs are compared


def frf_error(curve: list, reference: list) -> float:
    """Largest difference of two FRFs over the frequencies both cover, in % of the
    reference's peak. curve, reference: [frequencies, responses] (a single-valued branch,
    refined peak included). A shift of the peak by more than its width counts in full:
    comparing peaks alone lets a frequency error hide (and two knobs' amplitude errors
    cancel)."""
    (x, y), (xr, yr) = (np.asarray(c, float) for c in curve), (np.asarray(c, float)
                                                              for c in reference)
    lo, hi = max(x.min(), xr.min()), min(x.max(), xr.max())
    grid = np.union1d(np.linspace(lo, hi, FRF_GRID), [v for v in (*x, *xr) if lo <= v <= hi])
    i, ir = np.argsort(x), np.argsort(xr)
    diff = np.interp(grid, x[i], y[i]) - np.interp(grid, xr[ir], yr[ir])
    return 100.0 * float(np.abs(diff).max() / yr.max())


def changes(rows: list[dict], reference: dict) -> list[dict]:
    """Per row its peak frequency change [rad/s], amplitude change [%] and FRF error [%]
    (:func:`frf_error`) against the reference row (the finest setting)."""
    out = []
    for r in rows:
        d_omega = r["omega"] - reference["omega"]
        d_amp = 100.0 * (r["amplitude"] / reference["amplitude"] - 1.0)
        ratio = r["amplitude"] / r["stuck"][1]  # the friction's share: on its own model
        out.append({"d_omega": d_omega, "d_amplitude_pct": d_amp,
                    "frf_error_pct": frf_error(r["curve"], reference["curve"]),
                    "d_stuck_omega": r["stuck"][0] - reference["stuck"][0],
                    "d_ratio_pct": 100.0 * (ratio / (reference["amplitude"]
                                                     / reference["stuck"][1]) - 1.0)})
    return out


def table(rows: list[dict]) -> str:
    """The trade table as Markdown (rows: measure() results with their setting and change)."""
    lines = ["| setting | grid | H | modes (blisk/damper) | mesh | unknowns | peak [rad/s] "
             "| change | peak [mm] | change | FRF error | stuck peak: change [rad/s] "
             "| peak / stuck: change | model [s] | FRF [s] | total [s] | memory [MB] |",
             "|" + "---|" * 17]
    for r in rows:
        s = r["setting"]
        modes = "/".join(str(r["modes"][b]) for b in sorted(r["modes"]))
        model_s = r["mesh_s"] + r["reduction_s"] + r["coupling_s"]
        lines.append(
            f"| {s['name']} | 2x{s['grid'][0] * s['grid'][1]} | 0-{s['harmonics']} | "
            f"{s['modes']} ({modes}) | x{s['mesh']:g} ({r['nodes']} vertices) | {r['unknowns']} | "
            f"{r['omega']:.2f} | {r['d_omega']:+.2f} | {1e3 * r['amplitude']:.4f} | "
            f"{r['d_amplitude_pct']:+.2f} % | {r['frf_error_pct']:.1f} % | "
            f"{r['d_stuck_omega']:+.2f} | {r['d_ratio_pct']:+.2f} % | "
            f"{model_s:.0f} | {r['frf_s']:.0f} | "
            f"{r['total_s']:.0f} | {r['memory_mb']:.0f} |")
    return "\n".join(lines)


def picture(rows: list[dict], path: Path) -> Path:
    """Amplitude error [%] against total time [s], one marker per setting, Pareto front."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FormatStrFormatter

    t = np.array([r["total_s"] for r in rows])
    err = np.array([r["frf_error_pct"] for r in rows])
    positive = err[err > 0]
    floor = positive.min() / 3 if positive.size else 1.0
    shown = np.where(err > 0, err, floor)  # the reference (0 %) on the log axis' floor
    fig, ax = plt.subplots(figsize=(8.0, 5.5), dpi=120)
    rank = np.argsort(np.argsort(t))  # neighbours in time get labels above and below
    for k, (r, x, y) in enumerate(zip(rows, t, shown)):
        s = r["setting"]
        marker = "o" if s["harmonics"] == 1 else "s"
        colour = "tab:blue" if s["mesh"] == 1.0 else "tab:orange"
        name = s["name"] + (" (the reference: 0 %)" if err[k] == 0 else "")
        ax.scatter(x, y, marker="*" if err[k] == 0 else marker, s=90 if err[k] == 0 else 36,
                   color=colour, zorder=3)
        ax.annotate(name, (x, y), textcoords="offset points", fontsize=8,
                    xytext=(5, 4) if rank[k] % 2 == 0 else (5, -11))
    front = pareto_front(t, err)
    ax.plot(t[front], shown[front], "k--", lw=1, label="Pareto front", zorder=2)
    for marker, label in (("o", "H 0-1"), ("s", "H 0-3")):
        ax.scatter([], [], marker=marker, color="grey", label=label)
    for colour, label in (("tab:blue", "the case's mesh"), ("tab:orange", "coarser mesh")):
        ax.scatter([], [], marker="o", color=colour, label=label)
    ax.set(xscale="log", yscale="log", xlabel="time, cold: model + FRF [s]",
           ylabel="FRF error against the finest [% of its peak]",
           title="Blisk + dampers: accuracy against time per setting")
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_formatter(FormatStrFormatter("%g"))
        axis.set_minor_formatter(FormatStrFormatter("%g"))
    ax.tick_params(axis="x", which="minor", labelsize=7)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def _pick(text: str | None) -> list[Setting]:
    """The settings named in --only (the finest always first: it is the reference)."""
    if text is None:
        return list(SETTINGS)
    names = {s.name: s for s in SETTINGS}
    asked = [n.strip() for n in text.split(",") if n.strip()]
    bad = [n for n in asked if n not in names]
    if bad:
        raise ValueError(f"--only: unknown setting(s) {', '.join(bad)}; allowed: "
                         f"{', '.join(names)}")
    return [s for s in SETTINGS if s.name in asked]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="microslip bench trade", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--case", type=Path, default=Path("cases/15_blisk_damper.toml"),
                        help="the blisk-damper case whose knobs are varied")
    parser.add_argument("--only", default=None, metavar="NAMES",
                        help="comma-separated setting names (default: all); the first run is "
                             "the reference of the changes")
    parser.add_argument("--start", type=float, default=3120.0, help="FRF start [rad/s]")
    parser.add_argument("--stop", type=float, default=3180.0, help="FRF stop [rad/s]")
    parser.add_argument("--out", type=Path, default=None,
                        help="folder for trade.json and trade.png")
    args = parser.parse_args(argv)
    from microslip.case import (
        CaseError,
        check,
        load,
        settings,
    )

    try:
        settings = _pick(args.only)
        check_window(args.start, args.stop)
        base = load(args.case).data
        datas = [case_data(base, s, args.start, args.stop) for s in settings]
        for d in datas:
            check(d, str(args.case))
    except (ValueError, CaseError) as err:
        print(f"microslip bench trade: {err}", file=sys.stderr)
        return 2
    print(f"{len(settings)} settings of {args.case}, FRF {args.start:g}..{args.stop:g} rad/s, "
          f"each cold in its own process", flush=True)
    rows: list[dict] = []
    stop_with_signals()
    t_all = time.perf_counter()
    for k, (s, data) in enumerate(zip(settings, datas)):
        r = cold(data, str(args.case))
        rows.append(r | {"setting": asdict(s)})
        spent = time.perf_counter() - t_all
        weights = [weight(x) for x in settings]
        left = spent * sum(weights[k + 1:]) / sum(weights[: k + 1])
        print(f"[{k + 1}/{len(settings)}] {s.name}: {s.describe()}: peak "
              f"{1e3 * r['amplitude']:.4f} mm at {r['omega']:.2f} rad/s (stuck "
              f"{1e3 * r['stuck'][1]:.4f} mm at {r['stuck'][0]:.2f}), {r['status']}, "
              f"{r['total_s']:.0f} s, {r['memory_mb']:.0f} MB; about {left / 60:.0f} min left "
              "(rough)", flush=True)
    for r, c in zip(rows, changes(rows, rows[0])):
        r.update(c)
    print(f"\nchanges against {settings[0].name} ({settings[0].describe()}):")
    print(table(rows))
    front = pareto_front([r["total_s"] for r in rows], [r["frf_error_pct"] for r in rows])
    print("Pareto front (time, FRF error): "
          + ", ".join(rows[i]["setting"]["name"] for i in front))
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "trade.json").write_text(json.dumps(rows, indent=1))
        print(f"wrote {picture(rows, args.out / 'trade.png')}, {args.out / 'trade.json'}")
    return 0 if all(r["status"] == "complete" for r in rows) else 1
