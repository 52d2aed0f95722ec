"""The layout of ``results.h5``, defined once: every group, dataset and attribute name.

Writers build their paths with the names below and readers find what they draw with the
same names. :data:`LAYOUT` is the tree with its shapes and units: the README's layout
section is :func:`layout_text` (a test holds them equal) and every object a run writes is
one of its entries (a test walks the files the suite's runs write, :func:`undescribed`).

In a pattern, ``NNN`` and ``NN`` stand for a zero-padded index, ``H`` for a nodal diameter
and ``<...>`` for a name the case gives (an analysis, a body, a contact, a patch).
"""

from __future__ import annotations

import re
import textwrap
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

# ------------------------------------------------------------------ top level
CASE = "case"
GEOMETRY = "geometry"
CONTACT_GRIDS = "contact_grids"
SURFACES = "surfaces"
REDUCTION = "reduction"
CONTACT_STIFFNESS = "contact_stiffness"
CYCLIC = "cyclic"

# ------------------------------------------------------------------ inside an analysis
CONTACTS = "contacts"
PATCHES = "patches"
MAPS = "maps"
BIFURCATIONS = "bifurcations"
#: Floquet exponents kept per point of an frf curve (the largest real parts)
FLOQUET = 6
SHAPES = "shapes"
LEVEL_FREE = "level_free"
LEVEL_STUCK = "level_stuck"
LINEAR_FREE = "linear_free"
LINEAR_STUCK = "linear_stuck"
SAMPLES = "samples"
STATISTICS = "statistics"
PATTERNS = "patterns"
AMPLIFICATION = "amplification"

_CURVE = "curve_"
_STEP = "step_"


def curve(index: int) -> str:
    """The group of an analysis' curve ``index`` (0-based): ``curve_000``, ..."""
    return f"{_CURVE}{index:03d}"


def mistuning_members(g) -> list[tuple[str, Any]]:
    """(label, the group holding patterns/ and amplification/) per member of a mistuning
    study's group (an ``h5py.Group``): the group itself ("") without a family, each of its
    curve_NNN with one; [] where nothing is written yet."""
    if PATTERNS in g:
        return [("", g)]
    return [(str(g[k].attrs.get("label", k)), g[k]) for k in sorted(g)
            if k.startswith(_CURVE) and PATTERNS in g[k]]


def point(index: int) -> str:
    """The group of a curve's map point ``index`` (0-based): ``point_00``, ..."""
    return f"point_{index:02d}"


def step(index: int) -> str:
    """The group of a transient's load step ``index`` (1-based): ``step_1``, ``step_2``."""
    return f"{_STEP}{index}"


#: The group of a modes analysis holding the reduced assembly's frequencies
ASSEMBLY_MODES = "assembly"


def nodal_diameter(h: int) -> str:
    """The group of a reduced body's model at nodal diameter ``h``: ``nd3``."""
    return f"nd{h}"


def linear_stuck(index: int, of: int) -> str:
    """The fully stuck linear limit of damper mass ``index`` among ``of`` masses: one mass
    gives ``linear_stuck``, several ``linear_stuck_000``, ..."""
    return LINEAR_STUCK if of == 1 else f"{LINEAR_STUCK}_{index:03d}"


def is_curve(name: str) -> bool:
    return name.startswith(_CURVE)


def is_step(name: str) -> bool:
    return name.startswith(_STEP)


def is_linear(name: str) -> bool:
    """A linear limit of an frf (free or fully stuck)."""
    return name == LINEAR_FREE or name.startswith(LINEAR_STUCK)


def is_level(name: str) -> bool:
    """A linear level of a peak curve (free or fully stuck)."""
    return name in (LEVEL_FREE, LEVEL_STUCK)


# ------------------------------------------------------------------ the tree
@dataclass(frozen=True)
class Entry:
    """A group (``children`` may be empty) or a dataset (``dataset``) of the layout.

    name: a name or a pattern (module docstring); doc: a dataset's shape, unit and meaning,
    or when a group is written; attrs: its attributes, each ``"name"`` or ``"name (what)"``
    (``"..."``: further attributes the case gives, an analysis' keys); repeated: its
    children are entries listed elsewhere, not listed again in the README's text."""

    name: str
    doc: str = ""
    attrs: tuple[str, ...] = ()
    children: tuple[Entry, ...] = ()
    dataset: bool = False
    repeated: bool = False

    def matches(self, name: str) -> bool:
        return re.fullmatch(_regex(self.name), name) is not None

    def attribute_names(self) -> set[str]:
        return {a.split(" ", 1)[0] for a in self.attrs}


