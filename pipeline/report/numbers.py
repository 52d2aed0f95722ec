"""The key numbers of each analysis type as tables (title, header, rows of text), read from
its results group: what a person looks for first (the peaks and where, the slip share
there, the folds, the linear limits, the optimum, the percentiles, the synthesized peaks)."""

from __future__ import annotations

import json
from dataclasses import dataclass

import h5py
import numpy as np

from microslip.draw.pictures import curves
from microslip.draw.plots import length_unit
from microslip.results import schema
from microslip.results.writer import attr_text


@dataclass(frozen=True)
class Table:
    """One table of the page: its title, column heads and rows (text)."""

    title: str
    head: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]


def length(value: float, unit: tuple[float, str]) -> str:
    """A displacement [m] in ``unit``, four significant digits (NaN: a dash)."""
    return "-" if not np.isfinite(value) else f"{unit[0] * value:.4g}"


def num(value: float, digits: int = 6) -> str:
    return "-" if not np.isfinite(value) else f"{value:.{digits}g}"


def tables(kind: str, g: h5py.Group) -> list[Table]:
    """The key numbers of analysis group ``g`` of type ``kind`` ([] for a type without)."""
    make = {"frf": _frf, "peak": _peak, "nonlinear_modes": _modes, "uncertainty": _spread,
            "dti": _dti}.get(kind)
    return make(g) if make else []


def _label(c: h5py.Group, default: str) -> str:
    return attr_text(c.attrs.get("label", "")) or default


def outputs_of(c: h5py.Group) -> list[str]:
    """The output names of a curve (its ``outputs`` attribute)."""
    return json.loads(attr_text(c.attrs.get("outputs", "[]")))


def _slip_at(c: h5py.Group, i: int) -> str:
    """The share of the period each contact slips at point i (the mean over its points), as
    'name p %'."""
    parts = [f"{name} {100 * cd['slip_fraction'][i]:.0f} %"
             for name, cd in c.get(schema.CONTACTS, {}).items() if "slip_fraction" in cd]
    return ", ".join(parts) or "-"


def _frf(g: h5py.Group) -> list[Table]:
    """Per curve and output: the largest response and where, the slip share there, the
    folds and bifurcations; the linear limits' peaks."""
    rows = []
    unit = length_unit([np.nanmax(c["response"][()]) for _, c in curves(g)
                        if "response" in c and len(c["parameter"])])
    for key, c in curves(g):
        if "response" not in c or not len(c["parameter"]):
            rows.append((_label(c, key), attr_text(c.attrs.get("status", "")), "0", "-", "-",
                         "-", "-"))
            continue
        x, resp = c["parameter"][()], c["response"][()]
        folds = len(c["turning_points"][()]) if "turning_points" in c else 0
        bif = len(c["bifurcations"]["index"][()]) if "bifurcations" in c and \
            "index" in c["bifurcations"] else 0
        for k, out in enumerate(outputs_of(c) or ["response"]):
            i = int(np.nanargmax(resp[:, k]))
            rows.append((_label(c, key) + (f" ({out})" if resp.shape[1] > 1 else ""),
                         attr_text(c.attrs.get("status", "")), str(len(x)),
                         length(resp[i, k], unit), num(x[i]), _slip_at(c, i),
                         f"{folds} / {bif}"))
    out = [Table("Peaks of the computed curves",
                 ("curve", "status", "points", f"peak [{unit[1]}]", "at",
                  "slipping at the peak [% of the period]", "folds / bifurcations"), tuple(rows))]
    limits = [(attr_text(lg.attrs.get("label", key)), length(np.nanmax(lg["response"][:, 0]), unit),
               num(lg["omega"][int(np.nanargmax(lg["response"][:, 0]))]))
              for key, lg in sorted(g.items()) if schema.is_linear(key) and "response" in lg
              and len(lg["omega"])]
    if limits:
        out.append(Table("Linear limits (free and fully stuck)", ("system", f"peak [{unit[1]}]",
                                                                   "at [rad/s]"), tuple(limits)))
    return out


def _peak(g: h5py.Group) -> list[Table]:
    """Per curve: the smallest and largest peak and where; the free and stuck levels."""
    rows = []
    unit = length_unit([np.nanmax(c["amplitude"][()]) for _, c in curves(g)
                        if np.isfinite(c["amplitude"][()]).any()])
    for key, c in curves(g):
        a, p = c["amplitude"][()].reshape(-1), c["parameter"][()]
        if not np.isfinite(a).any():
            continue
        lo, hi = int(np.nanargmin(a)), int(np.nanargmax(a))
        rows.append((_label(c, key), str(len(p)), length(a[lo], unit), num(p[lo]),
                     length(a[hi], unit), num(p[hi])))
    out = [Table("The peak curve", ("curve", "values", f"smallest peak [{unit[1]}]", "at",
                                    f"largest peak [{unit[1]}]", "at"), tuple(rows))]
    levels = [(attr_text(lv.attrs.get("label", key)),
               length(np.nanmax(lv["amplitude"][()]), unit))
              for key, lv in sorted(g.items()) if schema.is_level(key) and "amplitude" in lv]
    if levels:
        out.append(Table("Reference levels", ("system", f"peak [{unit[1]}]"), tuple(levels)))
    return out


