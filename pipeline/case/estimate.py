"""What a valid case will need before anything is built: the unknowns and peak memory of
each analysis (:func:`sizes`, refused by check when above the memory available), the rough
time of each of its tasks (:func:`task_seconds`: the dry run's figures, and whether a local
cluster is worth starting), and the notes on contacts stiffer than the time sampling
resolves (:func:`notes`)."""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from microslip.assembly.spec import PatchFriction
from microslip.laws.coulomb import FrictionLaw
from microslip.laws.registry import LAWS
from microslip.solve.hbm import CACHE_LIMIT  # the memory estimate reads the cache bound
from microslip.solve.memory import (
    ContactShape,
    available_memory,
    balance_bytes,
    memory_text,
)

from . import specs
from .build import as_matrix, harmonics_of, kinematic_row
from .checks import is_int
from .kinds import Kinds, kinds_or_shipped
from .paths import set_path


@dataclass(frozen=True)
class Size:
    """What one analysis will hold: the real unknowns of its harmonic balance (of a time
    integration: the DOFs; loops prescribe the motion and have none) and its peak memory."""

    analysis: str
    unknowns: int
    nbytes: int
    detail: str = ""  # what sets the size (for a refusal)

    def __str__(self) -> str:
        what = (f"{self.unknowns:,} unknowns" if self.unknowns else
                f"no unknowns ({self.detail or 'prescribed motion'})")
        return f"{self.analysis}, {what}, {memory_text(self.nbytes)}"


def sizes(data: dict, kinds: Kinds | None = None) -> list[Size]:
    """Per analysis of a valid case, the estimate for its largest curve (its ``set``, then
    each ``family`` value or table applied), from the case's numbers alone: nothing is
    built, so check and run refuse what will not fit before any work."""
    out = []
    for i, a in enumerate(data.get("analysis", [])):
        name = specs.analysis_name(a, i)
        kind = kinds_or_shipped(kinds)[a["type"]]
        out.append(max(((kind.size or _balance)(name, v, a) for v in _variants(data, a)),
                       key=lambda s: s.nbytes))
    return out


#: Measured anchors of the time estimates: the shipped cases run to the end with
#: ``--workers 0`` (one process, one BLAS thread) on two quiet cores (2026-11; the README's
#: Estimates table gives each case's estimate against its run). Each is a whole-analysis
#: figure: the solves, Hill's stability at every point, the map points, the pictures.
#:
#: A harmonic-balance point of an assembly: POINT_S at 1296 real unknowns and 64 samples,
#: growing as unknowns^1.6 (the structured Newton's GMRES: ~110 products with the per-order
#: blocks a point, `bench assembly`) and as samples^0.5; Hill's stability adds STABILITY of
#: it (a dense LU of Newton's Jacobian up to stability.HILL_LU unknowns and ARPACK's
#: solves: about one point). A lumped model's point: the
#: per-contact overhead of a Newton step (LUMPED_CONTACT_S, the kernels' calls) and the
#: return map's work, samples x unknowns x motions (LUMPED_SAMPLE_S). A curve: CURVE_POINTS
#: points (the shipped curves: 26 to 161); a map point: MAP_SOLVES solves and MAP_DRAW_S per
#: picture; a peak value followed by continuation: PEAK_SOLVES solves. A time integration:
#: STEP_S per step of 9 DOFs (linear in the DOFs), STEADY_PERIODS periods after the ramp.
POINT_S = 0.25
POINT_UNKNOWNS = 1296
POINT_EXPONENT = 1.6
STABILITY = 1.0
#: The linear limits (a dense per-order solve per frequency) grow as unknowns^1.8.
LINEAR_EXPONENT = 1.8
LUMPED_CONTACT_S = 3e-3
LUMPED_SAMPLE_S = 1e-6
CURVE_POINTS = 80
MAP_SOLVES = 12
MAP_DRAW_S = 2.0
PEAK_SOLVES = 20
STEP_S = 13e-6
STEADY_PERIODS = 250
LOOPS_S = 0.2
#: A results picture (matplotlib) [s]; a run's start (Python, NumPy, SciPy, numba's cached
#: kernels and microslip imported) [s].
PICTURE_S = 1.0
START_S = 4.0


