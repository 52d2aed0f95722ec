"""Reduced bodies + contact patches -> the harmonic-balance model (Firrone & Zucca 4.2, 5.1-5.3).

Per harmonic order n, a cyclic body enters with its reduced model at nodal diameter
h(n) = n EO mod Ns (folded into 0..Ns/2; a backward wave takes the complex conjugates), a
body without cyclic symmetry (the damper) with its one model at every order. The shared DOFs
of the balance are the master DOFs of every body (the same physical DOFs at every order);
each order also has the fixed-interface modal coordinates of its models, whose number differs
between nodal diameters, and the balance condenses them per order.

One contact point per node pair of a patch, in the pair's frame (rows t1, t2, n; n the patch
normal from body a into body b): the relative displacement ``g = F (u_a - u_b')`` with
``u_b'`` the displacement of the touching face. When that face belongs to the neighbouring
sector (``b_sector_offset = k``), sector k moves as ``exp(i n EO k phi) R(k phi) u_b`` at
harmonic n (the cyclic wave of the engine order; the same phase whether the ND's matrices are
conjugated or not, since they describe the true amplitudes of the fundamental sector), so
the kinematics is complex per order. The forces act on the DOFs as ``B^H f`` (virtual work),
which the harmonic balance's real layout gives.

Named surfaces (``geometry.pairing``) pair node to surface: ``u_b'`` is then side b's
displacement interpolated at the pair with the facet's shape functions, each pair has its
own frame and share of the stiffness; against the ground there is no ``u_b'``.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import scipy.sparse as sp

from microslip.fe import cyclic
from microslip.fe.contact_stiffness import PatchStiffness
from microslip.fe.reduced_model import ReducedModel
from microslip.fourier import Harmonics
from microslip.geometry.mesh import Mesh, rotation_z
from microslip.geometry.pairing import nodal_areas_and_normals, paired_contact, surface_body
from microslip.geometry.surfaces import surface_of
from microslip.laws.coulomb import ContactElements
from microslip.solve.hbm import Contact, HarmonicBalance
from microslip.solve.linear import Excitation, LinearDynamics

from .recovery import AssemblyModel, BodyLayout, ContactPoints, body_positions
from .spec import AssemblySpec, PatchFriction


def join(mesh: Mesh, models: Mapping[str, Mapping[int, ReducedModel]],
           patch_stiffness: Mapping[str, PatchStiffness], spec: AssemblySpec,
           harmonics: Harmonics, *, sub_sample: bool = True, jacobian: str = "auto"
           ) -> AssemblyModel:
    """The assembly model of ``spec`` over the reduced ``models`` (body -> ND -> model, as the
    structural stage gives them) with the patches' stiffness per node pair.

    Everything named is checked before any matrix is built (ValueError naming it)."""
    _check(mesh, models, patch_stiffness, spec, harmonics)
    layout = _layout(mesh, models, spec, harmonics)
    n_dof = sum(b.n_masters for b in layout)
    node_dof = _node_dofs(layout)
    contacts, points = [], {}
    for pc in spec.contacts:
        for c, pts in _patch_contacts(mesh, pc, patch_stiffness[pc.patch], node_dof, n_dof,
                                      spec.engine_order, harmonics):
            contacts.append(c)
            points[c.name] = pts
    K, M, C, Mp = _linear(layout, harmonics, n_dof, set(spec.mass_bodies))
    if 0 in harmonics.orders and spec.static_anchor > 0:
        free = {b for b, per_nd in models.items() if per_nd[min(per_nd)].has_rigid_mode}
        anchored = [c for c in contacts if {points[c.name].body_a, points[c.name].body_b} & free]
        if any(K[o] is K[0] for o in K if o != 0):
            K[0] = K[0].copy()  # (the other orders' stiffness has no anchor)
        K[0][:n_dof, :n_dof] += static_anchor(anchored, n_dof, spec.static_anchor)
    linear = LinearDynamics.create(K, M, C, harmonics=harmonics, mass_part=Mp, n_shared=n_dof)
    excitation = _excitation(mesh, layout, node_dof, n_dof, spec, harmonics)
    hb = HarmonicBalance(linear, contacts, excitation, harmonics, sub_sample=sub_sample,
                         jacobian=jacobian)
    outputs = {o.name: _row(mesh, node_dof, n_dof, o.node_set, o.direction)
               for o in spec.outputs}
    dof_nodes = np.concatenate([np.repeat(b.master_nodes, 3) for b in layout])
    return AssemblyModel(hb, tuple(layout), dof_nodes, outputs, points, spec)


# --- checks -----------------------------------------------------------------------------------


def _check(mesh, models, stiffness, spec: AssemblySpec, harmonics: Harmonics) -> None:
    for pc in spec.contacts:
        if pc.patch not in mesh.contacts:
            raise ValueError(f"contacts.{pc.patch}: not a contact patch of the mesh; it has "
                             f"{sorted(mesh.contacts)}")
        if pc.patch not in stiffness:
            raise ValueError(f"contacts.{pc.patch}: no contact stiffness for this patch")
        p = mesh.contacts[pc.patch]
        for body in (p.body_a, p.body_b):
            if body is not None and body not in models:
                raise ValueError(f"contacts.{pc.patch}: body {body!r} has no reduced model")
    for body in (*spec.centrifugal, *spec.mass_bodies):
        if body not in models:
            raise ValueError(f"body {body!r} has no reduced model; bodies: {sorted(models)}")
    for load in spec.loads:
        if load.harmonic not in harmonics.orders:
            raise ValueError(f"loads.{load.node_set}.harmonic = {load.harmonic}: not among "
                             f"the harmonic orders {list(harmonics.orders)}")
    for name in [x.node_set for x in (*spec.loads, *spec.outputs)]:
        if name not in mesh.node_sets:
            raise ValueError(f"node set {name!r} does not exist; the mesh has "
                             f"{sorted(mesh.node_sets)}")
    if spec.centrifugal and 0 not in harmonics.orders:
        raise ValueError("centrifugal loads are static: the harmonics must include order 0")


# --- the linear part ----------------------------------------------------------------------------


def _layout(mesh: Mesh, models, spec: AssemblySpec, harmonics: Harmonics) -> list[BodyLayout]:
    """Each body's model per order and where its masters and modes sit."""
    out, offset = [], 0
    for body in sorted(models):
        per_nd = models[body]
        boundary = mesh.cyclic.get(body)
        chosen, conj = [], []
        for o in harmonics.orders:
            if boundary is None:
                h, c = min(per_nd), False
            else:
                h, c = cyclic.harmonic_nodal_diameter(o, spec.engine_order, boundary.sectors)
                if h not in per_nd:
                    raise ValueError(
                        f"body {body!r}: harmonic {o} with engine order {spec.engine_order} "
                        f"lives on nodal diameter {h}, which was not reduced (reduced: "
                        f"{sorted(per_nd)}); add it to [reduction]")
            chosen.append(per_nd[h])
            conj.append(c)
        first = chosen[0]
        for m in chosen[1:]:
            if not np.array_equal(m.master_nodes, first.master_nodes):
                raise ValueError(f"body {body!r}: the models of its nodal diameters have "
                                 "different master nodes")
        out.append(BodyLayout(body, boundary is not None, offset, first.master_nodes,
                              tuple(chosen), tuple(conj)))
        offset += 3 * len(first.master_nodes)
    return out


