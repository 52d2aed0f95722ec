"""The [reduction] table of a case: validated before any meshing, and read into the body
specs and patch stiffnesses the structural stage (app.structure) reduces.

The table (all keys optional but one of ``nodal_diameters`` or
``engine_order``):

    nodal_diameters = [0, 1, 2, 3]   # explicit, or:
    engine_order = 3                 # with harmonics = H: the NDs of harmonics 0..H
    harmonics = 3                    # default: the case's [harmonics] max, else 1
    order = 2                        # element order (1: linear tets, a trade, see the bench)
    modes = "auto"                   # fixed-interface modes: "auto" (cut-off) or a count
    cutoff = 4.0                     # "auto": modes below cutoff x f_max
    f_max = 12000.0                  # [Hz] highest frequency of interest, for EVERY body
    backend = "auto"                 # "pardiso", "superlu" or "auto" (by size)
    [reduction.material]             # default for every body: steel
    youngs_modulus = 2.0e11          # [Pa]
    poisson_ratio = 0.3
    density = 7850.0                 # [kg/m^3]
    [reduction.damping]              # linear damping of every body, applied to the reduced
    modal_ratios = 0.001             # models (no re-reduction): zeta (one, or per elastic
    rayleigh_alpha = 0.0             # mode) and/or C = alpha M + beta K  [1/s], [s]
    [reduction.bodies.<body>]        # per body: material, damping, modes, clamped, masters,
                                     # recovery, supports:
    supports = [{ set = "hub", held = ["z"] },                             # x, y, z
                { set = "rim", held = ["r", "theta"], frame = "cylindrical" }]  # about +z
    [reduction.contact_stiffness.<patch>]  # normal, tangential per unit area [N/m^3]

Conventions from the geometry models' node-set names: a body is clamped on ``<body>/bore``
or ``<body>/clamp``; its masters are every contact-patch node it owns plus ``<body>/excitation``
and ``<body>/response``; the recovery matrix is kept on the masters plus ``<body>/response``,
``<body>/tip`` and ``<body>/blade_tip`` (what outputs and pictures use).

Without ``f_max``, the cyclic bodies choose their modes by their own 10th fixed-interface
frequency and the other bodies (the free damper, whose fixed-interface modes are all far above
the disk's) get as f_max the highest frequency the cyclic bodies resolve: the damper keeps a
few modes instead of every mode below 4x its own 10th (249 for the default blisk's damper).

Supports hold a node set's nodes in some directions only: of the model frame ("global", x, y,
z) or cylindrical about the model's +z axis (the disk axis of a cyclic model: r, theta, z).
An imported deck's own supports (``*BOUNDARY``, ``Mesh.supports``) hold its bodies too, beside
``clamped`` and the case's supports. A supported node cannot be a master.

Reduced models are cached in ``<out>/models/cb-<hash>.h5``: a re-run reuses every body and ND
whose mesh, material, constraints, masters and mode selection have not changed.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from microslip.fe import bodies, contact_stiffness, cyclic, linalg, reduced_model
from microslip.fe.bodies import BodySpec
from microslip.fe.fem import Damping, Material, MaterialZones
from microslip.geometry.boundaries import ContactPatch, Support
from microslip.geometry.full_disk import sector_count
from microslip.geometry.pairing import paired_contact

from .checks import is_int, is_number, unknown_keys
from .geometry_table import GeometryTable
from .mistuning_table import MistuningTable

STEEL = Material(2.0e11, 0.3, 7850.0)
FROM_FILE = "file"  # material = "file": each body's from the imported deck's cards
KEYS = {"nodal_diameters", "engine_order", "harmonics", "order", "modes", "cutoff", "f_max",
        "backend", "material", "damping", "bodies", "contact_stiffness"}
BODY_KEYS = {"material", "damping", "modes", "clamped", "masters", "recovery", "supports"}
SUPPORT_KEYS = {"set", "held", "frame"}
#: a case's support frames, with their directions' names
SUPPORT_FRAMES = {"global": ("x", "y", "z"), "cylindrical": ("r", "theta", "z")}
DAMPING_KEYS = {"rayleigh_alpha", "rayleigh_beta", "modal_ratios"}
MATERIAL_KEYS = {"youngs_modulus", "poisson_ratio", "density"}
STIFFNESS_KEYS = {"normal", "tangential"}
BACKENDS = ("auto", *linalg.BACKENDS)
_CLAMP_SETS = ("bore", "clamp")
_MASTER_SETS = ("excitation", "response")
_RECOVERY_SETS = ("response", "tip", "blade_tip")



def check(red: Any, data: Mapping[str, Any], out: list[str],
          geometry: GeometryTable | None = None) -> None:
    """Append one line per fault of a case's [reduction] table to ``out``; ``geometry``:
    the case's [geometry] as checked (None: invalid or missing, reported there)."""
    if not isinstance(red, dict):
        out.append(f"reduction: expected a table, got {red!r}")
        return
    unknown_keys("reduction.", red, KEYS, out)
    if "geometry" not in data:
        out.append("reduction: needs a [geometry] table (the mesh to reduce)")
    sectors = geometry.sectors if geometry is not None else None
    if geometry is None and "geometry" in data:
        pass  # a [geometry] with a fault (said there): its symmetry is not known
    elif sectors is None:
        for k in ("nodal_diameters", "engine_order", "harmonics"):
            if k in red:
                out.append(f"reduction.{k}: the geometry model has no cyclic symmetry; remove "
                           "it")
    elif ("nodal_diameters" in red) == ("engine_order" in red):
        out.append("reduction: give either nodal_diameters = [...] or engine_order (with "
                   "harmonics), exactly one")
    elif "harmonics" in red and "engine_order" not in red:
        out.append("reduction.harmonics: only with engine_order (the NDs of harmonics 0..H)")
    nds = red.get("nodal_diameters")
    if nds is not None and not (isinstance(nds, list) and nds and all(
            is_int(h) and h >= 0 for h in nds)):
        out.append(f"reduction.nodal_diameters = {nds!r}: expected a non-empty list of "
                   "integers >= 0 (each at most sectors / 2)")
    elif nds is not None and sectors is not None and max(nds) > sectors // 2:
        out.append(f"reduction.nodal_diameters = {nds!r}: at most sectors / 2 = "
                   f"{sectors // 2} (the geometry has {sectors} sectors)")
    if red.get("backend", ReductionTable.backend) in linalg.BACKENDS and red["backend"] not in \
            linalg.available_backends():
        out.append(f"reduction.backend = {red['backend']!r}: not installed here; available: "
                   f"{list(linalg.available_backends())} or 'auto'")
    for key, ok, allowed in (
        ("engine_order", is_int, "an integer"),
        ("harmonics", lambda v: is_int(v) and v >= 0, "an integer >= 0 (orders 0..H)"),
        ("order", lambda v: v in (1, 2), "1 or 2"),
        ("modes", _is_modes, "'auto' or an integer >= 0"),
        ("cutoff", lambda v: is_number(v) and v >= 1.0, "a number >= 1"),
        ("f_max", lambda v: is_number(v) and v > 0.0, "a frequency > 0 [Hz]"),
        ("backend", lambda v: v in BACKENDS, f"one of {list(BACKENDS)}"),
    ):
        if key in red and not ok(red[key]):
            out.append(f"reduction.{key} = {red[key]!r}: expected {allowed}")
    _check_material("reduction.material", red.get("material"), out)
    imported = isinstance(data.get("geometry"), dict) and data["geometry"].get("model") == \
        "import"
    given = [("reduction.material", red.get("material"))] + [
        (f"reduction.bodies.{n}.material", b.get("material"))
        for n, b in (red.get("bodies") or {}).items() if isinstance(b, dict)]
    for key, value in given:
        if value == FROM_FILE and not imported:
            out.append(f"{key} = \"file\": only an imported mesh (model = \"import\") has "
                       "material cards; give the material in SI")
    _check_damping("reduction.damping", red.get("damping"), out)
    for name, b in _table_of(red, "bodies", out).items():
        pre = f"reduction.bodies.{name}"
        unknown_keys(f"{pre}.", b, BODY_KEYS, out)
        if not isinstance(b, dict):
            continue
        _check_material(f"{pre}.material", b.get("material"), out)
        _check_damping(f"{pre}.damping", b.get("damping"), out)
        if "modes" in b and not _is_modes(b["modes"]):
            out.append(f"{pre}.modes = {b['modes']!r}: expected 'auto' or an integer >= 0")
        for k in ("clamped", "masters", "recovery"):
            if k in b and not (isinstance(b[k], list) and all(isinstance(s, str)
                                                              for s in b[k])):
                out.append(f"{pre}.{k} = {b[k]!r}: expected a list of node-set names")
        _check_supports(pre, b.get("supports", []), out)
    for name, s in _table_of(red, "contact_stiffness", out).items():
        pre = f"reduction.contact_stiffness.{name}"
        if not isinstance(s, dict) or set(s) != STIFFNESS_KEYS:
            out.append(f"{pre}: expected a table with exactly {sorted(STIFFNESS_KEYS)} "
                       "[N/m^3]")
            continue
        for k in sorted(STIFFNESS_KEYS):
            if not (is_number(s[k]) and s[k] > 0.0):
                out.append(f"{pre}.{k} = {s[k]!r}: expected a stiffness per area > 0 [N/m^3]")