def point_seconds(unknowns: int, samples: int, lumped: tuple[int, int] | None = None,
                  stability: bool = True) -> float:
    """Rough seconds per continuation point of a harmonic balance of ``unknowns`` real
    unknowns at ``samples`` per period, Hill's stability included with ``stability``;
    ``lumped``: (contacts, their motions) of a lumped model (None: an assembly)."""
    if lumped is not None:
        contacts, motions = lumped
        return (LUMPED_CONTACT_S * (1 + contacts)
                + LUMPED_SAMPLE_S * samples * max(unknowns, 1) * max(motions, 1))
    if unknowns <= 0:
        return 0.0
    scale = (unknowns / POINT_UNKNOWNS) ** POINT_EXPONENT * (samples / 64) ** 0.5
    return POINT_S * scale * (1 + (STABILITY if stability else 0.0))


def task_seconds(data: dict, spec: specs.Analysis, variant: dict | None = None,
                 kinds: Kinds | None = None) -> float:
    """Rough seconds of one task of analysis ``spec`` of the valid case ``data``, in one
    process (its kind's ``task_seconds``: an FRF curve with its map points, a peak curve or
    one of its values, an uncertainty sample; a time integration or the loops, whole).
    ``variant``: the case as that curve sees it (default: the largest of the analysis'
    curves)."""
    return kinds_or_shipped(kinds).of(spec).task_seconds(data, spec, variant)


def balance_points(data: dict, spec: specs.Analysis, variant: dict | None = None
                   ) -> list[tuple[int, int, tuple[int, int] | None]]:
    """:func:`point_seconds`' sizes (unknowns, samples, lumped) of the harmonic balance of
    each curve of analysis ``spec`` (only ``variant``'s where given)."""
    a = next(x for i, x in enumerate(data["analysis"])
             if specs.analysis_name(x, i) == spec.name)
    return [_point_sizes(v, a, spec.name) for v in (
        [variant] if variant is not None else _variants(data, a))]


def balance_point_seconds(data: dict, spec: specs.Analysis, variant: dict | None = None
                          ) -> float:
    """Rough seconds of one continuation point of the harmonic balance of analysis
    ``spec`` (the largest of its curves', or ``variant``'s), with Hill's stability where
    the spec asks for it."""
    stability = bool(getattr(spec, "stability", False))
    return max(point_seconds(*p, stability=stability)
               for p in balance_points(data, spec, variant))


def _point_sizes(data: dict, a: dict, name: str) -> tuple[int, int, tuple[int, int] | None]:
    """(unknowns, samples, lumped) of one curve's case ``data``: point_seconds' sizes."""
    lumped = None
    if "assembly" not in data:
        shapes = _lumped_contacts(data)[1]
        lumped = (len(shapes), sum(c.components for c in shapes))
    return balance_size(name, data).unknowns, harmonics_of(data).n_samples, lumped


def time_integration_seconds(data: dict, frequencies: tuple[float, ...], ramp_time: float,
                             settle_time: float, ramp_periods: int, steady_periods: int,
                             steps_per_period: int) -> float:
    """The steps of a time integration (the ramp and settling, ``steady_periods`` periods
    to the steady state per frequency) times STEP_S for its DOFs."""
    dofs = len(data["model"]["dofs"])
    periods = sum((ramp_time + settle_time) * w / (2 * math.pi) + ramp_periods
                  + steady_periods for w in frequencies)
    return periods * steps_per_period * STEP_S * dofs / 9


def analysis_seconds(data: dict, spec: specs.Analysis, kinds: Kinds | None = None) -> float:
    """Rough seconds of a whole analysis in one process beyond its tasks: its pictures
    (one per analysis, or per output of a lumped case where its kind draws one each)."""
    outputs = len(getattr(spec, "outputs", None) or ()) or 1
    per_output = kinds_or_shipped(kinds).of(spec).pictures_per_output
    return PICTURE_S * (outputs if per_output else 1)


def memory_faults(data: dict, out: list[str], kinds: Kinds | None = None) -> None:
    """A fault per analysis whose estimate exceeds the memory available now."""
    limit = available_memory()
    for s in sizes(data, kinds) if limit is not None else []:
        if s.nbytes > limit:
            out.append(f"analysis.{s.analysis}: needs {memory_text(s.nbytes)} "
                       f"({s.unknowns:,} real unknowns: {s.detail}) but "
                       f"{limit / 1e9:.1f} GB of memory is available; lower harmonics.max "
                       "(or harmonics.orders), harmonics.samples or the contact DOFs")


def _variants(data: dict, a: dict) -> list[dict]:
    """The case as each curve of analysis ``a`` sees it."""
    base = copy.deepcopy({k: v for k, v in data.items() if k != "analysis"})
    for key, value in a.get("set", {}).items():
        set_path(base, key, value, create=True)
    fam = a.get("family") or {}
    tables = fam.get("sets", [])
    if "key" in fam:
        tables = [{fam["key"]: v} for v in fam["values"]]
    variants = []
    for table in tables:
        v = copy.deepcopy(base)
        for key, value in table.items():
            set_path(v, key, value, create=True)
        variants.append(v)
    return variants or [base]