def _regex(pattern: str) -> str:
    if pattern.startswith("<"):
        return ".+"
    for placeholder, digits in (("_NNN", r"_\d{3}"), ("_NN", r"_\d{2}"), ("_N", r"_\d+"),
                                ("ndH", r"nd\d+")):
        if pattern.endswith(placeholder):
            return re.escape(pattern.removesuffix(placeholder)) + digits
    return re.escape(pattern)


def group(name: str, doc: str = "", attrs: tuple[str, ...] = (), *children: Entry) -> Entry:
    return Entry(name, doc, attrs, tuple(children))


def data(name: str, doc: str) -> Entry:
    return Entry(name, doc, dataset=True)


_RUN = ("status (complete | stopped | interrupted | failed)", "message",
        "warnings (JSON list: the lines the curve warned of, if any)")
_CONTACT_HISTORY = (data("T", "(steps, points, dim) N tangential force"),
                    data("N", "(steps, points) N normal force"),
                    data("state", "(steps, points) state per step (codes as an frf's)"))
_PATCH_STATE = (
    data("state", "(n, P) state per node pair (codes as contacts/<contact>/state)"),
    data("static", "(n, P, 3) N static forces [T0_1, T0_2, N0] per node pair"),
    data("slip_share", "(n,) share of the node pairs slipping"))

MISTUNING_GROUPS = (
    group(PATTERNS, "(mistuning) one row per pattern, level by level",
          ("seed", "sectors", "tuned_status", "tuned_peak", "tuned_omega",
           "tuned_free_peak", "tuned_free_omega (the cyclic sector's, m and rad/s)"),
          data("sigma", "(n,) the pattern's standard deviation"),
          data("deviation", "(n, N) each blade's Young's modulus x (1 + deviation)"),
          data("blade_peaks", "(n, N) m, each blade's largest response over the "
               "computed points (the worst blade's refined)"),
          data("peak", "(n,) m, the worst blade's peak (NaN: none)"),
          data("omega", "(n,) rad/s, where it is"),
          data("blade", "(n,) the worst blade"),
          data("free_peak", "(n,) m, the worst blade's peak without the dampers "
               "(linear; NaN: free = false)"),
          data("free_omega", "(n,) rad/s, where it is"),
          data("amplification", "(n,) peak / tuned_peak"),
          data("free_amplification", "(n,) free_peak / tuned_free_peak"),
          data("points", "(n,) continuation points of the pattern's sweeps"),
          data("samples", "(n,) time samples per period of its sweeps"),
          data("seconds", "(n,) s, the pattern's task when it was computed"),
          data("status", "(n,) complete | stopped | failed | not run")),
    group(AMPLIFICATION, "(mistuning) the amplification per level, with the dampers "
          "(friction_) and without (free_)", ("percent", "whitehead ((1 + sqrt N) / 2)",
                                              "limit (NaN: none)", "cases (JSON)"),
          data("sigma", "(k,) the levels"),
          data("friction_percentiles", "(k, 3) at percent (5, 50, 95)"),
          data("friction_largest", "(k,) the largest"),
          data("friction_mean", "(k,)"),
          data("friction_count", "(k,) complete patterns"),
          data("friction_exceedance", "(k,) P(amplification > limit) (NaN: no limit)"),
          data("friction_exceedance_error", "(k,) its binomial standard error"),
          data("free_percentiles", "(k, 3) without the dampers (free = true)"),
          data("free_largest", "(k,)"), data("free_mean", "(k,)"),
          data("free_count", "(k,)"), data("free_exceedance", "(k,)"),
          data("free_exceedance_error", "(k,)")))

