"""The FRFs of a results file as data for the page's interactive plot (report/plot.js):
per output, every curve's points with what a person asks of one (the parameter, the
response, its stability, the share of contact points slipping), the linear limits, and the
points whose contact maps the page shows, by their letters."""

from __future__ import annotations

import h5py
import numpy as np

from microslip.draw.pictures import analysis_spec, curves, lettered_maps
from microslip.draw.plots import LABELS, length_unit
from microslip.results import schema
from microslip.results.writer import attr_text

from .numbers import outputs_of


def _finite(values: np.ndarray, digits: int = 7) -> list:
    """JSON numbers (NaN: null), rounded to ``digits`` significant digits."""
    return [None if not np.isfinite(v) else float(f"{v:.{digits}g}") for v in values]


def _slip(c: h5py.Group) -> list | None:
    """Per point the share [%] of every contact's points slipping (their mean), or None."""
    parts = [cd["slip_fraction"][()] for cd in c.get(schema.CONTACTS, {}).values()
             if "slip_fraction" in cd]
    return _finite(100.0 * np.mean(parts, axis=0), 3) if parts else None


def frf_plots(g: h5py.Group, name: str) -> list[dict]:
    """One plot per output of the frf analysis group ``g``: {title, x, y, series: [{label,
    x, y [unit], stable (1, 0, -1 or null), slip [%] or null, kind: curve | limit}], marks:
    [{letter, x, y [unit], target: the id of the status maps' figure}], unit: m, mm or um
    as the responses' size reads}."""
    par = analysis_spec(g).parameter
    members = [(k, c) for k, c in curves(g) if "response" in c and len(c["parameter"])]
    outputs = outputs_of(members[0][1]) if members else []
    plots = []
    for k, out in enumerate(outputs):
        scale, unit = length_unit([np.nanmax(c["response"][:, k]) for _, c in members])
        series = [{"label": attr_text(c.attrs.get("label", "")) or key, "kind": "curve",
                   "x": _finite(c["parameter"][()]),
                   "y": _finite(scale * c["response"][:, k]),
                   "stable": [int(s) for s in c["stable"][()]] if "stable" in c else None,
                   "slip": _slip(c)} for key, c in members]
        series += [{"label": attr_text(lg.attrs.get("label", key)), "kind": "limit",
                    "x": _finite(lg["omega"][()]), "y": _finite(scale * lg["response"][:, k]),
                    "stable": None, "slip": None}
                   for key, lg in sorted(g.items()) if schema.is_linear(key)
                   and "response" in lg and par == "frequency"]
        # a map point's letter leads to the contact-status maps (the figure's id)
        marks = [{"letter": letter, "x": float(p.attrs["parameter"]),
                  "y": float(scale * p["response"][k]), "target": f"fig-{name}_status"}
                 for letter, _, p in lettered_maps(g) if "response" in p]
        plots.append({"title": f"{name}: {out}", "x": LABELS.get(par, par), "unit": unit,
                      "y": f"{out}: response [{unit}]", "series": series, "marks": marks})
    return plots
