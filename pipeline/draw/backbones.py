"""Pictures of a nonlinear-modes analysis, from results.h5 alone: the backbone (natural
frequency against the output's amplitude), the damping ratio against it, and, synthesized
from the mode, the FRFs at the analysis' excitations and the resonance peak against the
excitation level (the performance curve) or, over a family, against the family's value."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from microslip.results.writer import attr_text

from . import plots
from .pictures import Options, analysis_spec, curves, frf_maps

#: A family of more members than this is drawn in graded colours, its first and last
#: members named in the legend (a legend of every member would not fit the picture).
NAMED_MEMBERS = 6


def _label(c: h5py.Group) -> str | None:
    return attr_text(c.attrs.get("label", "")) or None


def _styles(members: list[h5py.Group]) -> list[dict]:
    """Per member its legend label and colour: each its own in a small family; in a large
    one colours graded from the first to the last member, only those two named."""
    n = len(members)
    if n <= NAMED_MEMBERS:
        return [{"label": _label(c)} for c in members]
    from matplotlib import colormaps

    grade = colormaps["viridis"]
    return [{"label": _label(c) if k in (0, n - 1) else None,
             "color": grade(k / (n - 1))} for k, c in enumerate(members)]


def draw(g: h5py.Group, name: str, out: Path, options: Options | None = None) -> list[Path]:
    """Every picture of the analysis group ``g``; the paths written (``options``: none
    applies to these line pictures)."""
    spec = analysis_spec(g)
    members = [c for _, c in curves(g) if "omega" in c and len(c["omega"])]
    if not members:
        return []
    output = spec.output
    amp = f"max |{output}(t)| [m]" if spec.measure == "peak" else \
        f"max |{output}(t) - {output}0| [m]"
    paths = [out / f"{name}_frequency.png", out / f"{name}_damping.png"]
    styles = _styles(members)
    plots.curves(paths[0], f"{name}: natural frequency of mode {spec.mode} against the "
                 "level", amp, [{"x": c["response"][:, 0], "y": c["omega"][()]} | st
                                for c, st in zip(members, styles)],
                 "natural frequency w [rad/s]", logx=True)
    plots.curves(paths[1], f"{name}: modal damping ratio against the level", amp,
                 [{"x": c["response"][:, 0], "y": 100.0 * c["damping_ratio"][()]} | st
                  for c, st in zip(members, styles)],
                 "damping ratio zeta [%]", logx=True)
    paths.append(out / f"{name}_peaks.png")
    plots.curves(paths[-1], f"{name}: resonance peak of {output} against the excitation, "
                 "from the mode", "excitation: multiple of the case's load [-]",
                 [{"x": c["peak_excitation"][()], "y": c["response"][:, 0]} | st
                  for c, st in zip(members, styles) if "peak_excitation" in c],
                 f"resonance peak, {amp}", logx=True, logy=True)
    if spec.excitations:
        paths.append(out / f"{name}_frf.png")
        plots.curves(paths[-1], f"{name}: FRFs of {output} synthesized from the mode",
                     "excitation frequency w [rad/s]", _synthesized(members, styles), amp)
    design = _design_curves(members)
    if design:
        paths.append(out / f"{name}_optimization.png")
        plots.curves(paths[-1], f"{name}: peak of {output} against {spec.family.legend}",
                     spec.family.legend,
                     design, f"resonance peak, {amp}", optimum=(spec.family.legend, "m"))
    return paths + frf_maps(g, name, out, options or Options())


def _design_curves(members: list[h5py.Group]) -> list[dict]:
    """Over a family of numbers (a design study: Firrone & Zucca Fig. 22 right from
    backbones), per excitation the synthesized peak against the family's value; [] for a
    single backbone or a family of tables."""
    values = [c.attrs.get("family_value", "") for c in members]
    if len(members) < 2 or not all(isinstance(v, (int, float, np.number)) for v in values):
        return []
    excitations = members[0]["excitations"][()] if "excitations" in members[0] else []
    series = []
    for k, e in enumerate(excitations):
        y = np.array([c["peak_response"][k, 0] if "peak_response" in c else np.nan
                      for c in members])
        series.append({"x": np.asarray(values, float), "y": y,
                       "label": f"excitation x{e:g}"})
    return series


def _synthesized(members: list[h5py.Group], styles: list[dict]) -> list[dict]:
    """Per member and excitation the closed FRF curve (below the resonance, then back
    above it), and the backbone dashed (a large family: in its member's colour, the
    first and last members named)."""
    series = []
    graded = len(members) > NAMED_MEMBERS
    for c, st in zip(members, styles):
        if "frequencies" not in c:
            continue
        y = c["response"][:, 0]
        tag = _label(c)
        named = not graded or st["label"] is not None
        for e, (low, high) in zip(c["excitations"][()], c["frequencies"][()]):
            x = np.concatenate([low, high[::-1]])
            series.append({"x": x, "y": np.concatenate([y, y[::-1]]), "color": st.get("color"),
                           "label": f"{tag + ', ' if tag else ''}excitation x{e:g}"
                           if named else None})
        series.append({"x": c["omega"][()], "y": y, "ls": "--",
                       "color": st.get("color", "0.45"), "lw": 1.0,
                       "label": f"backbone{' ' + tag if tag else ''}" if named else None})
    return series