def _check_supports(pre: str, supports: Any, out: list[str]) -> None:
    """One line per fault of a body's ``supports`` list."""
    if not isinstance(supports, list):
        out.append(f"{pre}.supports = {supports!r}: expected a list of tables {{ set = "
                   "\"<node set>\", held = [\"x\", ...], frame = \"global\" }")
        return
    for i, item in enumerate(supports):
        where = f"{pre}.supports[{i}]"
        if not isinstance(item, dict):
            out.append(f"{where} = {item!r}: expected a table with set, held (and frame)")
            continue
        unknown_keys(f"{where}.", item, SUPPORT_KEYS, out)
        if not isinstance(item.get("set"), str):
            out.append(f"{where}.set = {item.get('set')!r}: expected a node-set name")
        frame = item.get("frame", "global")
        if frame not in SUPPORT_FRAMES:
            out.append(f"{where}.frame = {frame!r}: expected one of {list(SUPPORT_FRAMES)}")
            continue
        names = SUPPORT_FRAMES[frame]
        held = item.get("held")
        misspelt = any(difflib.get_close_matches(str(k), ["held"], n=1)
                       for k in item if k not in SUPPORT_KEYS)  # said by unknown_keys
        if held is None:
            if not misspelt:
                out.append(f"{where}.held: missing; the directions held, among {list(names)}")
        elif not (isinstance(held, list) and held and all(h in names for h in held)
                and len(set(held)) == len(held)):
            out.append(f"{where}.held = {held!r}: expected a non-empty list of distinct "
                       f"directions of the {frame} frame, among {list(names)}")