def _node_dofs(layout: list[BodyLayout]) -> dict[int, int]:
    """Global node -> first shared DOF (x; y, z follow)."""
    return {int(n): b.offset + 3 * i for b in layout for i, n in enumerate(b.master_nodes)}


def _linear(layout: list[BodyLayout], harmonics: Harmonics, n_dof: int, mass_bodies: set[str]):
    """Per order K, M, C, M_part: block-diagonal over the bodies, masters in the shared part,
    modes past it in body order."""
    K, M, C, Mp = {}, {}, {}, {}
    for k, o in enumerate(harmonics.orders):
        if k and all(b.models[k] is b.models[0] and b.conjugate[k] == b.conjugate[0]
                     for b in layout):  # no cyclic body: every order the same matrices,
            first = harmonics.orders[0]  # held once (a whole disk's are GBs each)
            K[o], M[o], C[o], Mp[o] = K[first], M[first], C[first], Mp[first]
            continue
        n = n_dof + sum(b.models[k].n_modes for b in layout)
        K[o], M[o], C[o], Mp[o] = (np.zeros((n, n), dtype=complex) for _ in range(4))
        for b, idx in body_positions(layout, k, n_dof):
            Kb, Mb, Cb = b.models[k].matrices(conjugate=b.conjugate[k])
            ix = np.ix_(idx, idx)
            K[o][ix], M[o][ix], C[o][ix] = Kb, Mb, Cb
            if b.body in mass_bodies:
                Mp[o][ix] = Mb
    return K, M, C, Mp


