"""Parameter declarations: unit, default, checked range, validated before Gmsh runs.

A model's parameters are a frozen dataclass whose fields are declared with
:func:`param`; :func:`check_ranges` checks every field against its range and
:func:`require` states the cross-parameter rules (blade fits the pitch, damper
fits the pocket, ...). Both raise :class:`GeometryParameterError`, whose message
names the parameter, its value and the allowed range.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields


class GeometryParameterError(ValueError):
    """A geometry parameter is outside its allowed range (raised before Gmsh is called)."""


class GeometryBuildError(RuntimeError):
    """Gmsh failed; the message carries the parameters that caused it."""


@dataclass(frozen=True)
class Bound:
    """Interval [lo, hi] with optionally open ends."""

    lo: float
    hi: float
    lo_open: bool = False
    hi_open: bool = False

    def __contains__(self, value: float) -> bool:
        above = value > self.lo if self.lo_open else value >= self.lo
        below = value < self.hi if self.hi_open else value <= self.hi
        return above and below

    def __str__(self) -> str:
        return (
            f"{'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}{')' if self.hi_open else ']'}"
        )


def param(
    default,
    unit: str,
    lo: float,
    hi: float,
    doc: str,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    integer: bool = False,
):
    """Declare a dataclass field with unit, range and one-line meaning."""
    meta = {"unit": unit, "bound": Bound(lo, hi, lo_open, hi_open), "doc": doc, "integer": integer}
    return field(default=default, metadata=meta)


def positive_length(default: float, doc: str, hi: float = 10.0):
    """A length in (0, hi] m."""
    return param(default, "m", 0.0, hi, doc, lo_open=True)


def angle_deg(default: float, doc: str):
    """An angle in (0, 90) degrees."""
    return param(default, "deg", 0.0, 90.0, doc, lo_open=True, hi_open=True)


def grid_count(default: int, doc: str):
    """A node count of a structured contact grid direction, >= 2."""
    return param(default, "-", 2, 500, doc, integer=True)


def contact_size_param(faces: str = "contact flanks"):
    """The contact faces' element size [m] apart from the contact grid (0: the grid is the
    mesh), as ``geometry.averaging`` reads it."""
    return param(0.0, "m", 0.0, 10.0, f"element size on the {faces}; 0: the contact grid "
                 "is the mesh (one node per point)")


def root_fillet_param(part: str = "blade"):
    """Radius [m] of a fillet where ``part`` meets its platform (0: a sharp corner)."""
    return param(0.0, "m", 0.0, 0.02, f"radius of the fillet where the {part} meets the "
                 "platform; 0: a sharp corner")


def root_size_param(part: str = "blade"):
    """Element size [m] at ``part``'s root: its edges graded, or its fillet (0: none)."""
    return param(0.0, "m", 0.0, 10.0, f"element size at the {part}'s root: along its edges "
                 "graded to the blade's over 3 x blade_size (a sharp corner's stress "
                 "singularity), or over its fillet; 0: none")


def blade_layers_param(part: str = "blade"):
    """Prism layers along ``part`` above its root (0: tetrahedra)."""
    return param(0, "-", 0, 400, f"prism layers along the {part} above its root (its "
                 "section meshed at blade_size, two cells through the thickness at least); "
                 "0: tetrahedra", integer=True)


def check_ranges(params) -> None:
    """Raise GeometryParameterError for the first field outside its declared range."""
    owner = type(params).__name__
    for f in fields(params):
        value = getattr(params, f.name)
        meta = f.metadata
        unit = meta["unit"]
        if meta["integer"]:
            ok_type = isinstance(value, int) and not isinstance(value, bool)
        else:
            ok_type = isinstance(value, int | float) and not isinstance(value, bool)
        if not ok_type or not math.isfinite(value) or value not in meta["bound"]:
            kind = "an integer" if meta["integer"] else "a finite number"
            unit = "" if unit == "-" else f" {unit}"  # a count or ratio has no unit to say
            raise GeometryParameterError(
                f"{owner}.{f.name} = {value!r}{unit}: must be {kind} in "
                f"{meta['bound']}{unit} ({meta['doc']})"
            )


def require(ok: bool, name: str, value: float, allowed: str, why: str) -> None:
    """Cross-parameter rule: raise GeometryParameterError naming ``name`` unless ``ok``."""
    if not ok:
        raise GeometryParameterError(f"{name} = {value:.6g}: must be {allowed} ({why})")


def as_dict(params) -> dict:
    """JSON-serialisable dict of the parameter values, tagged with the class name."""
    return {"kind": type(params).__name__, **asdict(params)}


def describe(cls) -> list[tuple[str, str, object, str, str]]:
    """(name, unit, default, range, meaning) for every parameter of a parameter class."""
    return [
        (f.name, f.metadata["unit"], f.default, str(f.metadata["bound"]), f.metadata["doc"])
        for f in fields(cls)
    ]