def names_faults(mesh: Any, red: Any, out: list[str]) -> None:
    """The fault (one line) of a body, node set or patch the [reduction] table names, or its
    conventions need, that ``mesh`` lacks (an imported mesh is read at check time)."""
    try:
        for spec in body_specs(mesh, ReductionTable.of(red)):
            if not bodies.spec_nodes(mesh, spec)[0].size:
                out.append(f"reduction.bodies.{spec.body}.masters: body {spec.body!r} has no "
                           "master node (no contact, excitation or response set); name its "
                           f"interface node sets; node sets: {sorted(mesh.node_sets)}")
    except ValueError as exc:  # (a message naming its key already says where)
        out.append(str(exc) if str(exc).startswith("reduction") else f"reduction: {exc}")


def _table_of(red: Mapping[str, Any], key: str, out: list[str]) -> dict:
    """red[key] if it is a table (of bodies, of patches), else {} and a fault."""
    value = red.get(key, {})
    if isinstance(value, dict):
        return value
    out.append(f"reduction.{key} = {value!r}: expected a table of named tables")
    return {}


def _is_modes(v: Any) -> bool:
    return v == "auto" or (is_int(v) and v >= 0)



def _check_material(pre: str, m: Any, out: list[str]) -> None:
    if m is None or m == FROM_FILE:  # ("file": the imported mesh's, checked with its names)
        return
    if not isinstance(m, dict) or set(m) != MATERIAL_KEYS:
        out.append(f"{pre}: expected a table with exactly {sorted(MATERIAL_KEYS)}, or "
                   f"{FROM_FILE!r} (an imported deck's material cards)")
        return
    bad = [k for k in sorted(MATERIAL_KEYS) if not is_number(m[k])]
    if bad:
        out.append(f"{pre}: {', '.join(f'{k} = {m[k]!r}' for k in bad)}: expected numbers")
        return
    try:
        material(m)
    except ValueError as e:
        out.append(f"{pre}: {e}")