def static_anchor(contacts: list[Contact], n_dof: int, ratio: float) -> np.ndarray:
    """(n_dof, n_dof) real stiffness ``ratio sum B_t^T kt B_t`` of order 0: a spring of
    ``ratio kt`` on every pair's mean tangential relative displacement.

    A contact that opens during the period starts each closure from zero tangential force,
    and one in gross slip forgets where it started: either way its mean tangential force
    does not depend on the mean tangential displacement, and a body held by such contacts
    alone (a damper at a partial lift-off resonance) has a mean position the balance leaves
    free (the order-0 Jacobian is singular; Newton stalls and continuation crawls). The
    anchor picks the position nearest the undeformed one. Where a pair sticks, its static
    tangential stiffness grows by the ratio (1e-3 changes the blisk's peak by < 1e-4,
    measured: see the README). ``join`` anchors the contacts of free bodies only (whose
    static model has a rigid mode, ``ReducedModel.has_rigid_mode``): between held bodies (a
    shroud's interlock, whose blade untwists under the centrifugal load) the anchor would
    hold back a static motion nothing else resists."""
    A = np.zeros((n_dof, n_dof))
    for c in contacts:
        el = c.elements
        B = np.real(np.asarray(c.kinematics[0])).reshape(el.size, el.n_components, n_dof)
        for j in range(el.dim):
            A += B[:, j, :].T @ (el.kt[:, j, None] * B[:, j, :])
    return ratio * A


# --- contacts -----------------------------------------------------------------------------------


def _patch_contacts(mesh: Mesh, pc: PatchFriction, stiffness: PatchStiffness,
                    node_dof: dict[int, int], n_dof: int, engine_order: int,
                    harmonics: Harmonics) -> list[tuple[Contact, ContactPoints]]:
    """The contact(s) of one patch: one law-D element per node pair, or two law-B ones.

    A pair's partner displacement is side b's interpolated at the pair (``weights``; one
    node for node), turned and phased when side b is a neighbouring sector's; against the
    ground there is none."""
    c = paired_contact(mesh, pc.patch)
    p = c.pairing
    frames = c.frames
    kn = pc.stiffness_scale * stiffness.normal.ravel()
    kt = pc.stiffness_scale * stiffness.tangential.ravel()
    for name, nodes in ((c.body_a, p.nodes_a), (c.body_b, p.nodes_b)):
        missing = [int(x) for x in nodes if int(x) not in node_dof]
        if missing:
            raise ValueError(f"contacts.{pc.patch}: nodes {missing[:5]} of body {name!r} are "
                             "not masters of its reduced model")
    k = c.b_sector_offset
    if k and c.body_b not in mesh.cyclic:
        raise ValueError(f"contacts.{pc.patch}: a neighbouring-sector patch needs a cyclic "
                         f"body b, {c.body_b!r} is not")
    phi = mesh.cyclic[c.body_b].angle if k else 0.0
    rot = rotation_z(k * phi)
    da = np.array([node_dof[int(x)] for x in p.nodes_a])
    db = np.array([node_dof[int(x)] for x in p.nodes_b], dtype=np.int64)
    interference = pc.interference - p.gaps
    points = ContactPoints(pc.patch, c.body_a, c.body_b, p.nodes_a, p.nodes_b,
                           c.grid or (len(p.nodes_a),), frames, p.gaps)
    if pc.elements == "2D":
        rows = [(0, 1, 2)]
        elements = [ContactElements.create("D", kt=kt, kn=kn, mu=pc.mu,
                                           interference=interference, coupled=True,
                                           start_phase=pc.start_phase)]
        names = [pc.patch]
    else:  # two orthogonal 1D elements sharing the pair's normal stiffness
        rows = [(0, 2), (1, 2)]
        elements = [ContactElements.create("B", kt=kt, kn=0.5 * kn, mu=pc.mu,
                                           interference=interference, coupled=True,
                                           start_phase=pc.start_phase)] * 2
        names = [f"{pc.patch}.t1", f"{pc.patch}.t2"]
    out = []
    for comps, el, name in zip(rows, elements, names):
        B = {}
        for o in harmonics.orders:
            phase = np.exp(1j * o * engine_order * k * phi) if k else 1.0
            B[o] = _kinematics(frames[:, comps, :], da, db, p.weights, phase * rot, n_dof)
        out.append((Contact(name, el, B), points))
    return out


