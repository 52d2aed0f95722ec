"""The structural stage of a case: from the meshed geometry to the reduced model of every body
at every nodal diameter the case needs, and the contact stiffness of every patch.

A case's [reduction] table (all keys optional but one of ``nodal_diameters`` or
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
    modal_ratios = 0.001             # models (no re-reduction): zeta (one, or per mode) and/or
    rayleigh_alpha = 0.0             # C = alpha M + beta K  [1/s], [s]
    [reduction.bodies.<body>]        # per body: material, damping, modes, clamped, masters,
                                     # recovery
    [reduction.contact_stiffness.<patch>]  # normal, tangential per unit area [N/m^3]

Conventions from the geometry models' node-set names: a body is clamped on ``<body>/bore``
or ``<body>/clamp``; its masters are every contact-patch node it owns plus ``<body>/excitation``
and ``<body>/response``; the recovery matrix is kept on the masters plus ``<body>/response``,
``<body>/tip`` and ``<body>/blade_tip`` (what outputs and pictures use).

Without ``f_max``, the cyclic bodies choose their modes by their own 10th fixed-interface
frequency and the other bodies (the free damper, whose fixed-interface modes are all far above
the disk's) get as f_max the highest frequency the cyclic bodies resolve: the damper keeps a
few modes instead of every mode below 4x its own 10th (249 for the default blisk's damper).

Reduced models are cached in ``<out>/models/cb-<hash>.h5``: a re-run reuses every body and ND
whose mesh, material, constraints, masters and mode selection have not changed.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from numpy.typing import NDArray

from microslip.pipeline.fe import contact_stiffness, cyclic, linalg, reduction
from microslip.pipeline.fe.fem import Damping, Material
from microslip.pipeline.fe.reduction import BodySpec, ReducedModel

from .checks import is_int, is_number, unknown_keys
from .progress import time_left

Progress = Callable[[str], None]

STEEL = Material(2.0e11, 0.3, 7850.0)
KEYS = {"nodal_diameters", "engine_order", "harmonics", "order", "modes", "cutoff", "f_max",
        "backend", "material", "damping", "bodies", "contact_stiffness"}
BODY_KEYS = {"material", "damping", "modes", "clamped", "masters", "recovery"}
DAMPING_KEYS = {"rayleigh_alpha", "rayleigh_beta", "modal_ratios"}
MATERIAL_KEYS = {"youngs_modulus", "poisson_ratio", "density"}
STIFFNESS_KEYS = {"normal", "tangential"}
BACKENDS = ("auto", *linalg.BACKENDS)
_CLAMP_SETS = ("bore", "clamp")
_MASTER_SETS = ("excitation", "response")
_RECOVERY_SETS = ("response", "tip", "blade_tip")


@dataclass
class StructureResult:
    """What the stage produced.

    models: body -> ND -> ReducedModel (a body without cyclic symmetry: the same model under
        every ND).
    patch_stiffness: contact patch -> PatchStiffness (kn, kt per node pair [N/m]).
    nodal_diameters: the NDs reduced; f_max: the case's f_max, or the one inferred for the
        non-cyclic bodies [Hz] (None: neither).
    cached: (body, ND) pairs that were read from the cache instead of reduced.
    files: (body, ND) -> the model's HDF5 file (with a cache directory).
    frequencies: (body, ND) -> the first ten natural frequencies of the reduced model (free
        masters) [Hz].
    """

    models: dict[str, dict[int, ReducedModel]]
    patch_stiffness: dict[str, contact_stiffness.PatchStiffness]
    nodal_diameters: tuple[int, ...]
    f_max: float | None
    cached: list[tuple[str, int]] = field(default_factory=list)
    seconds: dict[tuple[str, int], float] = field(default_factory=dict)
    files: dict[tuple[str, int], Path] = field(default_factory=dict)
    frequencies: dict[tuple[str, int], NDArray] = field(default_factory=dict)


# --- validation of the [reduction] table (before any meshing or factorization) --------------


def check(red: Any, data: Mapping[str, Any], out: list[str]) -> None:
    """Append one line per fault of a case's [reduction] table to ``out``."""
    if not isinstance(red, dict):
        out.append(f"reduction: expected a table, got {red!r}")
        return
    unknown_keys("reduction.", red, KEYS, out)
    if "geometry" not in data:
        out.append("reduction: needs a [geometry] table (the mesh to reduce)")
    sectors = _sectors(data.get("geometry"))
    if sectors is None:
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
    if red.get("backend", "auto") in linalg.BACKENDS and red["backend"] not in \
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
    for name, s in _table_of(red, "contact_stiffness", out).items():
        pre = f"reduction.contact_stiffness.{name}"
        if not isinstance(s, dict) or set(s) != STIFFNESS_KEYS:
            out.append(f"{pre}: expected a table with exactly {sorted(STIFFNESS_KEYS)} "
                       "[N/m^3]")
            continue
        for k in sorted(STIFFNESS_KEYS):
            if not (is_number(s[k]) and s[k] > 0.0):
                out.append(f"{pre}.{k} = {s[k]!r}: expected a stiffness per area > 0 [N/m^3]")