def _check_damping(pre: str, d: Any, out: list[str]) -> None:
    if d is None:
        return
    if not isinstance(d, dict) or not d or set(d) - DAMPING_KEYS:
        out.append(f"{pre}: expected a table with some of {sorted(DAMPING_KEYS)}")
        return
    ratios = d.get("modal_ratios", 0.0)
    ratios = ratios if isinstance(ratios, list) else [ratios]
    if not all(is_number(v) for v in [d.get("rayleigh_alpha", 0.0),
                                       d.get("rayleigh_beta", 0.0), *ratios]):
        out.append(f"{pre} = {d!r}: expected numbers (modal_ratios: a number or a list)")
        return
    try:
        damping(d)
    except (TypeError, ValueError) as e:
        out.append(f"{pre}: {e}")


def damping(table: Mapping[str, Any] | None) -> Damping | None:
    """Damping from a case table (rayleigh_alpha [1/s], rayleigh_beta [s], modal_ratios: one
    zeta or a list per elastic mode)."""
    if table is None:
        return None
    ratios = table.get("modal_ratios", ())
    ratios = (ratios,) if isinstance(ratios, int | float) else tuple(ratios)
    return Damping(float(table.get("rayleigh_alpha", 0.0)),
                   float(table.get("rayleigh_beta", 0.0)), tuple(float(z) for z in ratios))


def material(table: Mapping[str, Any] | str | None, default: Material | str = STEEL
             ) -> Material | str:
    """Material from a case table (keys youngs_modulus, poisson_ratio, density), or
    FROM_FILE (the imported mesh's cards, resolved per body by ``body_specs``)."""
    if table is None:
        return default
    if table == FROM_FILE:
        return FROM_FILE
    return Material(float(table["youngs_modulus"]), float(table["poisson_ratio"]),
                    float(table["density"]))


@dataclass(frozen=True, kw_only=True)
class BodyTable:
    """[reduction.bodies.<body>]: what one body overrides (None: the table's, or the
    naming conventions' node sets)."""

    material: Material | str | None = None  # (str: FROM_FILE)
    damping: Damping | None = None
    damping_given: bool = False  # an explicit damping table (no damping at all is None)
    modes: int | str | None = None
    clamped: tuple[str, ...] | None = None
    masters: tuple[str, ...] | None = None
    recovery: tuple[str, ...] | None = None
    supports: tuple[tuple[str, tuple[str, ...], str], ...] = ()  # (set, held, frame)


@dataclass(frozen=True, kw_only=True)
class ReductionTable:
    """A validated [reduction] table with every default resolved (the module docstring):
    the NDs (explicit, or by engine order and harmonics), the element order, the modes and
    their cut-off, f_max [Hz], the factorization backend, material and damping, per-body
    overrides and per-patch contact stiffness per unit area (normal, tangential) [N/m^3]."""

    nodal_diameters: tuple[int, ...] | None = None
    engine_order: int | None = None
    harmonics: int | None = None
    order: int = 2
    modes: int | str = reduced_model.DEFAULT_MODES
    cutoff: float = reduced_model.CUTOFF
    f_max: float | None = None
    backend: str = "auto"
    material: Material | str = STEEL  # (str: FROM_FILE)
    damping: Damping | None = None
    bodies: Mapping[str, BodyTable] = field(default_factory=dict)
    contact_stiffness: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    mistuning: MistuningTable | None = None  # [assembly.mistuning]: the blade region kept

    @property
    def factorization(self) -> str | None:
        """The factorization backend the solvers take (None: the best available, "auto")."""
        return None if self.backend == "auto" else self.backend

    @classmethod
    def of(cls, table: Mapping[str, Any] | ReductionTable,
           mistuning: MistuningTable | None = None) -> ReductionTable:
        """The spec of a validated [reduction] table (a spec is returned as it is);
        ``mistuning``: the case's [assembly.mistuning], whose blade region every ND of its
        body keeps (and every ND is reduced)."""
        if isinstance(table, ReductionTable):
            return table
        base = material(table.get("material"))
        bodies = {}
        for body, b in table.get("bodies", {}).items():
            bodies[body] = BodyTable(
                material=material(b["material"], base) if "material" in b else None,
                damping=damping(b.get("damping")), damping_given="damping" in b,
                modes=b.get("modes"),
                supports=tuple((t["set"], tuple(t["held"]), t.get("frame", "global"))
                               for t in b.get("supports", [])),
                **{k: tuple(b[k]) for k in ("clamped", "masters", "recovery") if k in b})
        return cls(
            nodal_diameters=None if "nodal_diameters" not in table else tuple(
                sorted({int(h) for h in table["nodal_diameters"]})),
            engine_order=None if "engine_order" not in table else int(table["engine_order"]),
            harmonics=None if "harmonics" not in table else int(table["harmonics"]),
            order=int(table.get("order", cls.order)),
            modes=table.get("modes", cls.modes),
            cutoff=float(table.get("cutoff", cls.cutoff)),
            f_max=None if "f_max" not in table else float(table["f_max"]),
            backend=table.get("backend", cls.backend),
            material=base, damping=damping(table.get("damping")), bodies=bodies,
            contact_stiffness={name: (float(t["normal"]), float(t["tangential"]))
                               for name, t in table.get("contact_stiffness", {}).items()},
            mistuning=mistuning)