FRF_CURVE = group(
    "curve_NNN", "(frf) one branch: a family value, a method",
    ("label", "method (arclength | natural | natural-down)", "measure",
     "family_key", "family_value", *_RUN, "turning_points (point indices)", "elapsed_s",
     "outputs (names)", "harmonic_orders", "samples (per period)",
     "mass_multiplier", "excitation (the operating point)", "normalised"),
    data("parameter", "(n,) the swept parameter"),
    data("omega", "(n,) rad/s"),
    data("amplitude", "(n, outputs) m, max_t |x(t)|"),
    data("response", "(n, outputs) m, the analysis' measure"),
    data("coefficients", "(n, outputs, nc) m, harmonic coefficients [X0, Re X1, Im X1, ...]"),
    data("residual", "(n,) norm of the balance residual"),
    data("iterations", "(n,) Newton iterations"),
    data("turning_points", "(k,) point indices where the parameter turns back"),
    data("jumps", "(k, 2) from, to point of each jump of a natural sweep at a fold"),
    data("jump_parameter", "(k, 2) their parameter values"),
    data("stable", "(n,) Hill's stability of each point (stability = true)"),
    data("floquet", f"(n, {FLOQUET}) 1/s complex, the Floquet exponents with the largest "
         "real parts (NaN: fewer)"),
    group(BIFURCATIONS, "(stability) between the points, in branch order", (),
          data("kind", "(b,) fold | branch point | period doubling | Neimark-Sacker"),
          data("index", "(b,) the point before it"),
          data("parameter", "(b,) where it was located"),
          data("omega", "(b,) rad/s"),
          data("response", "(b, outputs) m, the analysis' measure there"),
          data("exponent", "(b,) 1/s complex, the critical Floquet exponent there"),
          data("located", "(b,) to 1e-4 of the step (false: the last trial)")),
    data("unknowns", "(n, u) the balance unknowns"),
    data("unknown_dofs", "(u / nc,) model DOF of each unknown block"),
    data("unknown_nodes", "(u / nc,) mesh node of each unknown block (assembly)"),
    data("unknown_directions", "(u / nc,) 0 x, 1 y, 2 z (assembly)"),
    group(CONTACTS, "", (),
          group("<contact>", "", (),
                data("state", "(n,) 0 stick, 1 stick-slip, 2 gross slip, 3 partial "
                     "lift-off, 4 open (of the contact's first point)"),
                data("node_state", "(n, points) the same per contact point"),
                data("dissipation", "(n,) J/cycle"),
                data("slip_fraction", "(n,) share of the period slipping"),
                data("static_force", "(n, columns) N"),
                data("columns", "names of static_force's columns (T0, T0_1, T0_2, N0)"),
                data("undersampled", "(n,) stick arcs within two samples"),
                data("loop_point", "(n,) the contact point dissipating most at each point "
                     "(all stuck: the first): whose hysteresis loop is stored"),
                data("loop_u", "(n, d, s) m float32, its relative tangential displacement "
                     "over a period (every sample up to 64, else every ceil(ns / 64)-th)"),
                data("loop_T", "(n, d, s) N float32, its tangential force there"))),
    data("sampling_change", "(n,) where undersampled: first-order relative change of "
         "the response at twice the samples"),
    data("sampling_shift", "(n,) and the shift of the parameter"),
    group(PATCHES, "(assembly)", (), group("<patch>", "", (), *_PATCH_STATE)),
    group(MAPS, "(assembly, maps)", (),
          group("point_NN", "", ("what (peak | value)", "parameter", "omega (rad/s)",
                                 "excitation"),
                data("unknowns", "(u,) the solution"),
                data("response", "(outputs,) m, the analysis' measure"),
                group(PATCHES, "", (), group("<patch>", "", (), *(
                    data(d.name, d.doc.replace("(n, ", "(").replace("(n,)", "()"))
                    for d in _PATCH_STATE))),
                group(SHAPES, "(map_types with shape)", ("orders", "wave_numbers"),
                      data("<body>", "(p, 3, nc) m displacement coefficients at the "
                           "surface nodes")))))

LINEAR_CURVE_DATA = (data("omega", "(m,) rad/s"),
                     data("coefficients", "(m, outputs, nc) m"),
                     data("response", "(m, outputs) m"))
LEVEL_DATA = (data("parameter", "(k,)"), data("omega", "(k,) rad/s"),
              data("amplitude", "(k,) m"))