def _modes(g: h5py.Group) -> list[Table]:
    """Per backbone: its linear limit, the largest damping ratio and where, and the peaks
    synthesized at each excitation with their direct checks."""
    rows, peaks = [], []
    unit = length_unit([np.nanmax(c["response"][()]) for _, c in curves(g)
                        if "response" in c and len(c["response"])])
    for key, c in curves(g):
        if "omega" not in c or not len(c["omega"]):
            continue
        label = _label(c, key)
        z = c["damping_ratio"][()]
        i = int(np.nanargmax(z))
        rows.append((label, str(len(c["omega"])), num(c["omega"][0]), f"{100 * z[0]:.3g}",
                     f"{100 * z[i]:.3g}", length(c["response"][i, 0], unit)))
        for k, e in enumerate(c["excitations"][()] if "excitations" in c else ()):
            p, chk = c["peak_response"][k, 0], c["peak_check"][k, 0]
            peaks.append((label, f"x{e:g}", length(p, unit), num(c["peak_omega"][k]),
                          f"{100 * c['peak_damping_ratio'][k]:.3g}",
                          "-" if not np.isfinite(chk) else f"{p / chk - 1:+.1e}"))
    out = [Table("The nonlinear modes", ("backbone", "levels", "linear w [rad/s]",
                                          "linear zeta [%]", "largest zeta [%]",
                                          f"at amplitude [{unit[1]}]"), tuple(rows))]
    if peaks:
        out.append(Table("Peaks synthesized from the modes (checked by a direct solve)",
                         ("backbone", "excitation", f"peak [{unit[1]}]", "at [rad/s]",
                          "zeta [%]",
                          "against the direct solve"), tuple(peaks)))
    return out


def _spread(g: h5py.Group) -> list[Table]:
    """The percentiles of the peak and the exceedance probability."""
    if schema.STATISTICS not in g:
        return []
    s = g[schema.STATISTICS]
    pc = s["percentiles"][()]
    unit = length_unit(pc)
    rows = [(f"{p:g} % [{unit[1]}]", length(v, unit))
            for p, v in zip(s.attrs.get("percent", (5, 50, 95)), pc)]
    rows += [(f"mean [{unit[1]}]", length(float(s.attrs.get("mean", np.nan)), unit)),
             ("samples", str(int(s.attrs.get("count", 0))))]
    if "limit" in s.attrs:
        rows.append((f"P(peak > {length(float(s.attrs['limit']), unit)} {unit[1]})",
                     f"{float(s.attrs.get('exceedance', np.nan)):.3g} +- "
                     f"{float(s.attrs.get('exceedance_error', np.nan)):.2g}"))
    return [Table("Statistics of the peak", ("", "value"), tuple(rows))]


def _dti(g: h5py.Group) -> list[Table]:
    """Per frequency the time integration's steady response."""
    rows = []
    unit = length_unit([np.nanmax(c["response"][()]) for _, c in curves(g)
                        if "response" in c and len(c["response"])])
    for key, c in curves(g):
        for w, r, conv in zip(c["omega"][()], c["response"][:, 0], c["converged"][()]):
            rows.append((_label(c, key), num(w), length(r, unit), "yes" if conv else "no"))
    return [Table("Steady states by time integration", ("curve", "w [rad/s]",
                                                         f"response [{unit[1]}]", "periodic"),
                  tuple(rows))]


def reduction_tables(g: h5py.Group) -> list[Table]:
    """The reduced models (per body and nodal diameter: masters, modes, the first
    frequencies of the reduced model with its masters free) and each patch's contact
    stiffness (the mean over its node pairs)."""
    rows = []
    for body, bg in g.items():
        if body == schema.CONTACT_STIFFNESS or not isinstance(bg, h5py.Group):
            continue
        for nd, m in sorted(bg.items(), key=lambda kv: int(kv[0][2:]) if kv[0][2:].isdigit()
                            else -1):
            f = m["frequencies_hz"][()] if "frequencies_hz" in m else np.zeros(0)
            elastic = f[f > 1e-3 * f.max()] if f.size and f.max() > 0 else f
            rows.append((body, nd.removeprefix("nd"), str(int(m.attrs.get("n_master_dofs", 0))),
                         str(int(m.attrs.get("n_modes", 0))),
                         ", ".join(f"{v:.5g}" for v in elastic[:3]) or "-"))
    out = [Table("Reduced models (Craig-Bampton, every contact node a master)",
                 ("body", "nodal diameter", "master DOFs", "modes",
                  "first elastic frequencies [Hz]"), tuple(rows))]
    if schema.CONTACT_STIFFNESS in g:
        kt = [(patch, f"{np.mean(pg['normal_n_per_m'][()]):.4g}",
               f"{np.mean(pg['tangential_n_per_m'][()]):.4g}")
              for patch, pg in g[schema.CONTACT_STIFFNESS].items()]
        out.append(Table("Contact stiffness of the patches (flat punch, mean per node pair)",
                         ("patch", "normal [N/m]", "tangential [N/m]"), tuple(kt)))
    return out