def _kinematics(frames: np.ndarray, dof_a: np.ndarray, dof_b: np.ndarray,
                weights: sp.csr_matrix, transfer: np.ndarray, n_dof: int) -> np.ndarray:
    """(P c, n_dof) complex: rows (pair, component) = F (u_a - transfer sum_j w_j u_b(j)).

    frames: (P, c, 3) rows of each pair's frame; dof_a (P,), dof_b (m,): first DOF of each
    node of side a and side b; weights: (P, m) side b's interpolation at each pair (no
    column: the ground); transfer: (3, 3) complex, the neighbouring sector's phase and
    rotation (identity for a plain pair)."""
    P, c, _ = frames.shape
    B = np.zeros((P, c, n_dof), dtype=complex)
    rows = np.arange(P)
    w = weights.tocoo()
    turned = frames @ transfer  # (P, c, 3): the pair's frame acting on side b's displacement
    for j in range(3):
        B[rows, :, dof_a + j] += frames[:, :, j]
        for r in range(c):
            np.add.at(B[:, r, :], (w.row, dof_b[w.col] + j), -w.data * turned[w.row, r, j])
    return B.reshape(P * c, n_dof)


# --- loads and outputs --------------------------------------------------------------------------


def _unit(mesh: Mesh, node: int, direction) -> np.ndarray:
    """(3,) unit vector of a named or given direction at a node."""
    if not isinstance(direction, str):
        return np.asarray(direction, dtype=float)
    if direction in ("x", "y", "z"):
        return np.eye(3)["xyz".index(direction)]
    if direction == "axial":
        return np.array([0.0, 0.0, 1.0])
    x, y, _ = mesh.points[node]
    r = np.hypot(x, y)
    if r == 0.0:
        raise ValueError(f"node {node} lies on the disk axis: no {direction} direction")
    return np.array([x / r, y / r, 0.0]) if direction == "radial" else np.array(
        [-y / r, x / r, 0.0])


def _row(mesh: Mesh, node_dof: dict[int, int], n_dof: int, node_set: str,
         direction, spread: str = "nodes") -> np.ndarray:
    """(n_dof,) mean displacement of a node set's nodes along a direction (``spread``
    "area": weighted by the nodes' tributary areas on the surface the set is a face of)."""
    nodes = np.asarray(mesh.node_sets[node_set]).ravel()
    missing = [int(x) for x in nodes if int(x) not in node_dof]
    if missing:
        raise ValueError(f"node set {node_set!r}: nodes {missing[:5]} are not masters of any "
                         "reduced body (add the set to the body's masters)")
    weights = np.full(len(nodes), 1.0 / len(nodes))
    if spread == "area":
        weights = _area_shares(mesh, node_set, nodes)
    row = np.zeros(n_dof)
    for node, w in zip(nodes, weights):
        d = node_dof[int(node)]
        row[d: d + 3] += w * _unit(mesh, int(node), direction)
    return row


def _area_shares(mesh: Mesh, node_set: str, nodes: np.ndarray) -> np.ndarray:
    """(len(nodes),) each node's share of the tributary area of the surface ``node_set``
    is a face of (nodes off that surface: 0)."""
    owners = surface_body(mesh, node_set)
    if len(owners) != 1:
        raise ValueError(f"loads.{node_set}.spread = 'area': the set must be a face of one "
                         f"body, it is a face of {owners or 'none'}")
    faces = surface_of(mesh.body_cells(owners[0]), nodes)
    on, areas, _ = nodal_areas_and_normals(mesh.points, faces)
    shares = np.zeros(len(nodes))
    shares[np.searchsorted(nodes, on)] = areas / areas.sum()
    return shares


def _excitation(mesh: Mesh, layout: list[BodyLayout], node_dof: dict[int, int], n_dof: int,
                spec: AssemblySpec, harmonics: Harmonics) -> Excitation:
    """The nodal loads per order and the centrifugal loads per unit speed^2 (order 0: the
    reduced load vector of each body, masters and modes)."""
    forces: dict[int, np.ndarray] = {}
    for load in spec.loads:
        row = _row(mesh, node_dof, n_dof, load.node_set, load.direction, load.spread)
        f = forces.setdefault(load.harmonic, np.zeros(n_dof, dtype=complex))
        f += load.amplitude * np.exp(1j * load.phase) * row  # total force over the set
    rotating = part = None
    if spec.centrifugal:
        k0 = harmonics.orders.index(0)
        n0 = n_dof + sum(b.models[k0].n_modes for b in layout)
        rotating, part = np.zeros(n0), np.zeros(n0)
        for b, idx in body_positions(layout, k0, n_dof):
            m = b.models[k0]
            if b.body in spec.centrifugal:
                if "centrifugal" not in m.loads:
                    raise ValueError(f"body {b.body!r}: its reduced model has no centrifugal "
                                     "load (reduce it again)")
                rotating[idx] = np.real(m.loads["centrifugal"])
                if b.body in spec.mass_bodies:  # a heavier damper pulls harder
                    part[idx] = np.real(m.loads["centrifugal"])
    return Excitation(forces, rotating, spec.speed if rotating is not None else None,
                      spec.engine_order if rotating is not None and spec.speed is None
                      else None, part)