LAYOUT = group(
    "/", "", ("title", "source", "case_hash", "status (complete | partial | failed)",
              "message", "created", "versions (JSON)"),
    group(CASE, "", ("json (the case as run)",)),
    group(GEOMETRY, "(meshed cases)", ("type", "model", "content_hash", "nodes",
                                       "elements (e.g. '4210 tetrahedra')",
                                       "bodies", "contacts", "parameters", "status",
                                       "elapsed_s"),
          group(CYCLIC, "", (), group("<body>", "a sector body", ("sectors",),
                                      data("left", "(k, 3) m, the left cyclic face's nodes"),
                                      data("right", "(k, 3) m, their images on the right")))),
    group(CONTACT_GRIDS, "(meshed cases)", (),
          group("<patch>", "", ("body_a", "body_b", "high_edge", "high_edge_name",
                                "b_sector_offset (body b in the neighbour sector: +-1)"),
                data("points", "(n1, n2, 3) m, side a"),
                data("points_b", "(n1, n2, 3) m, side b's own nodes (fundamental sector)"),
                data("nodes_a", "(n1, n2) mesh nodes of body a"),
                data("nodes_b", "(n1, n2) mesh nodes of body b"),
                data("frame", "(3, 3) rows t1, t2, n"),
                data("map_axes", "(2, 3) right and up of the maps (up: growing radius, "
                     "right x up = n: seen from body b onto body a)"),
                data("map_coordinates", "(n1, n2, 2) m"),
                data("connectivity", "((n1-1)(n2-1), 4) quads of the node grid (i n2 + j); "
                     "named surfaces: (F, 4) side a's facets into the points (averaged points: "
                     "into cell_points; a triangle's 4th -1)"),
                data("cell_points", "(m, 3) m, averaged points only: side a's facets' "
                     "nodes (connectivity indexes them)"),
                data("cell_owner", "(m,) averaged points only: the point (patch) each of "
                     "them stands in"))),
    group(SURFACES, "(meshed cases)", ("sectors (0: no cyclic body)",),
          group("<body>", "", ("cyclic",),
                data("nodes", "(p,) mesh nodes of the body's outer surface"),
                data("points", "(p, 3) m"),
                data("triangles", "(t, 3) into nodes, normals out of the body"))),
    group(REDUCTION, "(reduced cases)", ("type", "nodal_diameters", "f_max_hz", "cached",
                                         "status", "elapsed_s"),
          group(CONTACT_STIFFNESS, "", (),
                group("<patch>", "", (),
                      data("normal_n_per_m", "(n1, n2) N/m per node pair"),
                      data("tangential_n_per_m", "(n1, n2) N/m per node pair"))),
          group("<body>", "", (),
                group("ndH", "", ("n_modes", "n_master_dofs", "file (the model, in the cache)"),
                      data("frequencies_hz", "(k,) Hz, the reduced model, masters free"),
                      data("mode_frequencies_hz", "(modes,) Hz, fixed-interface modes"),
                      data("master_nodes", "(masters,) mesh nodes")))),
    group("<analysis>", "", ("type", "name", *_RUN, "elapsed_s", "... (the analysis keys, "
                             "given or by default)"),
          FRF_CURVE,
          group(LINEAR_FREE, "(assembly frf) the free bodies (no damper), linear",
                ("label", *_RUN, "mass_multiplier"), *LINEAR_CURVE_DATA),
          group(LINEAR_STUCK, "(assembly frf) fully stuck, linear; linear_stuck_NNN per "
                "damper mass of a mass family", ("label", *_RUN, "mass_multiplier"),
                *LINEAR_CURVE_DATA),
          group("linear_stuck_NNN", "", ("label", *_RUN, "mass_multiplier"),
                *LINEAR_CURVE_DATA),
          group("curve_NNN", "(peak) one peak curve", ("label", "family_value", *_RUN,
                                                      "elapsed_s"),
                data("parameter", "(n,) the parameter's values"),
                data("omega", "(n,) rad/s, where the peak is"),
                data("amplitude", "(n,) m, the peak"),
                data("complete", "(n,) found"),
                data("how", "(n,) tracked | swept"),
                data("stable", "(n,) Hill's stability of the peak's solution (stability): 1 "
                     "stable, 0 unstable, -1 unknown (not solved there)"),
                data("floquet", f"(n, {FLOQUET}) 1/s complex, as an frf's")),
          group(LEVEL_FREE, "(peak, levels) the free bodies' peak", ("label", *_RUN),
                *LEVEL_DATA),
          group(LEVEL_STUCK, "(peak, levels) the fully stuck peak", ("label", *_RUN),
                *LEVEL_DATA),
          group(SAMPLES, "(uncertainty) one row per sample",
                ("names (the uncertain parameters, JSON)", "design", "seed",
                 "distributions (JSON)"),
                data("parameters", "(n, p) the sampled values"),
                data("peak", "(n,) m, the peak in the window (NaN: none)"),
                data("omega", "(n,) rad/s, where it is"),
                data("slip_share", "(n,) share of the contact points slipping there"),
                data("points", "(n,) continuation points of the sample's sweeps"),
                data("samples", "(n,) time samples per period of its sweeps (the case's, or "
                     "twice as many where those could not cover the window: each sweep then "
                     "goes on from where it stopped at twice the samples, what it found "
                     "kept)"),
                data("seconds", "(n,) s, the sample's task when it was computed"),
                data("status", "(n,) complete | stopped | failed | not run")),
          group(STATISTICS, "(uncertainty) of the complete samples' peaks",
                ("percent", "mean", "std", "count", "limit", "exceedance (P(peak > limit))",
                 "exceedance_error", "free_peak", "free_omega", "stuck_peak",
                 "stuck_omega (levels)"),
                data("percentiles", "(3,) m, at percent (5, 50, 95)"),
                data("spearman", "(p,) rank correlation of the peak with each parameter"),
                data("prcc", "(p,) partial rank correlation")),
          *MISTUNING_GROUPS,
          Entry("curve_NNN", "(mistuning, a family) a member's study: its patterns/ and "
                "amplification/ as above", ("label", "family_key", "family_value"),
                MISTUNING_GROUPS, repeated=True),
          group("curve_NNN", "(loops) one loop per amplitude",
                ("label", *_RUN, "law", "contact", "dim", "mu", "motion (u | u_x | v)"),
                data("amplitude", "(a,) the multipliers"),
                data("motion_amplitude", "(a,) m, of the scaled motion"),
                data("u", "(a, dim, samples) m"), data("v", "(a, samples) m"),
                data("T", "(a, dim, samples) N"), data("N", "(a, samples) N"),
                data("dissipation", "(a,) J/cycle"), data("state", "(a,) over the loop")),
          group("<body>/nd<h> (or <body>/body)", "(modes) one body at one nodal diameter "
                "(a body without cyclic symmetry: body)",
                ("n_free", "seconds", "reduced_modes", "master_dofs"),
                data("frequencies_hz", "(k,) Hz, of the unreduced body held as reduced"),
                data("reduced_hz", "(k,) Hz, of its reduced model, masters free"),
                data("relative_error", "(k,) reduced_hz / frequencies_hz - 1"),
                data("nodes", "(n_v,) the body's vertices (mesh indices)"),
                data("shapes", "(k, n_v, 3) the vertices' displacements per mode, mass-"
                     "normalised (complex at 0 < h < Ns/2; shapes = true)")),
          group("assembly/order<n>", "(modes, an [assembly] case) the reduced assembly on "
                "harmonic n's nodal diameter, undamped", ("order",),
                data("stuck_hz", "(k,) Hz, every contact stuck (its kt, kn springs)"),
                data("free_hz", "(k,) Hz, the cyclic bodies free of contact")),
          group("curve_NNN", "(dti) the time integration",
                ("label", *_RUN, "outputs", "steps_per_period", "measure"),
                data("omega", "(n,) rad/s"),
                data("amplitude", "(n, outputs) m, max_t |x(t)|"),
                data("response", "(n, outputs) m, the measure"),
                data("coefficients", "(n, outputs, nc) m"),
                data("periods", "(n,) periods integrated"),
                data("converged", "(n,) periodic"),
                data("seconds", "(n,) s, wall time"),
                group(CONTACTS, "", (), group("<contact>", "", ("variable_normal",),
                                              data("N0", "(n, points) N static normal load"),
                                              data("T0", "(n, points, dim) N static "
                                                   "friction")))),
          group("curve_NNN", "(nonlinear_modes) one backbone: a family member",
                ("label", "family_key", "family_value", *_RUN, "elapsed_s", "outputs",
                 "harmonic_orders", "samples", "linear_omega (rad/s, the start)",
                 "linear_xi (1/s)", "start (stuck | free)", "mode"),
                data("modal_amplitude", "(n,) kg^1/2 m, the fundamental's mass-normalized "
                     "amplitude a of each level"),
                data("omega", "(n,) rad/s, the natural frequency"),
                data("xi", "(n,) 1/s, the self-excitation -xi M dq/dt"),
                data("damping_ratio", "(n,) xi / (2 omega)"),
                data("response", "(n, outputs) m, the analysis' measure"),
                data("coefficients", "(n, outputs, nc) m, as an frf's"),
                data("dissipation", "(n,) J/cycle, by the contacts"),
                data("viscous", "(n,) J/cycle, by the viscous damping"),
                data("residual", "(n,) norm of the balance residual"),
                data("iterations", "(n,) Newton iterations"),
                data("unknowns", "(n, u) the balance unknowns"),
                data("unknown_dofs", "(u / nc,) model DOF of each unknown block"),
                data("peak_excitation", "(n,) the excitation multiplier whose resonance "
                     "peak is at each level (synthesized)"),
                data("peak_frequency", "(n,) rad/s, that resonance's frequency"),
                data("modal_force", "(n,) N kg^-1/2, |psi_1^H F_1| at unit multiplier"),
                data("excitations", "(k,) the analysis' excitation multipliers"),
                data("peak_response", "(k, outputs) m, the synthesized resonance peak at "
                     "each (NaN: beyond the levels computed)"),
                data("peak_omega", "(k,) rad/s, where it is"),
                data("peak_check", "(k, outputs) m, the forced balance solved directly at "
                     "that frequency and excitation from the mode's motion (NaN: failed)"),
                data("peak_damping_ratio", "(k,) the mode's damping ratio there"),
                data("peak_modal_amplitude", "(k,) kg^1/2 m, its level"),
                data("frequencies", "(k, 2, n) rad/s, the two frequencies at which each "
                     "level is the response to each excitation (NaN: not reached)"),
                group(CONTACTS, "as an frf's", (),
                      group("<contact>", "", (), *(
                          data(d, "as an frf's") for d in (
                              "state", "node_state", "dissipation", "slip_fraction",
                              "static_force", "columns", "undersampled")))),
                group(PATCHES, "(assembly)", (), group("<patch>", "", (), *_PATCH_STATE))),
          group("step_N", "(transient) load step 1 (the static load), 2 (the harmonic)",
                ("label", *_RUN, "outputs", "contacts (their order)"),
                data("t", "(steps,) s"), data("q", "(steps, outputs) m"),
                data("F", "(steps, outputs) N"),
                group(CONTACTS, "", (), group("<contact>", "", ("mu",),
                                              *_CONTACT_HISTORY)))))


