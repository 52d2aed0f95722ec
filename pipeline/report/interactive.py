"""The FRFs of a results file as data for the page's interactive plot (report/plot.js):
per output, every curve's points with what a person asks of one (the parameter, the
response, its stability, the share of the period slipping, each contact's hysteresis
loop where the run stored it), the linear limits, and the points whose contact maps the
page shows, by their letters."""

from __future__ import annotations

import h5py
import numpy as np

from microslip.draw.pictures import analysis_spec, blade_of, curves, lettered_maps
from microslip.draw.plots import LABELS, length_unit
from microslip.results import schema
from microslip.results.writer import attr_text

from .numbers import outputs_of


def _finite(values: np.ndarray, digits: int = 7) -> list:
    """JSON numbers (NaN: null), rounded to ``digits`` significant digits."""
    return [None if not np.isfinite(v) else float(f"{v:.{digits}g}") for v in values]


def _slip(c: h5py.Group) -> list | None:
    """Per point the share [%] of the period the contact points slip (their mean over every
    contact's points), or None."""
    parts = [cd["slip_fraction"][()] for cd in c.get(schema.CONTACTS, {}).values()
             if "slip_fraction" in cd]
    return _finite(100.0 * np.mean(parts, axis=0), 3) if parts else None


#: the levels a loop's values are drawn at, per sign: 1 % of its span, a pixel of the
#: tooltip's 120 px picture
LOOP_LEVELS = 99
#: a loop's samples on the page at most (the tooltip's picture, not the balance's period)
LOOP_SAMPLES = 32


def _scaled(v: np.ndarray) -> tuple[list, list, list]:
    """(n, s) values as integers in [-LOOP_LEVELS, LOOP_LEVELS] across each row's span
    (its least value -LOOP_LEVELS, its largest LOOP_LEVELS: a loop riding on a large static
    part keeps its shape) and each row's least and largest values: a fourth of the JSON of
    7-digit numbers."""
    lo, hi = v.min(axis=1), v.max(axis=1)
    span = np.where(hi > lo, hi - lo, 1.0)
    ints = np.rint(2 * LOOP_LEVELS * (v - lo[:, None]) / span[:, None]) - LOOP_LEVELS
    return ints.astype(int).tolist(), _finite(lo, 6), _finite(hi, 6)


def _loops(c: h5py.Group, blade: int | None = None) -> list[dict] | None:
    """Per contact its stored hysteresis loops (the first tangential direction), one per
    point: {contact, unit, u, u0, u1, T, T0, T1} (:func:`_scaled`: the integers and each
    loop's least and largest value; u in unit: m, mm or um; T in N), or None where the run
    stored none. ``blade`` (a whole disk's output "tip#s"): of a whole disk's contacts
    ("<patch>#k") only sector s's; every sector's would put 2N loops in a tooltip and N^2
    on the page. Contacts without a sector suffix are always kept."""
    out = []
    for name, cd in sorted(c.get(schema.CONTACTS, {}).items()):
        if "loop_u" not in cd or not len(cd["loop_u"]) or (
                blade is not None and blade_of(name)[1] not in (None, blade)):
            continue
        step = -(-cd["loop_u"].shape[-1] // LOOP_SAMPLES)
        u = cd["loop_u"][:, 0, ::step].astype(float)
        T = cd["loop_T"][:, 0, ::step].astype(float)
        scale, unit = length_unit([np.max(np.abs(u))])
        (ui, u0, u1), (ti, t0, t1) = _scaled(scale * u), _scaled(T)
        out.append({"contact": name, "unit": unit, "u": ui, "u0": u0, "u1": u1,
                    "T": ti, "T0": t0, "T1": t1})
    return out or None


def frf_plots(g: h5py.Group, name: str) -> list[dict]:
    """One plot per output of the frf analysis group ``g`` (a whole disk's "tip#0" ..
    "tip#N-1" gathered into one plot "tip", a series per blade and member, without the
    linear limits: as its picture): {title, x, y, series: [{label, x, y [unit], stable (1,
    0, -1 or null), slip [%] or null, loops (:func:`_loops`) or null, kind: curve |
    limit}], marks: [{letter, x, y [unit] (a whole disk: its largest blade's), target: the
    id of the status maps' figure}], unit: m, mm or um as the responses' size reads}."""
    par = analysis_spec(g).parameter
    members = [(k, c) for k, c in curves(g) if "response" in c and len(c["parameter"])]
    outputs = outputs_of(members[0][1]) if members else []
    groups: dict[str, list[int]] = {}
    for k, out in enumerate(outputs):
        base, blade = blade_of(out)
        groups.setdefault(out if blade is None else base, []).append(k)
    return [_frf_plot(g, name, par, members, title, ks, outputs)
            for title, ks in groups.items()]


def _frf_plot(g: h5py.Group, name: str, par: str, members: list, title: str,
              ks: list[int], outputs: list[str]) -> dict:
    """The plot of output ``title``: the responses' columns ``ks`` (one, or a whole disk's
    blades) of every member, and the linear limits of a single output."""
    whole = blade_of(outputs[ks[0]])[1] is not None
    scale, unit = length_unit([np.nanmax(c["response"][:, ks]) for _, c in members])
    series = []
    for key, c in members:
        label = attr_text(c.attrs.get("label", "")) or key
        for k in ks:
            blade = blade_of(outputs[k])[1]
            series.append({
                "label": (f"blade {blade}" + (f", {label}" if len(members) > 1 else "")
                          if whole else label), "kind": "curve",
                "x": _finite(c["parameter"][()]), "y": _finite(scale * c["response"][:, k]),
                "stable": [int(s) for s in c["stable"][()]] if "stable" in c else None,
                "slip": _slip(c), "loops": _loops(c, blade)})
    if not whole:  # (a whole disk's N limits would hide its blades, as in its picture)
        series += [{"label": attr_text(lg.attrs.get("label", key)), "kind": "limit",
                    "x": _finite(lg["omega"][()]),
                    "y": _finite(scale * lg["response"][:, ks[0]]),
                    "stable": None, "slip": None, "loops": None}
                   for key, lg in sorted(g.items()) if schema.is_linear(key)
                   and "response" in lg and par == "frequency"]
    # a map point's letter leads to the contact-status maps (the figure's id)
    marks = [{"letter": letter, "x": float(p.attrs["parameter"]),
              "y": float(scale * np.max(p["response"][ks])), "target": f"fig-{name}_status"}
             for letter, _, p in lettered_maps(g) if "response" in p]
    return {"title": f"{name}: {title}", "x": LABELS.get(par, par), "unit": unit,
            "y": f"{title}: response [{unit}]", "series": series, "marks": marks,
            "levels": LOOP_LEVELS}