def _sectors(geo: Any) -> int | None:
    """Sectors of a [geometry] table's model (given or the model's default); None for a model
    without cyclic symmetry or an invalid table (reported elsewhere)."""
    from microslip import geometry

    if not isinstance(geo, dict) or geo.get("model") not in geometry.PARAMETERS:
        return None
    params = geo.get("parameters", {})
    given = params.get("sectors") if isinstance(params, dict) else None
    value = given if given is not None else getattr(geometry.PARAMETERS[geo["model"]](),
                                                    "sectors", None)
    return int(value) if is_int(value) and value >= 3 else None



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
    if m is None:
        return
    if not isinstance(m, dict) or set(m) != MATERIAL_KEYS:
        out.append(f"{pre}: expected a table with exactly {sorted(MATERIAL_KEYS)}")
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


# --- the stage ------------------------------------------------------------------------------


def damping(table: Mapping[str, Any] | None) -> Damping | None:
    """Damping from a case table (rayleigh_alpha [1/s], rayleigh_beta [s], modal_ratios: one
    zeta or a list per mode)."""
    if table is None:
        return None
    ratios = table.get("modal_ratios", ())
    ratios = (ratios,) if isinstance(ratios, int | float) else tuple(ratios)
    return Damping(float(table.get("rayleigh_alpha", 0.0)),
                   float(table.get("rayleigh_beta", 0.0)), tuple(float(z) for z in ratios))


def material(table: Mapping[str, Any] | None, default: Material = STEEL) -> Material:
    """Material from a case table (keys youngs_modulus, poisson_ratio, density)."""
    if table is None:
        return default
    return Material(float(table["youngs_modulus"]), float(table["poisson_ratio"]),
                    float(table["density"]))


def needed_nodal_diameters(red: Mapping[str, Any], sectors: int,
                           case_orders: Iterable[int] | None = None) -> tuple[int, ...]:
    """The NDs of a [reduction] table: explicit, or those of the harmonic orders under the
    engine order (``cyclic.nodal_diameters``: backward waves fold onto 0..Ns/2). Orders:
    0..``harmonics`` of the table, else the case's harmonic orders (``case_orders``), else
    0..1; order 0 (the static part, ND 0) always."""
    if "nodal_diameters" in red:
        nds = tuple(sorted(set(int(h) for h in red["nodal_diameters"])))
        for h in nds:
            if not 0 <= h <= sectors // 2:
                raise ValueError(f"reduction.nodal_diameters = {list(nds)}: ND {h} outside "
                                 f"0..{sectors // 2} (sectors = {sectors})")
        return nds
    if "harmonics" in red:
        orders = set(range(int(red["harmonics"]) + 1))
    else:
        orders = set(case_orders) if case_orders is not None else {0, 1}
    return cyclic.nodal_diameters(sorted(orders | {0}), int(red["engine_order"]), sectors)


def _existing(mesh: Any, body: str, suffixes: Sequence[str]) -> tuple[str, ...]:
    return tuple(f"{body}/{s}" for s in suffixes if f"{body}/{s}" in mesh.node_sets)


def body_specs(mesh: Any, red: Mapping[str, Any], surfaces: bool = False) -> list[BodySpec]:
    """One BodySpec per body of the mesh, by the naming conventions and the case's overrides;
    ``surfaces``: every body also recovered on its outer surface (deformed-shape pictures)."""
    base = material(red.get("material"))
    specs = []
    for body in sorted(mesh.bodies):
        b = red.get("bodies", {}).get(body, {})
        patches = tuple(sorted(name for name, p in mesh.contacts.items()
                               if body in (p.body_a, p.body_b)))
        specs.append(BodySpec(
            body=body,
            material=material(b.get("material"), base),
            damping=damping(b.get("damping", red.get("damping"))),
            master_sets=tuple(b.get("masters", _existing(mesh, body, _MASTER_SETS))),
            patches=patches,
            recovery_sets=tuple(b.get("recovery", _existing(mesh, body, _RECOVERY_SETS))),
            recovery_surface=surfaces,
            clamped_sets=tuple(b.get("clamped", _existing(mesh, body, _CLAMP_SETS))),
            n_modes=b.get("modes", red.get("modes", reduction.DEFAULT_MODES)),
            cutoff=float(red.get("cutoff", reduction.CUTOFF)),
            f_max=None if "f_max" not in red else float(red["f_max"]),
            order=int(red.get("order", 2)),
        ))
    unknown = sorted(set(red.get("bodies", {})) - set(mesh.bodies))
    if unknown:
        raise ValueError(f"reduction.bodies: {unknown} are not bodies of this mesh; it has "
                         f"{sorted(mesh.bodies)}")
    return specs