def _balance(name: str, data: dict, a: dict) -> Size:
    return balance_size(name, data)


def balance_size(name: str, data: dict) -> Size:
    """The size of the harmonic balance of a case (an analysis ``name`` of it): its real
    unknowns and peak memory, from the contacts and harmonics alone."""
    if "assembly" in data:
        contact_dofs, shapes = _patch_contacts(data)
        # a lower bound: the masters off the contacts (and "auto" modes) come later
        linear_dofs = contact_dofs + _modal_dofs(data)
    else:
        contact_dofs, shapes = _lumped_contacts(data)
        linear_dofs = len(data["model"]["dofs"])
    h = harmonics_of(data)
    points = specs.SolverTable.of(data.get("solver", {})).settings.max_points
    nbytes = balance_bytes(contact_dofs, linear_dofs, len(h.orders), h.n_coeffs, h.n_samples,
                           shapes, points, CACHE_LIMIT)
    detail = (f"{contact_dofs:,} contact DOF(s) x {h.n_coeffs:,} coefficients, H = "
              f"{max(h.orders)}, {h.n_samples:,} samples per period")
    return Size(name, contact_dofs * h.n_coeffs, nbytes, detail)


def _lumped_contacts(data: dict) -> tuple[int, list[ContactShape]]:
    """(DOFs any enabled contact touches, one shape per contact) of a lumped case."""
    touched: set[str] = set()
    shapes = []
    for c in data.get("contacts", []):
        if not specs.ContactTable.of(c, 0).enabled:
            continue
        keys = LAWS[c["law"]].motions
        mine = {dof for k in keys for dof in c[k]}
        # the time histories the kernel keeps per thread: one per motion at most
        dim = getattr(LAWS[c["law"]], "dim", len(keys))
        shapes.append(ContactShape(1, len(keys), dim, len(mine)))
        touched |= mine
    return len(touched), shapes


def _modal_dofs(data: dict) -> int:
    """The modal coordinates of an assembly case's bodies where their count is given
    (``modes`` an integer, per body or for all; "auto" is known only after the eigen
    solves: 0). The whole disk ([assembly.mistuning]) holds every sector's: a cyclic body
    its modes at every ND, cos and sin, about N x modes; another body N copies."""
    from microslip import geometry
    from microslip.geometry.full_disk import sector_count

    from .geometry_table import IMPORT, GeometryTable

    geo, red = data["geometry"], data.get("reduction", {})
    if geo["model"] == IMPORT:
        mesh = GeometryTable.of(geo).build()
        names, sectors = list(mesh.bodies), sector_count(mesh) if mesh.cyclic else 1
    else:
        names = list(geometry.NAMES.get(geo["model"], {}).get("bodies", ()))
        given = geo.get("parameters", {}).get("sectors")
        sectors = given if is_int(given) and given > 0 else getattr(
            geometry.PARAMETERS[geo["model"]](), "sectors", 1)
    copies = sectors if isinstance(data["assembly"].get("mistuning"), dict) else 1
    total = 0
    for name in names:
        modes = (red.get("bodies", {}).get(name) or {}).get("modes", red.get("modes"))
        total += copies * modes if is_int(modes) and modes > 0 else 0
    return total


