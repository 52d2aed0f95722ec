"""The [assembly] table of a case: reduced FE bodies joined by friction patches.

```toml
[assembly]
engine_order = 12            # default: [reduction] engine_order
speed = "frequency"          # centrifugal load's speed: rad/s, or "frequency": w / EO
centrifugal = ["damper"]     # bodies under centrifugal load (default: none)
mass_bodies = ["damper"]     # bodies the mass multiplier scales (default: the non-cyclic ones)
mass_multiplier = 1.0        # their mass as a multiple of the meshed one (analyses may sweep it)
excitation = 1.0             # multiplier of every load (a family over it: excitation levels)
static_anchor = 1e-3         # order-0 spring on the mean tangential slip of each pair touching a
                             # free body (a rigid mode: a damper), x kt (0: none)
[[assembly.contacts]]        # one per patch: a contact element per node pair
patch = "damper_left"        # a model's patch, or a contact of [geometry.contacts]
mu = 0.5
interference = 0.0           # [m] design interference (negative: gap); default 0
stiffness_scale = 1.0        # multiplier of the patch's flat-punch kn and kt; default 1
elements = "2D"              # "2D" (law D) or "1D+1D" (two law-B elements); default "2D"
[[assembly.loads]]           # amplitude cos(harmonic w t + phase) [N] over a node set
node_set = "blisk/excitation"
direction = "tangential"     # x y z radial tangential axial, or [dx, dy, dz]
amplitude = 1.0
harmonic = 1                 # default 1; 0: static
phase = 0.0                  # [deg], default 0
spread = "nodes"             # the force shared equally by the nodes, or "area": by their
                             #   tributary areas (a uniform traction over a face)
[[assembly.outputs]]         # what the analyses' outputs name: a node set's mean
name = "tip"                 #   displacement along a direction [m]
node_set = "blisk/response"
direction = "tangential"
```

Names (patches, bodies, node sets) are checked against ``geometry.NAMES`` of the case's
geometry model (and its declared contacts) before anything is meshed, or against an imported
mesh's own.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from microslip import geometry
from microslip.assembly.spec import (
    DIRECTIONS,
    ELEMENTS,
    SPREADS,
    STATIC_ANCHOR_RULE,
    AssemblySpec,
    NodalLoad,
    Output,
    PatchFriction,
    static_anchor_allowed,
)

from . import mistuning_table
from .checks import is_int, is_number, number, unknown_keys

KEYS = {"engine_order", "speed", "centrifugal", "mass_bodies", "mass_multiplier", "contacts",
        "loads", "outputs", "static_anchor", "excitation", "mistuning"}
CONTACT_KEYS = {"patch", "mu", "interference", "stiffness_scale", "elements"}
LOAD_KEYS = {"node_set", "direction", "amplitude", "harmonic", "phase", "spread"}
OUTPUT_KEYS = {"name", "node_set", "direction"}
#: Parameters an assembly case's analyses may sweep.
PARAMETERS = ("frequency", "excitation", "mass")
ANALYSES = ("frf", "peak", "uncertainty", "modes")


def output_names(data: Mapping[str, Any]) -> list[str]:
    """The outputs an analysis of an assembly case may name."""
    table = data.get("assembly", {})
    outs = table.get("outputs", []) if isinstance(table, dict) else []
    return [o.get("name") for o in outs if isinstance(o, dict)]


def check(table: Any, data: Mapping[str, Any], out: list[str],
          names: Mapping[str, Any] | None = None) -> None:
    """Append one line per fault of a case's [assembly] table to ``out``. ``names``: the
    geometry's patches, bodies and node sets when the case's [geometry] gives them (a
    parametric model's ``geometry.NAMES`` and its declared contacts, an imported mesh's
    own); None: not checked here."""
    if not isinstance(table, dict):
        out.append(f"assembly: expected a table, got {table!r}")
        return
    unknown_keys("assembly.", table, KEYS, out)
    if "reduction" not in data or "geometry" not in data:
        out.append("assembly: needs [geometry] and [reduction] (the bodies it joins)")
    if "model" in data:
        out.append("model: an assembly case takes its bodies from [geometry] and [reduction]; "
                   "remove [model] (or [assembly])")
    geo = data.get("geometry", {})
    if (isinstance(geo, dict) and geo.get("model") in geometry.MODELS
            and geo.get("model") not in geometry.NAMES and not geo.get("contacts")):
        out.append(f"assembly: geometry model {geo.get('model')!r} has no contact patches; "
                   f"assembly models: {sorted(geometry.NAMES)}, or declare contacts in "
                   "[geometry.contacts.<name>]")
    red = data.get("reduction", {})
    eo = table.get("engine_order", red.get("engine_order") if isinstance(red, dict) else None)
    if eo is None:
        out.append("assembly.engine_order: missing (and no [reduction] engine_order): the "
                   "engine order of the excitation")
    elif not (is_int(eo) and eo >= 1):
        out.append(f"assembly.engine_order = {eo!r}: expected an integer >= 1")
    speed = table.get("speed")
    if speed is not None and speed != "frequency" and not (is_number(speed) and speed >= 0):
        out.append(f"assembly.speed = {speed!r}: expected a rotation speed >= 0 [rad/s] or "
                   "'frequency' (speed = w / engine order)")
    for key in ("centrifugal", "mass_bodies"):
        bodies = table.get(key, [])
        if not (isinstance(bodies, list) and all(isinstance(b, str) for b in bodies)):
            out.append(f"assembly.{key} = {bodies!r}: expected a list of body names")
        elif names is not None:
            for b in bodies:
                if b not in names["bodies"]:
                    out.append(f"assembly.{key}: {b!r} is not a body; bodies: "
                               f"{list(names['bodies'])}")
    for key in ("mass_multiplier", "excitation"):
        if key in table:
            number(f"assembly.{key}", table[key], out, positive=True)
    anchor = table.get("static_anchor", AssemblySpec.static_anchor)
    if not static_anchor_allowed(anchor):
        out.append(f"assembly.static_anchor = {anchor!r}: expected {STATIC_ANCHOR_RULE}")
    if table.get("centrifugal") and "speed" not in table:
        out.append("assembly.speed: missing; the centrifugal load needs a speed [rad/s] or "
                   "'frequency'")
    _contacts(table, names, out)
    _loads(table, names, out)
    _outputs(table, names, out)
    if "mistuning" in table:
        params = geo.get("parameters", {}) if isinstance(geo, dict) else {}
        sectors = params.get("sectors") if isinstance(params, dict) else None
        mistuning_table.check(table["mistuning"], out, names,
                              sectors if is_int(sectors) else None)


def _contacts(table: dict, names: Mapping[str, Any] | None, out: list[str]) -> None:
    """[[assembly.contacts]]: a known patch each, once, its friction coefficient and
    optional interference, stiffness scale and elements."""
    contacts = _tables(table, "contacts", out, required=True)
    seen = set()
    for i, c in enumerate(contacts):
        pre = f"assembly.contacts[{c.get('patch', i)}]"
        unknown_keys(pre + ".", c, CONTACT_KEYS, out)
        patch = c.get("patch")
        if names is not None and patch not in names["patches"]:
            out.append(f"{pre}.patch = {patch!r}: not a contact of the geometry; contacts: "
                       f"{list(names['patches'])}")
        if patch in seen:
            out.append(f"{pre}: patch {patch!r} given twice")
        seen.add(patch)
        if "mu" not in c:
            out.append(f"{pre}.mu: missing; the friction coefficient (>= 0)")
        else:
            number(f"{pre}.mu", c["mu"], out, nonneg=True)
        if "interference" in c:
            number(f"{pre}.interference", c["interference"], out)
        if "stiffness_scale" in c:
            number(f"{pre}.stiffness_scale", c["stiffness_scale"], out, positive=True)
        if c.get("elements", PatchFriction.elements) not in ELEMENTS:
            out.append(f"{pre}.elements = {c.get('elements')!r}: expected one of "
                       f"{list(ELEMENTS)}")


def _loads(table: dict, names: Mapping[str, Any] | None, out: list[str]) -> None:
    """[[assembly.loads]]: a node set, a direction, an amplitude, harmonic, phase, spread."""
    for i, ld in enumerate(_tables(table, "loads", out)):
        pre = f"assembly.loads[{i}]"
        unknown_keys(pre + ".", ld, LOAD_KEYS, out)
        _node_set(pre, ld, names, out)
        _direction(pre, ld, out)
        number(f"{pre}.amplitude", ld.get("amplitude"), out)
        if "harmonic" in ld and not (is_int(ld["harmonic"]) and ld["harmonic"] >= 0):
            out.append(f"{pre}.harmonic = {ld['harmonic']!r}: expected an integer >= 0")
        if "phase" in ld:
            number(f"{pre}.phase", ld["phase"], out)
        if ld.get("spread", NodalLoad.spread) not in SPREADS:
            out.append(f"{pre}.spread = {ld.get('spread')!r}: expected one of {list(SPREADS)}")


def _outputs(table: dict, names: Mapping[str, Any] | None, out: list[str]) -> None:
    """[[assembly.outputs]]: a unique name each, a node set and a direction."""
    outputs = _tables(table, "outputs", out, required=True)
    seen = set()
    for i, o in enumerate(outputs):
        pre = f"assembly.outputs[{o.get('name', i)}]"
        unknown_keys(pre + ".", o, OUTPUT_KEYS, out)
        if not isinstance(o.get("name"), str) or not o.get("name"):
            out.append(f"{pre}.name: expected a name (the analyses' outputs use it)")
        elif o["name"] in seen:
            out.append(f"{pre}.name: {o['name']!r} given twice")
        seen.add(o.get("name"))
        _node_set(pre, o, names, out)
        _direction(pre, o, out)


def _tables(table: dict, key: str, out: list[str], required: bool = False) -> list[dict]:
    value = table.get(key, [])
    if not isinstance(value, list) or not all(isinstance(x, dict) for x in value):
        out.append(f"assembly.{key}: expected an array of tables [[assembly.{key}]]")
        return []
    if required and not value:
        out.append(f"assembly.{key}: missing; add at least one [[assembly.{key}]]")
    return value


def _node_set(pre: str, t: dict, names: Mapping | None, out: list[str]) -> None:
    ns = t.get("node_set")
    if not isinstance(ns, str):
        out.append(f"{pre}.node_set = {ns!r}: expected a node-set name")
    elif names is not None and ns not in names["node_sets"]:
        out.append(f"{pre}.node_set = {ns!r}: not a node set of the geometry; node sets: "
                   f"{list(names['node_sets'])}")


def _direction(pre: str, t: dict, out: list[str]) -> None:
    d = t.get("direction")
    ok = d in DIRECTIONS or (isinstance(d, list) and len(d) == 3 and all(
        is_number(x) for x in d) and any(x != 0 for x in d))
    if not ok:
        out.append(f"{pre}.direction = {d!r}: expected one of {list(DIRECTIONS)} or a "
                   "non-zero [dx, dy, dz]")


def names_of(mesh: Any) -> dict[str, tuple[str, ...]]:
    """A mesh's contacts, bodies and node sets, as ``geometry.NAMES`` gives a model's."""
    return {"patches": tuple(sorted(mesh.contacts)), "bodies": tuple(sorted(mesh.bodies)),
            "node_sets": tuple(sorted(mesh.node_sets))}


def spec(data: Mapping[str, Any], bodies: tuple[str, ...], cyclic_bodies: tuple[str, ...] = ()
         ) -> AssemblySpec:
    """The AssemblySpec of a validated case (``bodies``: the mesh's; ``cyclic_bodies``: its
    cyclic ones, whose complement the mass multiplier scales by default)."""
    table = data["assembly"]
    eo = int(table.get("engine_order", data.get("reduction", {}).get("engine_order", 1)))
    speed = table.get("speed")
    return AssemblySpec(
        contacts=tuple(PatchFriction(c["patch"], float(c["mu"]),
                                    float(c.get("interference", PatchFriction.interference)),
                                    c.get("elements", PatchFriction.elements),
                                    float(c.get("stiffness_scale",
                                                PatchFriction.stiffness_scale)))
                       for c in table["contacts"]),
        engine_order=eo,
        loads=tuple(NodalLoad(ld["node_set"], _dir(ld["direction"]), float(ld["amplitude"]),
                              int(ld.get("harmonic", 1)), math.radians(ld.get("phase", 0.0)),
                              ld.get("spread", NodalLoad.spread))
                    for ld in table.get("loads", [])),
        outputs=tuple(Output(o["name"], o["node_set"], _dir(o["direction"]))
                      for o in table["outputs"]),
        speed=None if speed in (None, "frequency") else float(speed),
        centrifugal=tuple(table.get("centrifugal", ())),
        mass_bodies=tuple(table.get("mass_bodies",
                                    [b for b in bodies if b not in cyclic_bodies])),
        static_anchor=float(table.get("static_anchor", AssemblySpec.static_anchor)),
    )


def _dir(d):
    return d if isinstance(d, str) else tuple(float(x) for x in d)