def patch_stiffnesses(mesh: Any, specs: Sequence[BodySpec], red: Mapping[str, Any]
                      ) -> dict[str, contact_stiffness.PatchStiffness]:
    """Flat-punch (or per-area, from the case) stiffness of every contact patch."""
    materials = {s.body: s.material for s in specs}
    given = red.get("contact_stiffness", {})
    unknown = sorted(set(given) - set(mesh.contacts))
    if unknown:
        raise ValueError(f"reduction.contact_stiffness: {unknown} are not contact patches of "
                         f"this mesh; it has {sorted(mesh.contacts)}")
    out = {}
    for name, patch in sorted(mesh.contacts.items()):
        per_area = None
        if name in given:
            per_area = (float(given[name]["normal"]), float(given[name]["tangential"]))
        out[name] = contact_stiffness.patch_stiffness(
            patch, materials[patch.body_a], materials[patch.body_b], per_area)
    return out


def reduce_structure(mesh: Any, red: Mapping[str, Any], cache_dir: str | Path | None,
                     case_orders: Iterable[int] | None = None, progress: Progress = print,
                     surfaces: bool = False) -> StructureResult:
    """Reduce every body of ``mesh`` for the NDs the [reduction] table asks (see the module).
    ``surfaces``: recover every body on its outer surface too (a case that draws deformed
    shapes; part of each model's cache key).

    Everything the table names (node sets, bodies, patches, NDs) is checked before the first
    assembly. Cyclic bodies go first; without f_max, the others get the highest 10th
    fixed-interface frequency of the cyclic bodies as theirs.
    """
    specs = body_specs(mesh, red, surfaces)
    sectors = {b.sectors for b in mesh.cyclic.values()}
    if not sectors:
        nds: tuple[int, ...] = (0,)
    else:
        nds = needed_nodal_diameters(red, max(sectors), case_orders)
    for spec in specs:  # names and node sets, before any heavy work
        reduction.spec_nodes(mesh, spec)
    patch_stiffness = patch_stiffnesses(mesh, specs, red)
    backend = red.get("backend", "auto")
    backend = None if backend == "auto" else backend
    result = StructureResult({}, patch_stiffness, nds, None if "f_max" not in red
                             else float(red["f_max"]))
    count = _Count(sum(len(set(nds)) if s.body in mesh.cyclic else 1 for s in specs))
    for spec in sorted(specs, key=lambda s: s.body not in mesh.cyclic):  # cyclic bodies first
        is_cyclic = spec.body in mesh.cyclic
        if not is_cyclic and spec.f_max is None and spec.n_modes == "auto":
            f_ref = reduction.reference_frequency(
                m for models in result.models.values() for m in models.values())
            if f_ref is not None:
                result.f_max = f_ref
                spec = replace(spec, f_max=f_ref)

        report = _recorder(result, spec.body, None if is_cyclic else nds, progress, count)
        result.models[spec.body] = reduction.reduce_body(mesh, spec, nds, cache_dir, backend,
                                                         report)
    return result


@dataclass
class _Count:
    """Models of the stage done so far, of ``total`` (one per cyclic body and ND, one per
    other body), for the progress lines; the time left is from the rate so far."""

    total: int
    clock: Callable[[], float] = time.perf_counter
    done: int = 0
    t0: float | None = None  # when the stage began (default: now)

    def __post_init__(self):
        if self.t0 is None:
            self.t0 = self.clock()

    def step(self) -> str:
        """One more model done: "i/N" and, while models remain, "~N s left"."""
        self.done += 1
        left = time_left(self.clock() - self.t0, self.done / max(self.total, 1))
        return f"{self.done}/{self.total}" + (f", {left}" if left else "")


def _recorder(result: StructureResult, body: str, serves: tuple[int, ...] | None,
              progress: Progress, count: _Count) -> Callable[..., None]:
    """The ``report`` of reduce_body for one body: records each model (under every ND in
    ``serves`` for a non-cyclic body, whose one model serves them all) and prints a line."""

    def report(h: int, model: ReducedModel, path: Path | None, cached: bool,
               seconds: float) -> None:
        nds = (h,) if serves is None else serves
        f = model.frequencies(10)
        result.seconds[body, nds[0]] = seconds
        if cached:
            result.cached.append((body, nds[0]))
        for nd in nds:
            result.frequencies[body, nd] = f
            if path is not None:
                result.files[body, nd] = path
        progress(f"[reduction] {body}" + (f" ND {h}" if serves is None else "")
                 + f" ({count.step()}): {model.n_masters} master DOFs + {model.n_modes} modes, "
                 + ("from cache" if cached else f"{seconds:.1f} s") + "; f [Hz] "
                 + " ".join(f"{x:.0f}" for x in f[:7]))

    return report