def _candidates(parent: Entry, name: str, dataset: bool) -> list[Entry]:
    return [e for e in parent.children if e.dataset == dataset
            and e.matches(name)]


def undescribed(root) -> list[str]:
    """The objects and attributes of an open results file (``h5py.File``) that LAYOUT does
    not describe: an empty list when the file follows the layout. A group may match several
    entries (a curve of each analysis type): it follows the layout if one of them
    describes all of it."""
    return _check(root, LAYOUT, "")


def _check(obj, entry: Entry, path: str) -> list[str]:
    import h5py

    faults = []
    known = entry.attribute_names()
    if "..." not in known:
        faults += [f"{path or '/'} attr {a}" for a in obj.attrs if a not in known]
    if not isinstance(obj, h5py.Group):
        return faults
    for name, child in obj.items():
        here = f"{path}/{name}"
        options = _candidates(entry, name, isinstance(child, h5py.Dataset))
        if not options:
            faults.append(here)
            continue
        found = [_check(child, e, here) for e in options]
        faults += min(found, key=len)
    return faults


_COLUMN = 28  # where the descriptions start
_WIDTH = 96


def layout_text() -> str:
    """The README's layout section: the tree, two spaces of indent per level, each entry's
    description (and attributes) from column 28."""
    return "\n".join(_lines(LAYOUT, 0)) + "\n"


def _lines(entry: Entry, depth: int) -> Iterator[str]:
    name = entry.name if entry.dataset or entry.name == "/" else entry.name + "/"
    head = f"{'  ' * depth}{name}"
    parts = [x for x in (entry.doc, f"attrs: {', '.join(entry.attrs)}" if entry.attrs
                         else "") if x]
    text = "; ".join(parts)
    if len(head) >= _COLUMN:
        yield head
        head = ""
    wrapped = textwrap.wrap(text, _WIDTH - _COLUMN) or [""]
    yield f"{head:<{_COLUMN}}{wrapped[0]}".rstrip()
    yield from (" " * _COLUMN + line for line in wrapped[1:])
    for child in () if entry.repeated else entry.children:
        yield from _lines(child, depth + 1)
