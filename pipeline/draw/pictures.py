"""The pictures of an analysis, drawn from what results.h5 holds (nothing recomputed).

``run`` calls these once an analysis is written; ``microslip render DIR`` calls them again
on a finished results file, with other colours, another map point or another size. What a
picture needs and the file does not hold is a defect of the file, not of the picture.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from microslip.case import specs
from microslip.case.kinds import Kinds, kinds_or_shipped
from microslip.laws.coulomb import slip_share
from microslip.laws.states import STATE_NAMES, STICK
from microslip.results import schema
from microslip.results.writer import attr_table, attr_text

from . import maps, plots, shapes

MEASURE_LABEL = {"peak": "max |{}(t)| [m]", "vibration": "max |{0}(t) - {0}0| [m]",
                 "harmonic": "first-harmonic amplitude of {} [m]"}
STYLE = {"natural": "--", "natural-down": ":"}  # line style per continuation method


@dataclass(frozen=True)
class Options:
    """How pictures are drawn. colours: state -> colour of the status maps; panel: pixels
    of one map (width, height); at: draw the maps at the computed point nearest this
    parameter value on every curve instead of the case's map points; map_types: which
    maps (None: the case's own)."""

    colours: Mapping[int, str] = field(default_factory=lambda: dict(maps.STATE_COLOURS))
    panel: tuple[int, int] = maps.PANEL
    at: float | None = None
    map_types: tuple[str, ...] | None = None


def analysis_spec(g: h5py.Group, kinds: Kinds | None = None) -> specs.Analysis:
    """The spec of an analysis group, from its record, by its type's class (``kinds``,
    default the shipped ones): what its pictures are drawn by (the keys a file from an
    older version lacks take their defaults)."""
    record = attr_table(g.attrs)
    return specs.from_record(record, kinds_or_shipped(kinds)[record["type"]].spec)


def _list(value) -> list:
    """An attribute written as a JSON list or as an array."""
    if isinstance(value, (str, bytes)):
        return list(json.loads(attr_text(value) or "[]"))
    return list(np.atleast_1d(value))


def curves(g: h5py.Group) -> list[tuple[str, h5py.Group]]:
    """The analysis' curve groups in order."""
    return sorted((k, v) for k, v in g.items() if schema.is_curve(k))


# --- frequency responses ------------------------------------------------------------------


def frf_series(g: h5py.Group) -> tuple[str, dict[str, list[dict]], dict[str, list[dict]]]:
    """(parameter, output -> line series, contact -> static-force line series) of an frf
    analysis group, with the linear limits where written."""
    par = analysis_spec(g).parameter
    series: dict[str, list[dict]] = {}
    static: dict[str, list[dict]] = {}
    for _, c in curves(g):
        outs = [attr_text(x) for x in _list(c.attrs.get("outputs", "[]"))]
        style = STYLE.get(attr_text(c.attrs.get("method", "")), "-")
        label = attr_text(c.attrs.get("label", "")) or None
        line = branch_line(c)
        jumps = c["jumps"][()] if "jumps" in c else np.zeros((0, 2), int)
        for k, n in enumerate(outs):
            series.setdefault(n, []).append({**line, "y": line["y"][:, k], "label": label,
                                             "ls": style, "bifurcations": [
                                                 (kind, xb, yb[k]) for kind, xb, yb in
                                                 line["bifurcations"]]})
        for contact, cd in c.get(schema.CONTACTS, {}).items():
            for what, y in static_lines(cd["static_force"][()],
                                        [attr_text(x) for x in cd["columns"][()]]):
                static.setdefault(contact, []).append({
                    "x": c["parameter"][()], "y": y, "ls": style, "jumps": jumps,
                    "label": ", ".join(s for s in (label, what) if s)})
    masses = [float(c.attrs.get("mass_multiplier", 1.0)) for _, c in curves(g)]
    for key, lg in sorted(g.items()):
        if not schema.is_linear(key):
            continue
        colour = "0.45"  # one limit: grey; one stuck limit per mass: its curves' colour
        mass = float(lg.attrs["mass_multiplier"])
        if key not in (schema.LINEAR_FREE, schema.LINEAR_STUCK) and mass in masses:
            colour = f"C{masses.index(mass) % 10}"
        for k, n in enumerate(series):
            series[n].append({"x": lg["omega"][()], "y": lg["response"][:, k],
                              "label": attr_text(lg.attrs["label"]), "lw": 1.0, "color": colour,
                              "ls": ":" if key == schema.LINEAR_FREE else "-."})
    return par, series, static


def branch_line(c: h5py.Group) -> dict:
    """A curve's line: x (m,), y (m, outputs), its computed points with the refined peak
    (a map point) and the located bifurcations drawn in, in branch order; stable (m,) or
    None (no stability: 1 stable, 0 unstable, -1 a bifurcation, where both meet);
    turning_points and jumps (point indices into the line), bifurcations [(kind, x,
    (outputs,) y)]."""
    x, y = c["parameter"][()], c["response"][()]
    values = x
    key = np.arange(len(x), dtype=float)  # where each drawn point sits along the branch
    stable = c["stable"][()].astype(int) if "stable" in c else None
    marks, peak = [], None
    xp, yp, at = _with_peak(c)
    if len(xp) > len(x):  # the refined peak, between points at - 1 and at
        peak = _along(values, at - 1, xp[at])
        x, y, key = xp, yp, np.insert(key, at, peak)
        if stable is not None:
            stable = np.insert(stable, at, stable[at - 1 if peak < at - 0.5 else at])
    b = c.get(schema.BIFURCATIONS)
    if b is not None and stable is not None and len(b["parameter"]):
        where = np.array([_along(values, i, v) for i, v in zip(b["index"][()],
                                                                b["parameter"][()])])
        where += 1e-6 * np.arange(where.size)  # two in one interval keep their order
        order = np.argsort(where, kind="stable")
        k = np.searchsorted(key, where[order])
        x = np.insert(x, k, b["parameter"][()][order])
        y = np.insert(y, k, b["response"][()][order], axis=0)
        key, stable = np.insert(key, k, where[order]), np.insert(stable, k, -1)
        marks = [(attr_text(kind), xb, yb) for kind, xb, yb in
                 zip(b["kind"][()], b["parameter"][()], b["response"][()])]
        if peak is not None:  # the peak takes the side of the bifurcation it lies on
            j = int(np.flatnonzero(key == peak)[0])
            left, right = stable[j - 1] if j else 1, stable[j + 1] if j + 1 < len(key) else 1
            stable[j] = right if left == -1 else left if right == -1 else stable[j]
    index = np.flatnonzero(key == np.round(key))  # the computed points' new places
    tp = c["turning_points"][()] if "turning_points" in c else np.zeros(0, int)
    jumps = c["jumps"][()] if "jumps" in c else np.zeros((0, 2), int)
    return {"x": x, "y": y, "stable": stable, "turning_points": index[tp],
            "jumps": index[jumps].reshape(-1, 2), "bifurcations": marks}


def _along(values: np.ndarray, i: int, value: float) -> float:
    """Where ``value`` of the parameter sits between points i and i + 1 of a branch: i plus
    its fraction of the way, within (0.01, 0.99) (a fold lies beyond both points' values:
    at the nearer end)."""
    if i + 1 >= len(values) or values[i + 1] == values[i]:
        return i + 0.5
    return i + float(np.clip((value - values[i]) / (values[i + 1] - values[i]), 0.01, 0.99))


def _with_peak(c: h5py.Group) -> tuple[np.ndarray, np.ndarray, int]:
    """(parameter, response, where inserted) of a curve with its refined peak (a map point)
    drawn in: a lightly damped peak is narrower than the continuation's steps, and the line
    would pass below the marked peak. The peak goes between the computed points around it
    (inserted at the end index, len(x), when there is none)."""
    x, y = c["parameter"][()], c["response"][()]
    for _, p in sorted(c.get(schema.MAPS, {}).items()):
        if attr_text(p.attrs["what"]) != "peak" or not len(x):
            continue
        v = float(p.attrs["parameter"])
        if np.any(x == v):
            break  # the peak is a computed point
        i = int(np.argmax(y[:, 0]))
        j = i + 1 if (i + 1 < len(x) and (x[i + 1] - v) * (x[i] - v) <= 0) else i
        if j == i and i > 0 and (x[i - 1] - v) * (x[i] - v) > 0:
            continue  # not between the computed points around the maximum
        return np.insert(x, j, v), np.insert(y, j, p["response"][()], axis=0), j
    return x, y, len(x)


def static_lines(static: np.ndarray, names: list[str]) -> list[tuple[str, np.ndarray]]:
    """(label, (n,) force [N]) lines of a contact's static forces ``static`` (n points,
    size x columns; ``names``: the columns' per contact point). A contact of several
    points (a patch) gives its total per component, "sum N0" etc.: one line per pair and
    component (108 for 36 pairs) is unreadable; the per-pair values stay in the file."""
    if not names or static.shape[1] == 0 or static.shape[1] % len(names):
        return []
    size = static.shape[1] // len(names)
    if size > 1:
        total = static.reshape(static.shape[0], size, len(names)).sum(axis=1)
        return [(f"sum {n}", total[:, j]) for j, n in enumerate(names)]
    return [(n, static[:, j]) for j, n in enumerate(names)]


LETTERS = "abcdefghijklmnopqrstuvwxyz"


def lettered_maps(g: h5py.Group) -> list[tuple[str, h5py.Group, h5py.Group]]:
    """(letter, curve, point) of every map point of an frf analysis, lettered a, b, c...
    in curve order."""
    out = []
    for _, c in curves(g):
        for _, p in sorted(c.get(schema.MAPS, {}).items()):
            out.append((LETTERS[len(out) % len(LETTERS)], c, p))
    return out


def map_marks(g: h5py.Group) -> dict[str, list[dict]]:
    """Per output, markers at the points that got maps (peaks, the solutions at a given
    frequency), labelled by their letter."""
    marks: dict[str, list[dict]] = {}
    for letter, c, p in lettered_maps(g):
        outs = [attr_text(x) for x in _list(c.attrs.get("outputs", "[]"))]
        for k, n in enumerate(outs):
            marks.setdefault(n, []).append({
                "x": [p.attrs["parameter"]], "y": [p["response"][k]], "style": "ko",
                "label": None, "text": letter})
    return marks


def frf(g: h5py.Group, name: str, out: Path, options: Options = Options()) -> list[Path]:
    """Every picture of an frf analysis: the response of each output (with the linear
    limits and the map points marked), the static forces of each contact, and the maps."""
    par, series, static = frf_series(g)
    series, static = _around_the_disk(series), _first_sector(static)
    measure = analysis_spec(g).measure
    marks = map_marks(g)
    normalised = any(bool(c.attrs.get("normalised", False)) for _, c in curves(g))
    paths = []
    for n, lines in series.items():
        if any(s.get("label") for s in lines):  # every curve named beside the limits
            lines = [s if s.get("label") else {**s, "label": "with the friction contacts"}
                     for s in lines]
        path = out / f"{name}_{n}.png"
        label = MEASURE_LABEL[measure].format(n)
        if normalised:
            label = label.replace(" [m]", " / excitation [m per unit]")
        plots.curves(path, f"{name}: response of {n}" + (
            ", normalised by the excitation" if normalised else ""), plots.LABELS[par], lines,
                     label, markers=marks.get(n, ()))
        paths.append(path)
    for contact, lines in static.items():
        path = out / f"{name}_static_{contact}.png"
        plots.curves(path, f"{name}: static forces, contact {contact}", plots.LABELS[par],
                     lines, "static contact force [N]")
        paths.append(path)
    return paths + frf_maps(g, name, out, options) + slip_growth(g, name, out)


def blade_of(name: str) -> tuple[str, int | None]:
    """("tip", 3) of a whole disk's "tip#3"; (name, None) of any other name."""
    base, _, s = name.rpartition("#")
    return (base, int(s)) if base and s.isdigit() else (name, None)


def _around_the_disk(series: dict[str, list[dict]]) -> dict[str, list[dict]]:
    """A whole disk's outputs ("tip#s") gathered into one picture per output: each blade's
    computed curves, labelled by blade (its linear limits left out: N of each would hide
    the blades); other outputs as they are."""
    out: dict[str, list[dict]] = {}
    for n, lines in series.items():
        base, s = blade_of(n)
        if s is None:
            out[n] = lines
            continue
        out.setdefault(base, []).extend(
            {**x, "label": f"blade {s}" + (f", {x['label']}" if x.get("label") else ""),
             "bifurcations": ()}
            for x in lines if "bifurcations" in x)
    return out


def _first_sector(static: dict[str, list[dict]]) -> dict[str, list[dict]]:
    """A whole disk's contacts: sector 0's static forces only (one picture per contact of
    the sector, not N); other contacts as they are."""
    return {c: v for c, v in static.items() if blade_of(c)[1] in (None, 0)}


def slip_at_peaks(g: h5py.Group) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(family values, patch -> slipping share [%] of its node pairs at that curve's peak,
    "all patches", and the share of all that do not stick, slipping or lifting off) over
    the curves of an frf analysis with maps at their peaks."""
    x, shares = [], {}
    for _, c in curves(g):
        peaks = [p for _, p in sorted(c.get(schema.MAPS, {}).items())
                 if attr_text(p.attrs["what"]) == "peak"]
        value = c.attrs.get("family_value", "")
        if not peaks or isinstance(value, (str, bytes)):
            continue
        x.append(float(value))
        pg = peaks[0][schema.PATCHES]
        states = {k: pg[k]["state"][()] for k in sorted(pg)}
        for k, st in states.items():
            shares.setdefault(k, []).append(100 * slip_share(st))
        every = np.concatenate(list(states.values()))
        shares.setdefault("all patches", []).append(100 * slip_share(every))
        shares.setdefault("all patches, not stuck (slip or lift-off)", []).append(
            100 * float(np.mean(every != STICK)))
    return np.array(x), {k: np.array(v) for k, v in shares.items()}


def slip_growth(g: h5py.Group, name: str, out: Path) -> list[Path]:
    """The slipping share of each patch's node pairs (and of all) at each curve's peak
    against the family value (Firrone & Zucca Fig. 20 right: slip growing with the excitation). Only
    for a family of at least two curves with maps at their peaks."""
    x, shares = slip_at_peaks(g)
    if len(x) < 2:
        return []
    family = analysis_spec(g).family
    series = [{"x": x, "y": v, "label": k, "lw": 2.2 if k.startswith("all") else 1.2,
               "ls": ":" if "not stuck" in k else "-"} for k, v in shares.items()]
    path = out / f"{name}_slip.png"
    what = family.legend if family is not None else "family value"
    plots.curves(path, f"{name}: slipping area at the resonance peak", what, series,
                 "node pairs in stick-slip or gross slip [%]", logy=False)
    return [path]


# --- maps -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class MapPoint:
    """A solution drawn in maps: its caption and, per patch, state (P,), static (P, 3)."""

    caption: str
    label: str
    value: float
    state: dict[str, np.ndarray]
    static: dict[str, np.ndarray]


def contact_grids(f: h5py.File) -> dict[str, maps.PatchGrid]:
    """The patches' grids of a results file (/contact_grids)."""
    return {k: maps.PatchGrid.from_group(k, v) for k, v in f.get(schema.CONTACT_GRIDS, {}).items()}


def map_points(g: h5py.Group, at: float | None = None) -> list[MapPoint]:
    """The points of an frf analysis that get maps: the case's (each curve's maps/ group),
    or, with ``at``, the computed point of each curve nearest that parameter value."""
    out = []
    par = getattr(analysis_spec(g), "parameter", "level")  # (a nonlinear mode's: the level)
    if at is not None:
        for _, c in curves(g):
            label = attr_text(c.attrs.get("label", ""))
            if schema.PATCHES not in c or not len(c["parameter"]):
                continue
            i = int(np.argmin(np.abs(c["parameter"][()] - at)))
            v = float(c["parameter"][i])
            pg = c[schema.PATCHES]
            out.append(MapPoint("\n".join(x for x in (label, f"{par} {v:.6g}") if x), label, v,
                                {p: pg[p]["state"][i] for p in pg},
                                {p: pg[p]["static"][i] for p in pg}))
        return out
    for letter, c, p in lettered_maps(g):
        label = attr_text(c.attrs.get("label", ""))
        pg = p[schema.PATCHES]
        what = _what(p, par)
        out.append(MapPoint(f"{letter}: {label}\n{what}" if label else f"{letter}: {what}",
                            label, float(p.attrs["parameter"]),
                            {k: pg[k]["state"][()] for k in pg},
                            {k: pg[k]["static"][()] for k in pg}))
    return out


def _what(p: h5py.Group, par: str) -> str:
    """A map point's description ("peak" with where it is)."""
    what = attr_text(p.attrs["what"])
    unit = {"frequency": " rad/s"}.get(par, "")
    if what == "peak":
        what += f" at {par} {float(p.attrs['parameter']):.6g}{unit}"
    elif unit:  # "frequency = 3156.5, solution 1 of 3": the unit after the value
        what = re.sub(rf"^({par} = [-+.\deE]+)", rf"\1{unit}", what)
    return what


def _map_rows(points: list) -> list[tuple[Any, list[str]]]:
    """The rows of a maps picture: (map point, its patches) per point, and on a whole disk
    per point and blade (each sector's patches "p#s" in a row of their own)."""
    rows = []
    for pt in points:
        blades: dict[int | None, list[str]] = {}
        for p in sorted(pt.state, key=lambda p: (blade_of(p)[1] or 0, p)):
            blades.setdefault(blade_of(p)[1], []).append(p)
        rows += [(pt, row) for row in blades.values()]
    return rows


def frf_maps(g: h5py.Group, name: str, out: Path, options: Options = Options()) -> list[Path]:
    """Status maps (and static normal-load maps) of every map point: one row per point, one
    column per patch. Nothing when the analysis has no map points."""
    points = map_points(g, options.at)
    kinds = options.map_types if options.map_types is not None else \
        analysis_spec(g).map_types
    if not points or not kinds:
        return []
    grids = contact_grids(g.file)
    rows = _map_rows(points)
    grids |= {p: grids[blade_of(p)[0]] for _, row in rows for p in row if p not in grids}
    patches = [p for _, row in rows[:1] for p in row]
    paths = []
    if "status" in kinds:
        panels = [[maps.Panel(grids[p], pt.state[p], _panel_caption(pt, p, True))
                   for p in row] for pt, row in rows]
        path = out / f"{name}_status.png"
        maps.status_maps(path, f"{name}: contact status over the period "
                         f"({_seen(grids, patches)})", panels,
                         colours=options.colours, panel=options.panel)
        paths.append(path)
    if "normal_load" in kinds:
        panels = [[maps.Panel(grids[p], pt.static[p][:, 2], _panel_caption(pt, p, False))
                   for p in row] for pt, row in rows]
        path = out / f"{name}_normal_load.png"
        maps.load_maps(path, f"{name}: static normal load per node pair "
                       f"({_seen(grids, patches)})", panels,
                       panel=options.panel)
        paths.append(path)
    if "shape" in kinds and options.at is None:  # stored at the case's map points only
        paths += frf_shapes(g, name, out, options)
    return paths


def frf_shapes(g: h5py.Group, name: str, out: Path, options: Options = Options()
               ) -> list[Path]:
    """The deformed sector and full disk at every map point that stored its shape,
    ``<name>_shape_<letter>.png``."""
    par = analysis_spec(g).parameter
    panel = shapes.PANEL if options.panel == maps.PANEL else options.panel
    paths = []
    for letter, c, p in lettered_maps(g):
        found = shapes.read(g.file, p)
        if found is None:
            continue
        label = attr_text(c.attrs.get("label", ""))
        title = f"{name} ({letter}): " + ", ".join(x for x in (label, _what(p, par)) if x)
        paths.append(shapes.draw(out / f"{name}_shape_{letter}.png", title, *found, panel))
    return paths


def _panel_caption(pt: MapPoint, patch: str, status: bool) -> str:
    if status:
        what = f"{slip_share(pt.state[patch]):.0%} of its node pairs slip"
    else:
        what = f"sum N0 = {pt.static[patch][:, 2].sum():.4g} N"
    return f"{pt.caption}\n{patch}: {what}"


def _seen(grids: Mapping[str, maps.PatchGrid], patches: list[str]) -> str:
    """How the patches are seen, for a picture's title."""
    pairs = sorted({(grids[p].body_b, grids[p].body_a) for p in patches})
    return "; ".join(f"seen from {b} onto {a}" for b, a in pairs) + ", high radius up"


# --- parameter curves -----------------------------------------------------------------------


def peak(g: h5py.Group, name: str, out: Path, options: Options = Options()) -> list[Path]:
    """The peak response against the parameter (optimization or performance curve), its
    minimum marked where the parameter is a preload or a mass, with the linear levels."""
    spec = analysis_spec(g)
    par, output, (lo, hi) = spec.parameter, spec.output, spec.window
    series = [{"x": c["parameter"][()], "y": c["amplitude"][()],
               # unknown (-1: not solved there) drawn as stable: nothing to say
               "stable": np.abs(c["stable"][()].astype(int)) if "stable" in c else None,
               "label": attr_text(c.attrs.get("label", "")) or None} for _, c in curves(g)]
    for key, label, style in ((schema.LEVEL_FREE, "free (no damper)", ":"),
                              (schema.LEVEL_STUCK, "fully stuck", "-.")):
        if key in g:
            stored = attr_text(g[key].attrs.get("label", ""))  # (before 0.24: "free")
            series.append({"x": g[key]["parameter"][()], "y": g[key]["amplitude"][()],
                           "label": stored if stored.startswith(("free (", "fully")) else label,
                           "ls": style, "color": "0.45", "lw": 1.0, "optimum": False})
    path = out / f"{name}.png"
    what = MEASURE_LABEL[spec.measure].format(output)
    plots.curves(path, f"{name}: peak response of {output}", plots.LABELS[par], series,
                 f"resonance peak of {what}\n(w in {lo:g} to {hi:g} rad/s)",
                 optimum=(par, "m") if par in ("preload", "mass") else None)
    return [path]


# --- contact laws alone, time integration ---------------------------------------------------


def loops(g: h5py.Group, name: str, out: Path, options: Options = Options()) -> list[Path]:
    """Hysteresis loops T(u) of one contact law (1D) or its force trajectories (2D), one
    per amplitude of the prescribed motion, each labelled with its state and dissipation."""
    c = g[schema.curve(0)]
    u, T, N = c["u"][()], c["T"][()], c["N"][()]
    two_d = int(c.attrs["dim"]) == 2
    mu = float(c.attrs["mu"])
    work = np.abs(T).max() * np.abs(u).max()  # W to 3 digits, round-off (vs. T u) shown as 0
    what = attr_text(c.attrs["motion"])
    loops_ = []
    for i, (amp, state, w) in enumerate(zip(c["motion_amplitude"][()], c["state"][()],
                                            c["dissipation"][()], strict=True)):
        label = (f"{what} amplitude {plots.number(amp)} m: {STATE_NAMES[state]}, "
                 f"W = {plots.number(w, work)} J")
        loops_.append({"u": u[i, 0], "T": T[i] if two_d else T[i, 0], "limit": mu * N[i],
                       "label": label})
    path = out / f"{name}.png"
    plots.loops(path, f"{name}: law {attr_text(c.attrs['law'])}, contact "
                f"{attr_text(c.attrs['contact'])}", loops_, two_d=two_d)
    return [path]


def modes(g: h5py.Group, name: str, out: Path, options: Options = Options()) -> list[Path]:
    """The reduced models' frequency error on each mode of every body and nodal diameter."""
    rows = []
    for body, b in g.items():
        if body == schema.ASSEMBLY_MODES:  # (the reduced assembly's: no unreduced reference)
            continue
        for where, m in b.items():
            rows.append({"label": body + ("" if where == "body" else f" ND {where[2:]}"),
                         "frequencies_hz": m["frequencies_hz"][()],
                         "relative_error": m["relative_error"][()]})
    path = out / f"{name}.png"
    plots.mode_errors(path, f"{name}: the reduced models against the unreduced bodies", rows)
    return [path]


def dti(g: h5py.Group, name: str, out: Path, options: Options = Options()) -> list[Path]:
    """Steady responses by time integration as markers over the FRF they are compared with
    (the analysis ``compare`` names), per output; the static contact forces likewise."""
    c = g[schema.curve(0)]
    spec = analysis_spec(g)
    compare = spec.compare
    ref = g.file.get(compare) if compare else None
    _, series, static = frf_series(ref) if ref is not None else ("", {}, {})
    omega, spp = c["omega"][()], int(c.attrs["steps_per_period"])
    paths = []
    for contact, cd in c.get(schema.CONTACTS, {}).items():
        lines = static.get(contact, [])
        if not lines:
            continue
        marks = [{"x": omega, "y": cd["N0"][()][:, 0], "label": "N0, time integration",
                  "style": "kD"}] if bool(cd.attrs.get("variable_normal", False)) else []
        marks.append({"x": omega, "y": cd["T0"][()][:, 0, 0], "label": "T0, time integration",
                      "style": "ks"})
        path = out / f"{name}_static_{contact}.png"
        plots.curves(path, f"{name}: static forces, contact {contact}",
                     plots.LABELS["frequency"], lines, "static contact force [N]",
                     markers=marks)
        paths.append(path)
    measure = spec.measure
    shown = c["response"][()]
    for k, output in enumerate(attr_text(x) for x in _list(c.attrs["outputs"])):
        path = out / f"{name}_{output}.png"
        plots.curves(path, f"{name}: response of {output}", plots.LABELS["frequency"],
                     series.get(output, []), MEASURE_LABEL[measure].format(output),
                     markers=[{"x": omega, "y": shown[:, k],
                               "label": f"time integration ({spp} steps/period)"}])
        paths.append(path)
    return paths


def transient(g: h5py.Group, name: str, out: Path, options: Options = Options()
              ) -> list[Path]:
    """The load steps (Firrone & Zucca Fig. 13): the outputs over time and the first contact's
    tangential force within its slip limits +- mu N."""
    steps = []
    for key in sorted(k for k in g if schema.is_step(k)):
        st = g[key]
        contacts = [attr_text(x) for x in _list(st.attrs.get(schema.CONTACTS, "[]"))]
        if not contacts:
            continue
        outputs = [attr_text(x) for x in _list(st.attrs["outputs"])]
        q, first = st["q"][()], st[schema.CONTACTS][contacts[0]]
        steps.append({"t": st["t"][()], "label": attr_text(st.attrs["label"]),
                      "outputs": {n: q[:, i] for i, n in enumerate(outputs)},
                      "T": first["T"][()][:, 0, 0],
                      "limit": float(first.attrs["mu"]) * first["N"][()][:, 0],
                      "contact": contacts[0]})
    if not steps:
        return []
    path = out / f"{name}.png"
    plots.transient(path, name, steps)
    return [path]


def uncertainty(g: h5py.Group, name: str, out: Path, options: Options = Options()
                ) -> list[Path]:
    """An uncertainty study: the histogram of the samples' peaks with the free and fully
    stuck levels and the limit; the peak against each uncertain parameter, coloured by
    the share of contact points slipping, each panel with its rank correlations."""
    spec = analysis_spec(g)
    s, st = g[schema.SAMPLES], g[schema.STATISTICS]
    names = json.loads(attr_text(s.attrs["names"]))
    ok = s["status"][()] == b"complete"
    peak, x = s["peak"][()][ok], s["parameters"][()][ok]
    what = MEASURE_LABEL[spec.measure].format(spec.output)
    levels = []
    for key, label, ls in (("free_peak", "free", ":"), ("stuck_peak", "fully stuck", "-.")):
        if key in st.attrs:
            levels.append({"x": float(st.attrs[key]), "label": label, "ls": ls})
    if spec.limit is not None:
        p, e = float(st.attrs["exceedance"]), float(st.attrs["exceedance_error"])
        levels.append({"x": spec.limit, "label": f"limit: P(exceeded) = {p:.2f} +- {e:.2f}",
                       "ls": "-", "color": "C3"})
    lo, hi = spec.window
    hist = out / f"{name}.png"
    plots.histogram(hist, f"{name}: peak of {spec.output} over {ok.sum()} samples "
                    f"(w in {lo:g} to {hi:g} rad/s)", peak, f"resonance peak of {what}",
                    levels)
    spread = out / f"{name}_parameters.png"
    rs, pr = st["spearman"][()], st["prcc"][()]
    columns = [{"x": x[:, j], "label": names[j],
                "note": f"rank corr. {rs[j]:+.2f}, partial {pr[j]:+.2f}"}
               for j in range(len(names))]
    plots.against_parameters(spread, f"{name}: peak of {spec.output} against each uncertain "
                             "parameter", columns, peak, f"peak of {what}",
                             colour=s["slip_share"][()][ok],
                             colour_label="share of contact points slipping at the peak")
    return [hist, spread]


def mistuning(g: h5py.Group, name: str, out: Path, options: Options = Options()
              ) -> list[Path]:
    """A mistuning study: the worst blade's amplification against the mistuning level
    (median, 95 % and largest of the patterns, with the dampers and without them, and
    Whitehead's bound; a family: each member's median and largest with the dampers, and
    without them once where the members agree, else each member's), its distribution per
    level (P(A > a), a panel per member, the limit marked) and every blade's peak around the
    disk for the pattern of the largest amplification at the highest level."""
    spec = analysis_spec(g)
    found = [(label, m) for label, m in schema.mistuning_members(g)
             if schema.AMPLIFICATION in m]
    if not found:
        return []
    series = []
    once = all(_same_free(found[0][1], m) for _, m in found[1:])
    colours = _colours(len(found))
    for k, (label, m) in enumerate(found):
        if spec.family is None:
            series += _amplification_series(m, {"friction": ("with the dampers", "C0"),
                                                "free": ("without the dampers (linear)",
                                                         "C1")}, spread=True)
            continue
        free = ("without the dampers (linear)", "0.5") if once else (
            f"{label}, without the dampers (linear)", colours[k])
        series += _amplification_series(m, {"friction": (f"{label}, with the dampers",
                                                         colours[k])}
                                        | ({"free": free} if k == 0 or not once else {}),
                                        spread=False)
    a = found[0][1][schema.AMPLIFICATION]
    levels = [{"y": float(a.attrs["whitehead"]), "label": "Whitehead (1 + sqrt N) / 2"},
              {"y": 1.0, "label": "tuned"}]
    curve = out / f"{name}.png"
    plots.amplification(curve, f"{name}: the worst blade's {spec.output} peak against the "
                        "tuned one", series, levels)
    spread = out / f"{name}_exceedance.png"
    plots.exceedance(spread, f"{name}: the distribution of the amplification per level",
                     [_exceedance_panel(m, label) for label, m in found], spec.limit)
    worst = _worst_pattern(found)
    if worst is None:
        return [curve, spread]
    label, p, j = worst
    sigma = p["sigma"][j]
    blades = out / f"{name}_blades.png"
    plots.around_the_disk(blades, f"{name}: every blade's peak, {label + ', ' if label else ''}"
                          f"pattern {j + 1} (sigma {100 * sigma:g} %, amplification "
                          f"{p['amplification'][j]:.3f})",
                          p["blade_peaks"][j] / float(p.attrs["tuned_peak"]),
                          100 * p["deviation"][j])
    return [curve, spread, blades]


def _exceedance_panel(m: h5py.Group, label: str) -> dict:
    """A member's exceedance curves: per level its complete patterns' amplification with
    the dampers (solid, the level's colour) and without them (dashed)."""
    p, a = m[schema.PATTERNS], m[schema.AMPLIFICATION]
    sigma, ok = p["sigma"][()], p["status"][()] == b"complete"
    levels = a["sigma"][()]
    colours = _colours(len(levels))
    curves = []
    for k, s in enumerate(levels):
        here = ok & (sigma == s)
        for case, ls in (("amplification", "-"), ("free_amplification", "--")):
            values = p[case][()][here]
            curves.append({"values": values[np.isfinite(values)], "color": colours[k],
                           "ls": ls,
                           "label": f"sigma {100 * s:g} %" if ls == "-" else "_nolegend_"})
    head = f"{label}: " if label else ""
    free = ", without them dashed" if "free_percentiles" in a else ""
    return {"title": f"{head}with the dampers solid{free}", "curves": curves}


def _amplification_series(m: h5py.Group, cases: dict[str, tuple[str, str]], spread: bool
                          ) -> list[dict]:
    """A member's curves from the tuned disk (1 at sigma 0), per case it has ("friction":
    with the dampers, solid; "free": without them, dashed) of ``cases`` (its legend head and
    colour): the median, the 95 % and the largest (``spread``: the study alone, its legend
    heads said once), or the median and the largest, each named."""
    a = m[schema.AMPLIFICATION]
    x = np.concatenate([[0.0], 100 * a["sigma"][()]])

    def tuned(y):
        return np.concatenate([[1.0], y])

    series = []
    for case, ls in (("friction", "-"), ("free", "--")):
        if f"{case}_percentiles" not in a or case not in cases:
            continue
        head, colour = cases[case]
        pc = a[f"{case}_percentiles"][()]
        series.append({"x": x, "y": tuned(pc[:, 1]), "label": f"{head}: median", "ls": ls,
                       "color": colour, "marker": "o"})
        if spread:
            series.append({"x": x, "y": tuned(pc[:, 2]), "label": "95 %", "ls": ls,
                           "color": colour, "alpha": 0.6})
        series.append({"x": x, "y": tuned(a[f"{case}_largest"][()]),
                       "label": "largest" if spread else f"{head}: largest", "ls": ls,
                       "color": colour, "marker": "^", "alpha": 0.6})
    return series


def _colours(n: int) -> list:
    """n distinct line colours: matplotlib's cycle up to 10, a colormap's beyond."""
    if n <= 10:
        return [f"C{k}" for k in range(n)]
    import matplotlib

    return [matplotlib.colormaps["viridis"](k / (n - 1)) for k in range(n)]


def _same_free(first: h5py.Group, other: h5py.Group) -> bool:
    """Whether a member's disk without the dampers gives the first member's amplification
    statistics (its percentiles and largest per level; a family of the dampers' mass or
    friction coefficient): drawn once then."""
    a, b = first[schema.AMPLIFICATION], other[schema.AMPLIFICATION]
    return all(x in a and x in b and np.allclose(a[x][()], b[x][()], rtol=1e-9, equal_nan=True)
               for x in ("free_percentiles", "free_largest"))


def _worst_pattern(found: list[tuple[str, h5py.Group]]) -> tuple[str, h5py.Group, int] | None:
    """(member label, its patterns group, the pattern) of the largest complete amplification
    at the study's highest level; None where no pattern there completed."""
    best = None
    for label, m in found:
        p = m[schema.PATTERNS]
        amp = p["amplification"][()]
        sigma = p["sigma"][()]
        ok = (p["status"][()] == b"complete") & np.isfinite(amp) & (sigma == sigma.max())
        if ok.any():
            j = int(np.flatnonzero(ok)[np.argmax(amp[ok])])
            if best is None or amp[j] > best[1]["amplification"][best[2]]:
                best = (label, p, j)
    return best


def render(results: Path, out: Path | None = None, options: Options = Options(),
           analyses: list[str] | None = None, kinds: Kinds | None = None) -> list[Path]:
    """Redraw the pictures of every analysis of a results file into ``out`` (default: the
    file's folder), each by its kind's drawer (``kinds``, default the shipped ones; the
    mesh previews of /geometry too). Returns the files written."""
    from microslip.results.writer import open_results

    out = out or results.parent
    out.mkdir(parents=True, exist_ok=True)
    from .previews import geometry_previews  # pyvista loads when a preview is drawn

    known = kinds_or_shipped(kinds)
    paths = []
    with open_results(results) as f:
        for name, g in f.items():
            kind = attr_text(g.attrs.get("type", ""))
            draw = (geometry_previews if kind == "geometry" else
                    known[kind].draw if kind in known else None)
            if draw is not None and (analyses is None or name in analyses):
                paths += draw(g, name, out, options)
    return paths