def _patch_contacts(data: dict) -> tuple[int, list[ContactShape]]:
    """(contact DOFs, shapes) of an assembly case from its contacts, known before meshing: a
    model's patch has n_axial x n_flank node pairs, each pair a node of each body (3 DOFs
    each); an imported mesh's contacts are counted on the mesh (read at the check, kept); a
    parametric model's declared contacts are not known before meshing (left out: a lower
    bound). The whole disk ([assembly.mistuning]) has every sector's contacts."""
    from microslip import geometry
    from microslip.geometry.full_disk import sector_count
    from microslip.geometry.pairing import paired_contact

    from .geometry_table import IMPORT, GeometryTable

    geo = data["geometry"]
    whole = isinstance(data["assembly"].get("mistuning"), dict)  # every sector's contacts
    copies = 1
    counts: dict[str, tuple[int, int, int]] = {}  # contact -> (pairs, DOFs, DOFs per pair)
    if geo["model"] == IMPORT:
        mesh = GeometryTable.of(geo).build()
        if whole and mesh.cyclic:
            copies = sector_count(mesh)
        for name in mesh.contacts:
            p = paired_contact(mesh, name).pairing
            per_pair = 3 * (1 + int(np.diff(p.weights.indptr).max(initial=0)))
            counts[name] = (len(p.nodes_a), 3 * (len(p.nodes_a) + len(p.nodes_b)), per_pair)
    else:
        given = geo.get("parameters", {})
        fields = {f.name: f.default for f in dataclasses.fields(geometry.PARAMETERS[geo["model"]])}

        def count(key: str) -> int:
            v = given.get(key, fields[key])
            return v if is_int(v) and v > 0 else fields[key]  # a bad value is refused at meshing

        # a patch's grid: the model's contact_n_* counts (axial x flank, radial x along, ...)
        pairs = math.prod(count(k) for k in fields if k.startswith("contact_n_"))
        if whole and "sectors" in fields:
            copies = count("sectors")
        counts = {name: (pairs, 6 * pairs, 6) for name in geometry.NAMES.get(
            geo["model"], {}).get("patches", ())}
    shapes, dofs = [], 0
    for c in data["assembly"]["contacts"]:
        pairs, n, per_pair = counts.get(c.get("patch"), (0, 0, 6))
        pairs, n = copies * pairs, copies * n
        dofs += n
        if c.get("elements", PatchFriction.elements) == "2D":
            shapes.append(ContactShape(pairs, 3, 2, per_pair))
        else:  # two law-B elements (t1 or t2, and n)
            shapes += [ContactShape(pairs, 2, 1, per_pair)] * 2
    return dofs, shapes


def notes(data: dict, kinds: Kinds | None = None) -> list[str]:
    """Remarks on a valid lumped case that are not faults: a contact so much stiffer than
    the structure it touches that the time sampling, not the contact, sets the accuracy.

    After a reversal of u = U cos(theta) a Jenkins contact sticks until u has come back
    2 u_s, u_s = mu N / kt: an arc theta_s ~ 2 sqrt(u_s / U). Where friction matters the
    motion is of the order of the friction force's displacement on the structure,
    U ~ mu N / k, so theta_s ~ 2 sqrt(k / kt). A transition placed one sample (2 pi / ns)
    off moves u by U theta_s 2 pi / ns; against the stick range 2 u_s that is a relative
    error of the hysteresis ~ (2 pi / ns) sqrt(kt / k). It reaches 1, the whole stick arc
    inside two samples (what the laws count as ``undersampled``), at
    kt / k = (ns / 2 pi)^2: above, the results go to the stuck-spring limit (still
    converging) at an accuracy the samples set. k is the structure's stiffness along the
    contact's motion, b K b^T (the other DOFs held: the larger, so no false note)."""
    known = kinds_or_shipped(kinds)
    if "model" not in data or not any(known[a["type"]].notes
                                      for a in data.get("analysis", [])):
        return []
    dofs = data["model"]["dofs"]
    index = {d: i for i, d in enumerate(dofs)}
    K = as_matrix(data["model"]["stiffness"], len(dofs))
    ns = harmonics_of(data).n_samples
    limit = (ns / (2 * np.pi)) ** 2
    out = []
    for i, c in enumerate(data.get("contacts", [])):
        contact = specs.ContactTable.of(c, i)
        if not contact.enabled:
            continue
        name = contact.name
        law = LAWS[c["law"]]
        if not isinstance(law, FrictionLaw):  # the note is about stick arcs
            continue
        d, variable = law.dim, law.variable_normal
        kt = np.broadcast_to(np.asarray(c["kt"], dtype=float), (d,))
        springs = [(f"kt{'' if d == 1 else f'[{j}]'}", kt[j], k)
                   for j, k in enumerate(["u"] if d == 1 else ["u1", "u2"])]
        springs += [("kn", c["kn"], "v")] if variable else []
        for key, stiff, motion in springs:
            b = kinematic_row(c[motion], index, len(dofs)).real
            k = float(b @ K @ b)
            if k <= 0 or stiff / k <= limit:
                continue
            need = 1 << int(np.ceil(np.log2(2 * np.pi * np.sqrt(stiff / k))))
            out.append(f"contacts.{name}.{key} = {stiff:g} N/m is {stiff / k:.3g} x the "
                       f"structure's stiffness along {motion} ({k:g} N/m), above "
                       f"(samples / 2 pi)^2 = {limit:.0f} for {ns} samples per period: the stick "
                       "arc after a reversal falls inside two samples, so the results tend to "
                       "the stuck-spring limit at an accuracy the sampling sets; "
                       f"harmonics.samples = {need:,} would resolve it")
    return out
