"""What each picture draws, in words a student reads: axes, colours of contact states, line
styles, markers. One function per kind of picture, chosen by the analysis type and the
picture's name after the analysis' own (the drawers' naming, ``draw.pictures``)."""

from __future__ import annotations

from microslip.draw.maps import STATE_COLOURS
from microslip.draw.plots import LABELS
from microslip.laws.states import STATE_NAMES

#: the colours' names as a reader says them
_SAID = {"white": "white", "#a0a0a0": "grey", "#e6550d": "orange", "black": "black",
         "#3182bd": "blue"}
#: the contact-state colours of the maps, as the drawers use them (draw.maps)
STATES = ", ".join(f"{name} {_SAID.get(STATE_COLOURS[k], STATE_COLOURS[k])}"
                   for k, name in enumerate(STATE_NAMES))

FRF = ("the response against the {par}: each curve a computed branch, solid where stable "
       "and dashed where unstable (when stability was computed), bifurcations marked by "
       "kind; dotted the free system and dash-dotted the fully stuck one (the linear "
       "limits, where drawn); letters mark the points whose contact maps follow")
STATUS = ("contact status of every node pair of each patch at the marked points (one row per "
          "point, one column per patch; " + STATES + ")")
NORMAL = ("static normal load of every node pair at the marked points (colour scale in N; "
          "zero where the pair is open)")
SHAPE = "the deformed sector and full disk at the marked point (displacements magnified)"
SLIP = "share of contact points slipping at each curve's peak, per patch"
STATIC = ("static contact forces of {contact} against the {par} (the coupled static/dynamic "
          "balance: the mean normal and tangential loads)")
BY_SUFFIX = {
    "nonlinear_modes": {
        "frequency": "natural frequency of the nonlinear mode against the output's "
                     "amplitude (the backbone)",
        "damping": "modal damping ratio against the output's amplitude: friction damps "
                   "most where the contacts partly slip",
        "peaks": "resonance peak against the excitation level, read from the one backbone "
                 "(single nonlinear mode theory; the performance curve)",
        "frf": "FRFs synthesized from the mode at the analysis' excitation levels, with the "
               "backbone dashed",
        "optimization": "resonance peak against the family's value at each excitation, "
                        "one backbone per value; stars mark each curve's minimum",
    },
    "uncertainty": {
        "": "histogram of the peak over the samples, with the free and stuck levels and "
            "the limit whose exceedance is reported",
        "parameters": "the peak against each uncertain input, coloured by the share of "
                      "contact points slipping at the peak",
    },
}
WHOLE = {
    "peak": "resonance peak against the {par} (dashed where the peak's solution is "
            "unstable; a star marks the minimum of a mass or preload curve; the free and "
            "fully stuck levels as lines where drawn)",
    "loops": "hysteresis loops of the contact under the prescribed relative motion: "
             "tangential force against displacement at each amplitude",
    "transient": "time history of the outputs from rest under the excitation",
    "modes": "the reduced bodies' modes",
}


def caption(kind: str, name: str, picture: str, parameter: str = "frequency") -> str:
    """The caption of picture file ``picture`` (a name, .png) of analysis ``name`` of type
    ``kind``; ``parameter`` the swept one of an FRF or peak curve."""
    stem = picture.removesuffix(".png")
    suffix = stem[len(name) + 1:] if stem.startswith(name + "_") else \
        ("" if stem == name else stem)
    par = LABELS.get(parameter, parameter)
    if kind == "geometry":
        return _preview(suffix or stem)
    if kind in BY_SUFFIX and suffix in BY_SUFFIX[kind]:
        return BY_SUFFIX[kind][suffix].format(par=par)
    if suffix == "status":
        return STATUS
    if suffix == "normal_load":
        return NORMAL
    if suffix.startswith("shape_"):
        return SHAPE + f" ({suffix.removeprefix('shape_')})"
    if suffix == "slip":
        return SLIP
    if suffix.startswith("static_"):
        return STATIC.format(contact=suffix.removeprefix("static_"), par=par)
    if kind in WHOLE and not suffix:
        return WHOLE[kind].format(par=par)
    if kind in ("frf", "dti"):
        what = FRF.format(par=par)
        if kind == "dti":
            what = ("the harmonic balance's response (line) against the time integration's "
                    "steady states (markers) at the analysis' frequencies")
        return f"{suffix or name}: {what}"
    return stem.replace("_", " ")


def _preview(stem: str) -> str:
    """The mesh previews."""
    if stem.endswith("_contacts"):
        return "the contact patches and their node pairs on the mesh"
    if stem.endswith("_full_disk"):
        return "the full disk: the sector copied round the axis"
    if stem.endswith("_sector"):
        return "the meshed sector, bodies coloured"
    return stem.replace("_", " ")