def needed_nodal_diameters(red: Mapping[str, Any] | ReductionTable, sectors: int,
                           case_orders: Iterable[int] | None = None) -> tuple[int, ...]:
    """The NDs of a [reduction] table: explicit, or those of the harmonic orders under the
    engine order (``cyclic.nodal_diameters``: backward waves fold onto 0..Ns/2). Orders:
    0..``harmonics`` of the table, else the case's harmonic orders (``case_orders``), else
    0..1; order 0 (the static part, ND 0) always. A mistuned case: every ND 0..Ns/2
    (the whole annulus is built from them all)."""
    red = ReductionTable.of(red)
    if red.mistuning is not None:
        return tuple(range(sectors // 2 + 1))
    if red.nodal_diameters is not None:
        nds = red.nodal_diameters
        for h in nds:
            if not 0 <= h <= sectors // 2:
                raise ValueError(f"reduction.nodal_diameters = {list(nds)}: ND {h} outside "
                                 f"0..{sectors // 2} (sectors = {sectors})")
        return nds
    if red.harmonics is not None:
        orders = set(range(red.harmonics + 1))
    else:
        orders = set(case_orders) if case_orders is not None else {0, 1}
    return cyclic.nodal_diameters(sorted(orders | {0}), red.engine_order, sectors)


def _existing(mesh: Any, body: str, suffixes: Sequence[str]) -> tuple[str, ...]:
    return tuple(f"{body}/{s}" for s in suffixes if f"{body}/{s}" in mesh.node_sets)


def _sets(given: tuple[str, ...] | None, mesh: Any, body: str, suffixes: Sequence[str]
          ) -> tuple[str, ...]:
    """The node sets a body names (an empty list is a choice too), else the conventions'."""
    return given if given is not None else _existing(mesh, body, suffixes)


def _resolved(m: Material | str, mesh: Any, body: str) -> Material:
    """A body's material, FROM_FILE read from the imported mesh's cards (ValueError naming
    the body and why the file gives none)."""
    if m != FROM_FILE:
        return m
    found = mesh.parameters.get("materials", {}).get(body, "the mesh is not an imported deck")
    if isinstance(found, str):
        raise ValueError(f"reduction: material = \"file\" for body {body!r}, but {found}; "
                         "give [reduction.bodies.<body>.material] in SI")
    if "zones" in found:  # a body of several materials
        return MaterialZones(tuple(
            (Material(z["youngs_modulus"], z["poisson_ratio"], z["density"]),
             np.asarray(z["elements"], dtype=np.int64)) for z in found["zones"]))
    return Material(found["youngs_modulus"], found["poisson_ratio"], found["density"])


def body_specs(mesh: Any, red: Mapping[str, Any] | ReductionTable, surfaces: bool = False
               ) -> list[BodySpec]:
    """One BodySpec per body of the mesh, by the naming conventions and the case's overrides;
    ``surfaces``: every body also recovered on its outer surface (deformed-shape pictures)."""
    red = ReductionTable.of(red)
    if red.mistuning is not None:
        _whole_disk_faults(mesh)
    specs = []
    for body in sorted(mesh.bodies):
        b = red.bodies.get(body, BodyTable())
        patches = tuple(sorted(name for name, p in mesh.contacts.items()
                               if body in (p.body_a, p.body_b)))
        specs.append(BodySpec(
            body=body,
            material=_resolved(b.material or red.material, mesh, body),
            damping=b.damping if b.damping_given else red.damping,
            master_sets=_sets(b.masters, mesh, body, _MASTER_SETS),
            patches=patches,
            recovery_sets=_sets(b.recovery, mesh, body, _RECOVERY_SETS),
            recovery_surface=surfaces,
            clamped_sets=_sets(b.clamped, mesh, body, _CLAMP_SETS),
            supports=body_supports(mesh, body, b.supports),
            n_modes=b.modes if b.modes is not None else red.modes,
            cutoff=red.cutoff,
            f_max=red.f_max,
            order=red.order,
            region=_region(mesh, red.mistuning, body),
        ))
    unknown = sorted(set(red.bodies) - set(mesh.bodies))
    if unknown:
        raise ValueError(f"reduction.bodies: {unknown} are not bodies of this mesh; it has "
                         f"{sorted(mesh.bodies)}")
    return specs


def _whole_disk_faults(mesh: Any) -> None:
    """ValueError where a mistuned case's mesh cannot make its whole disk: the sectors are
    joined node for node at the cyclic faces, of one sector count."""
    apart = sorted(b for b, c in mesh.cyclic.items() if not c.matching)
    if apart:
        raise ValueError(f"assembly.mistuning: the whole disk joins its sectors node for node, "
                         f"but the cyclic faces of {apart} are tied by interpolation (meshed "
                         "apart): mesh them matching")
    try:
        sector_count(mesh)
    except ValueError as fault:
        raise ValueError(f"assembly.mistuning: a whole disk: {fault}") from None


def _region(mesh: Any, mistuning: MistuningTable | None, body: str) -> tuple[int, ...]:
    """The mistuned region's elements if ``body`` is the mistuned one, else ()."""
    if mistuning is None or body not in mesh.cyclic \
            or mistuning.body_of(tuple(mesh.cyclic), tuple(mesh.bodies)) != body:
        return ()
    return tuple(int(e) for e in mistuning.elements(mesh, body))


def body_supports(mesh: Any, body: str,
                  given: Sequence[tuple[str, tuple[str, ...], str]] = ()) -> tuple[Support, ...]:
    """The supports of ``body``: the mesh's own (a deck's ``*BOUNDARY``) on its nodes, then
    the case's (set, held directions, frame) on the set's nodes in the body; ValueError
    naming a set the mesh lacks or one with no node in the body."""
    nodes = mesh.body_nodes(body)
    out = []
    for support in getattr(mesh, "supports", {}).values():
        inside = np.intersect1d(support.nodes, nodes)
        if inside.size:
            out.append(replace(support, nodes=inside))
    for i, (name, held, frame) in enumerate(given):
        where = f"reduction.bodies.{body}.supports[{i}].set = {name!r}"
        if name not in mesh.node_sets:
            raise ValueError(f"{where}: no such node set; node sets: "
                             f"{sorted(mesh.node_sets)}")
        inside = np.intersect1d(mesh.node_sets[name], nodes)
        if not inside.size:
            raise ValueError(f"{where}: none of its nodes is in body {body!r}")
        flags = [d in held for d in SUPPORT_FRAMES[frame]]
        out.append(Support(inside, np.array(flags), frame))
    return tuple(out)


def patch_stiffnesses(mesh: Any, specs: Sequence[BodySpec],
                      red: Mapping[str, Any] | ReductionTable
                      ) -> dict[str, contact_stiffness.PatchStiffness]:
    """Flat-punch (or per-area, from the case) stiffness of every contact patch."""
    materials = {s.body: s.material for s in specs}
    given = ReductionTable.of(red).contact_stiffness
    unknown = sorted(set(given) - set(mesh.contacts))
    if unknown:
        raise ValueError(f"reduction.contact_stiffness: {unknown} are not contact patches of "
                         f"this mesh; it has {sorted(mesh.contacts)}")
    out = {}
    for name, patch in sorted(mesh.contacts.items()):
        b = None if patch.body_b is None else materials[patch.body_b]  # None: the ground
        if isinstance(patch, ContactPatch):  # a structured patch: equal shares on its grid
            out[name] = contact_stiffness.patch_stiffness(patch, materials[patch.body_a], b,
                                                          given.get(name))
        else:  # named surfaces: by tributary area, or equally ("nodes")
            areas = paired_contact(mesh, name).pairing.areas
            if patch.spread == "nodes":
                areas = np.full(len(areas), areas.sum() / len(areas))
            out[name] = contact_stiffness.pairing_stiffness(
                name, areas, materials[patch.body_a], b, given.get(name))
    return out
