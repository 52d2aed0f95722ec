"""Whether an imported model is plausible in the units it was read in.

A deck carries no unit: the same numbers are a 40 mm steel blade in mm-t-s and a 40 m blade
of E = 2.1e5 Pa in SI. A deck read in the wrong system still solves, to answers off by
orders of magnitude (frequencies, folds, NaN exponents), so the run says what it assumed
and warns where a body's size or material is far from any blade, disk or damper:

- size: every body between 0.5 mm and 10 m across (bounding-box diagonal [m]: a damper's
  few millimetres to a large fan's annulus);
- material: E between 1e8 Pa and 1.2e12 Pa (polymers and composites to tungsten carbide),
  density between 100 and 25,000 kg/m^3 (foams to tungsten), and the bar wave speed
  sqrt(E / rho) between 300 and 20,000 m/s (the ratio a unit mix-up moves most).

Where another unit system of ``geometry.imported.UNITS`` makes every number plausible,
the warning names it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from microslip.geometry.imported import UNITS, Units

#: Plausible ranges (see the module) [m], [Pa], [kg/m^3], [m/s].
SIZE = (5e-4, 10.0)
MODULUS = (1e8, 1.2e12)
DENSITY = (100.0, 25_000.0)
WAVE_SPEED = (300.0, 20_000.0)


@dataclass(frozen=True)
class BodyNumbers:
    """One body as read: its size across [m] and, where known, E [Pa] and density
    [kg/m^3] with whether they come from the file's cards (which scale with its units)."""

    body: str
    size: float
    modulus: float | None = None
    density: float | None = None
    from_file: bool = False


def faults(b: BodyNumbers) -> list[str]:
    """What is implausible about one body (phrases; empty: nothing)."""
    out = []
    if not SIZE[0] <= b.size <= SIZE[1]:
        out.append(f"{b.size:.3g} m across (a blade, disk or damper: {SIZE[0]:g}..{SIZE[1]:g} m)")
    if b.modulus is not None and not MODULUS[0] <= b.modulus <= MODULUS[1]:
        out.append(f"E = {b.modulus:.3g} Pa (metals and composites: {MODULUS[0]:.0e}.."
                   f"{MODULUS[1]:.1e} Pa)")
    if b.density is not None and not DENSITY[0] <= b.density <= DENSITY[1]:
        out.append(f"density {b.density:.3g} kg/m^3 ({DENSITY[0]:g}..{DENSITY[1]:,.0f})")
    if b.modulus and b.density and b.modulus > 0 and b.density > 0:
        c = math.sqrt(b.modulus / b.density)
        if not WAVE_SPEED[0] <= c <= WAVE_SPEED[1]:
            out.append(f"sqrt(E / density) = {c:.3g} m/s ({WAVE_SPEED[0]:g}.."
                       f"{WAVE_SPEED[1]:,.0f} m/s in any solid)")
    return out


def read_in(b: BodyNumbers, read: Units, other: Units) -> BodyNumbers:
    """The body's numbers had its file been read in ``other`` units instead of ``read``
    (a material given in the case is SI whatever the file's units)."""
    def scaled(value: float | None, factor: float) -> float | None:
        return value * factor if b.from_file and value is not None else value

    return BodyNumbers(b.body, b.size * other.length / read.length,
                       scaled(b.modulus, other.stress / read.stress),
                       scaled(b.density, other.density / read.density), b.from_file)


def unit_lines(bodies: list[BodyNumbers], units: str, given: bool, file: str
               ) -> tuple[list[str], list[str]]:
    """(notes, warnings) on an imported model read in ``units`` (``given``: the case says
    so; else the default was assumed)."""
    notes = [] if given else [
        f"geometry.units not given: {file} is read in {units} (m, kg, s; E in Pa, density in "
        "kg/m^3); give units = \"mm-t-s\" for a deck in millimetres (or say units = "
        f"\"{units}\")"]
    read = UNITS[units]
    warnings = []
    for b in bodies:
        found = faults(b)
        if not found:
            continue
        fits = [u.name for u in UNITS.values() if u.name != units
                and all(not faults(read_in(x, read, u)) for x in bodies)]
        hint = (f"; every body is plausible in units = \"{fits[0]}\"" if fits else
                "; check geometry.units and the material")
        warnings.append(f"body {b.body} read in {units} is implausible: {', '.join(found)}"
                        + hint)
    return notes, warnings


def imported_bodies(mesh: Any, materials: Mapping[str, Any]) -> list[BodyNumbers]:
    """The numbers of each body of an imported ``mesh`` (SI, as read); ``materials``: body
    -> its fe.Material as the case resolves it, or "file" (the deck's cards), or absent."""
    cards = mesh.parameters.get("materials", {})
    out = []
    for body in sorted(mesh.bodies):
        x = mesh.points[mesh.body_nodes(body)]
        size = float(np.linalg.norm(np.ptp(x, axis=0))) if len(x) else 0.0
        m = materials.get(body)
        if m == "file" and isinstance(cards.get(body), dict):
            card = cards[body]
            if "zones" in card:  # several materials: the one of most elements
                card = max(card["zones"], key=lambda z: len(z["elements"]))
            out.append(BodyNumbers(body, size, card["youngs_modulus"], card["density"], True))
        elif m is not None and m != "file":
            out.append(BodyNumbers(body, size, m.youngs_modulus, m.density))
        else:
            out.append(BodyNumbers(body, size))
    return out


#: CAD files that declare their own length unit (converted to metres on reading).
SELF_DESCRIBING = (".step", ".stp", ".iges", ".igs")


def case_unit_lines(data: Mapping[str, Any]) -> tuple[list[str], list[str]]:
    """(notes, warnings) on the units of a valid case's imported mesh (none for a parametric
    model, which is SI by construction): the unit assumed when the case gives none, and each
    body implausible in it, with the materials the [reduction] gives each body."""
    from pathlib import Path

    from .geometry_table import GeometryTable
    from .reduction_table import ReductionTable

    geo = data.get("geometry")
    if not (isinstance(geo, Mapping) and geo.get("model") == "import"):
        return [], []
    table = GeometryTable.of(geo)
    mesh = table.build()
    materials: dict[str, Any] = {}
    if "reduction" in data:
        red = ReductionTable.of(data["reduction"])
        for body in mesh.bodies:
            own = red.bodies.get(body)
            materials[body] = own.material if own and own.material is not None else \
                red.material
    name = Path(table.file).name
    given = "units" in geo or Path(name).suffix.lower() in SELF_DESCRIBING
    return unit_lines(imported_bodies(mesh, materials), table.units, given, name)
