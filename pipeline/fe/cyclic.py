"""Cyclic symmetry (Firrone & Zucca 5.1.1): sector matrices per nodal diameter.

Sector angle phi = 2 pi / Ns about the disk axis +z. The right-face nodes are the images of the
left-face nodes under R(+phi) (``CyclicBoundary.right[i] = R(phi) left[i]``). For nodal diameter
h the right-face DOFs are eliminated with

    u_R = exp(i h phi) R(phi) u_L        (Cartesian DOFs, P2 edge DOFs included)

so that u_body = P_h u_free and K_h = P_h^H K P_h, M_h = P_h^H M P_h: complex Hermitian, real for
h = 0 and h = Ns/2.

Faces meshed independently (``CyclicBoundary.matching`` False) are tied by interpolation: each
DOF of the finer face (the slave; its vertices, and its edge midpoints for quadratic elements)
follows the other face's displacement interpolated at its rotated position with the facet's
shape functions (the trace of the element: 3- or 6-node triangle, 4- or 8-node quad),

    u_S = exp(+-i h phi) R(+-phi) W u_M,        (+ when the right face is the slave)

a non-conforming tie whose error is of the order of the discretization error.

Sector s of the disk then carries exp(i h s phi) R(s phi) u (a forward
travelling wave for a time factor exp(i w t)).

Engine-order excitation EO: temporal harmonic n lives on nodal diameter n EO mod Ns, folded into
0..Ns/2; a fold (residue > Ns/2) is a backward wave whose sector matrices are the complex
conjugates of those of ND Ns - residue. The 0th harmonic is ND 0.

Clamped node sets are removed after the cyclic elimination (their DOFs are zero).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from microslip.geometry import surfaces
from microslip.geometry.boundaries import own_images_only
from microslip.geometry.mesh import mid_edge_points, rotation_z

from .fem import BodyModel, IntArray


def _check_sectors(sectors: int) -> None:
    if not (isinstance(sectors, int | np.integer) and sectors >= 2):
        raise ValueError(f"sectors={sectors!r}: must be an integer >= 2")


def check_nodal_diameter(nodal_diameter: int, sectors: int) -> None:
    """ValueError unless 0 <= nodal_diameter <= sectors // 2."""
    _check_sectors(sectors)
    if not (
        isinstance(nodal_diameter, int | np.integer) and 0 <= nodal_diameter <= sectors // 2
    ):
        raise ValueError(
            f"nodal_diameter={nodal_diameter!r}: must be an integer in 0..{sectors // 2} "
            f"(sectors={sectors})"
        )


def phase(nodal_diameter: int, sectors: int) -> complex | float:
    """Inter-sector phase factor exp(i h phi); exactly +-1.0 (real) for h = 0 and h = Ns/2."""
    check_nodal_diameter(nodal_diameter, sectors)
    if nodal_diameter == 0:
        return 1.0
    if 2 * nodal_diameter == sectors:
        return -1.0
    return complex(np.exp(2j * np.pi * nodal_diameter / sectors))


def harmonic_nodal_diameter(harmonic: int, engine_order: int, sectors: int) -> tuple[int, bool]:
    """(nodal diameter, conjugate) on which temporal harmonic n of an EO excitation lives.

    ``conjugate`` is True for a backward wave: use the complex conjugates of that ND's matrices.
    """
    _check_sectors(sectors)
    if not (isinstance(harmonic, int | np.integer) and harmonic >= 0):
        raise ValueError(f"harmonic={harmonic!r}: must be an integer >= 0")
    if not isinstance(engine_order, int | np.integer):
        raise ValueError(f"engine_order={engine_order!r}: must be an integer")
    residue = (harmonic * engine_order) % sectors
    if 2 * residue <= sectors:
        return int(residue), False
    return int(sectors - residue), True


def nodal_diameters(harmonics: Iterable[int], engine_order: int, sectors: int) -> tuple[int, ...]:
    """Sorted distinct nodal diameters a case with these harmonics and engine order needs."""
    return tuple(
        sorted({harmonic_nodal_diameter(n, engine_order, sectors)[0] for n in harmonics})
    )


def check_boundary(body: BodyModel, boundary: Any, rtol: float = 1e-8) -> None:
    """Validate a CyclicBoundary against the body: faces in the body and disjoint but for the
    axis nodes (each its own image); matching faces' pairs rotated images (the comparison
    only checks the given pairing)."""
    left = np.asarray(boundary.left, dtype=np.int64)
    right = np.asarray(boundary.right, dtype=np.int64)
    _check_sectors(boundary.sectors)
    if left.ndim != 1 or right.ndim != 1 or (boundary.matching and left.shape != right.shape):
        raise ValueError(
            f"cyclic boundary: left {left.shape} and right {right.shape} must be equal 1-D shapes"
        )
    if not own_images_only(left, right, boundary.matching):
        raise ValueError("cyclic boundary: a node is on both faces but not its own image "
                         "(only a node on the axis is)")
    pl = body.points[body.local_nodes(left, "cyclic boundary left")]
    pr = body.points[body.local_nodes(right, "cyclic boundary right")]
    if not boundary.matching:
        return
    R = rotation_z(2.0 * np.pi / boundary.sectors)
    scale = max(float(np.abs(body.points).max()), 1e-300)
    err = float(np.abs(pl @ R.T - pr).max()) if len(pl) else 0.0
    if err > rtol * scale:
        raise ValueError(
            f"cyclic boundary: right nodes are not R(2 pi/{boundary.sectors}) images of the left "
            f"nodes (max deviation {err:.3e} m)"
        )


@dataclass(frozen=True)
class FaceTie:
    """u_S = sign-phase R W u_M: the slave face's DOFs from the master face's.

    slave: (k, 3) and master: (m, 3) DOF triples (x, y, z); weights: (k, m) CSR;
    slave_is_right: the right face is the slave (u_S = exp(i h phi) R(phi) W u_M), else
    the left one (exp(-i h phi) R(-phi)).
    """

    slave: IntArray
    master: IntArray
    weights: sp.csr_matrix
    slave_is_right: bool


def face_tie(body: BodyModel, boundary: Any) -> FaceTie:
    """The tie of a body's cyclic faces: node for node (right from left) when they match,
    by interpolation (the finer face from the other) when they do not."""
    left = np.asarray(boundary.left, dtype=np.int64)
    right = np.asarray(boundary.right, dtype=np.int64)
    if not boundary.matching:
        return _interpolated_tie(body, boundary)
    right_dofs = [body.dofs_of_nodes(right, "cyclic boundary right")]
    left_dofs = [body.dofs_of_nodes(left, "cyclic boundary left")]
    if body.order == 2:
        e_right = body.set_edges(right)
        pairs = body.edges[e_right]
        to_left = dict(zip(right.tolist(), left.tolist(), strict=True))
        image = np.vectorize(to_left.__getitem__, otypes=[np.int64])(pairs)
        e_left = body.edge_index(image)
        if np.any(e_left < 0):
            raise ValueError(
                "cyclic boundary: right-face edges have no left-face counterpart "
                "(faces are not periodic meshes)"
            )
        right_dofs.append(body.edge_dofs[e_right])
        left_dofs.append(body.edge_dofs[e_left])
    slave, master = np.concatenate(right_dofs), np.concatenate(left_dofs)
    return FaceTie(slave, master, sp.identity(len(slave), format="csr"), True)


def _interpolated_tie(body: BodyModel, boundary: Any) -> FaceTie:
    """The finer face's vertices (and edge midpoints, order 2) interpolated on the other."""
    left = np.asarray(boundary.left, dtype=np.int64)
    right = np.asarray(boundary.right, dtype=np.int64)
    slave_is_right = boundary.slave_is_right
    slave, master = (right, left) if slave_is_right else (left, right)
    back = rotation_z(-boundary.angle if slave_is_right else boundary.angle)  # -> master
    xyz = np.zeros((int(body.nodes[-1]) + 1, 3))
    xyz[body.nodes] = body.points
    surface = surfaces.surface_of(body.cells, master)
    # the slave's DOF carriers: vertices, then (order 2) the midpoints of its face edges
    points = [xyz[slave]]
    slave_dofs = [body.dofs_of_nodes(slave, "cyclic face")]
    if body.order == 2:
        edges = body.set_edges(slave)
        points.append(xyz[body.edges[edges]].mean(axis=1))
        slave_dofs.append(body.edge_dofs[edges])
    where = surfaces.project(np.concatenate(points) @ back.T, xyz, surface)
    rows, keys, values = _facet_weights(body, surface, where)
    master_keys, column = np.unique(keys, return_inverse=True)
    vertex = master_keys < 0  # keys: -(node + 1) for a vertex, edge index otherwise
    master_dofs = np.empty((len(master_keys), 3), dtype=np.int64)
    master_dofs[vertex] = body.dofs_of_nodes(-master_keys[vertex] - 1, "cyclic face")
    master_dofs[~vertex] = body.edge_dofs[master_keys[~vertex]]
    weights = sp.csr_matrix((values, (rows, column)),
                            shape=(sum(len(p) for p in points), len(master_keys)))
    return FaceTie(np.concatenate(slave_dofs), master_dofs, weights, slave_is_right)


def _facet_weights(body: BodyModel, surface: Any, where: Any
                   ) -> tuple[IntArray, IntArray, NDArray]:
    """(row, key, weight) triplets of the facets' shape functions of the body's order: a
    vertex keyed -(node + 1), an edge by its index."""
    (rows, nodes, w_corner), (rows_mid, pairs, w_mid) = surfaces.interpolation(
        surface, where, body.order)
    edges = body.edge_index(pairs)
    if np.any(edges < 0):  # (-1 would read as vertex 0's key)
        raise ValueError("cyclic face: a facet edge is not an edge of the body")
    return (np.concatenate([rows, rows_mid]), np.concatenate([-(nodes + 1), edges]),
            np.concatenate([w_corner, w_mid]))


@dataclass(frozen=True, eq=False)
class SectorModel:
    """Matrices of one body with constraints (and cyclic symmetry at one ND) applied.

    stiffness, mass: (n_f, n_f) CSR over the free coordinates; float64, or complex128
    Hermitian for 0 < h < Ns/2.
    free_dofs: (n_f,) sorted, the body DOF each free coordinate stands for (a node held in
    some directions of a local frame keeps its free directions as coordinates, standing for
    the first of its DOFs).
    expansion: (N, n_f) CSR P_h, u_body = P_h u_free.
    nodal_diameter, sectors: None for a body without cyclic symmetry (e.g. the damper).
    clamped_nodes: global node indices held fixed; supports: the nodes held in some
    directions (``geometry.boundaries.Support``).
    """

    body: BodyModel
    stiffness: sp.csr_matrix
    mass: sp.csr_matrix
    free_dofs: IntArray
    expansion: sp.csr_matrix
    nodal_diameter: int | None
    sectors: int | None
    clamped_nodes: IntArray
    supports: tuple[Any, ...] = ()

    @property
    def n_free(self) -> int:
        return int(self.stiffness.shape[0])

    @property
    def is_complex(self) -> bool:
        return bool(np.iscomplexobj(self.stiffness.data))

    def free_index(self, nodes: Sequence[int] | IntArray, what: str = "nodes") -> IntArray:
        """(k, 3) positions in the free vector of the x, y, z DOFs of global vertices ``nodes``.

        ValueError for a node that is clamped or on the eliminated right cyclic face.
        """
        dofs = self.body.dofs_of_nodes(nodes, what)
        pos = np.searchsorted(self.free_dofs, dofs)
        pos_c = np.minimum(pos, len(self.free_dofs) - 1)
        ok = self.free_dofs[pos_c] == dofs
        if not ok.all():
            bad = np.asarray(nodes).ravel()[~ok.all(axis=1)]
            raise ValueError(
                f"{what}: node(s) {bad[:8].tolist()} have no free DOFs (clamped, or on the "
                "right cyclic face, or the finer of two non-matching ones, whose DOFs follow "
                "the other face; use nodes of the other face)"
            )
        return pos_c


def _held_triples(body: BodyModel, supports: Sequence[Any]) -> dict[int, np.ndarray]:
    """First DOF of each DOF triple a support holds -> (m, 3) the unit vectors held there
    (every support's, at the vertex or the mid-edge point; an edge is held where both its
    ends are, on the body's surface, as ``BodyModel.set_dofs`` holds a clamped set's)."""
    points = np.zeros((int(body.nodes[-1]) + 1, 3))
    points[body.nodes] = body.points
    held: dict[int, list[np.ndarray]] = {}
    for support in supports:
        nodes = np.intersect1d(support.nodes, body.nodes)
        triples = [body.dofs_of_nodes(nodes, "supported nodes")]
        xyz = [points[nodes]]
        if len(body.edge_dofs):
            edges = body.set_edges(nodes)
            triples.append(body.edge_dofs[edges])
            xyz.append(mid_edge_points(points, body.edges[edges], body.curved_edges,
                                       body.edge_nodes))
        vectors = support.held_directions(np.concatenate(xyz))
        for triple, v in zip(np.concatenate(triples), vectors, strict=True):
            held.setdefault(int(triple[0]), []).append(v)
    return {k: np.concatenate(v) for k, v in held.items()}


def _kept_directions(held: np.ndarray) -> np.ndarray:
    """(3 - rank, 3) orthonormal rows spanning what the held vectors (m, 3) leave free."""
    _, sigma, vt = np.linalg.svd(held)
    return vt[int((sigma > 1e-9).sum()):]


def _supported_basis(body: BodyModel, removed: np.ndarray, supports: Sequence[Any],
                     on_axis: dict[int, np.ndarray] | None = None
                     ) -> tuple[sp.csr_matrix, IntArray, dict[int, np.ndarray]]:
    """(B (N, n_q) CSR, owner (n_q,), kept): u_body = B q over the DOFs not ``removed``, a
    supported triple's coordinates its free directions; owner: the body DOF each column
    stands for (sorted); kept: first DOF of a supported triple -> its free directions
    (rows). ``on_axis``: first DOF of a triple on a sector's axis -> the (complex)
    directions its nodal diameter leaves it (kept as they are: no support holds more)."""
    N = body.n_dofs
    kept = {k: _kept_directions(v) for k, v in _held_triples(body, supports).items()
            if not removed[k]}
    for k, directions in (on_axis or {}).items():
        if not removed[k]:
            kept[k] = directions
    plain = ~removed
    for k in kept:
        plain[k:k + 3] = False
    rows, vals = [np.flatnonzero(plain)], [np.ones(int(plain.sum()))]
    owner = [rows[0]]
    for k, directions in kept.items():
        for j, d in enumerate(directions):
            rows.append(k + np.arange(3))
            vals.append(d)
            owner.append(np.full(3, k + j))
    owner_of_entry = np.concatenate(owner)
    column_owner = np.unique(owner_of_entry)
    columns = np.searchsorted(column_owner, owner_of_entry)
    B = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), columns)),
                      shape=(N, len(column_owner)),
                      dtype=np.result_type(*vals) if vals else np.float64)
    return B, column_owner.astype(np.int64), kept


def sector_model(
    body: BodyModel,
    clamped_nodes: Sequence[int] | IntArray = (),
    boundary: Any = None,
    nodal_diameter: int = 0,
    supports: Sequence[Any] = (),
) -> SectorModel:
    """Apply clamps, supports (``geometry.boundaries.Support``: nodes held in some directions) and
    (if ``boundary`` is a CyclicBoundary) the ND-h cyclic condition.

    u_body = P q: a supported node's DOFs are the combinations of its free directions; the
    slave face's DOFs follow the master's (their supports then project them on their own
    free directions; a clamped slave DOF stays zero)."""
    clamped_nodes = np.unique(np.asarray(clamped_nodes, dtype=np.int64))
    clamped = body.set_dofs(clamped_nodes, "clamped nodes") if clamped_nodes.size else None
    N = body.n_dofs
    removed = np.zeros(N, dtype=bool)
    if clamped is not None:
        removed[clamped] = True
    dtype: type = np.float64
    if boundary is None:
        B, owner, kept = _supported_basis(body, removed, supports)
        P, sectors = B, None
    else:
        sectors = int(boundary.sectors)
        check_nodal_diameter(nodal_diameter, sectors)
        check_boundary(body, boundary)
        tie, axis = _axis_apart(face_tie(body, boundary))
        T = phase(nodal_diameter, sectors) * rotation_z(2.0 * np.pi / sectors)
        if not tie.slave_is_right:  # the left face follows the right: the inverse
            T = np.conj(phase(nodal_diameter, sectors)) * rotation_z(-2.0 * np.pi / sectors)
        dtype = np.complex128 if np.iscomplexobj(T) else np.float64
        free_on_axis = _kept_directions(np.eye(3) - T).conj()  # u = T u on the axis
        B, owner, kept = _supported_basis(body, removed, supports,
                                          {int(k): free_on_axis for k in axis[:, 0]})
        slave = np.zeros(N, dtype=bool)
        slave[tie.slave.ravel()] = True
        P = _tied(B, tie, T, removed, slave, kept)
        keep = ~slave[owner]
        P, owner = P[:, np.flatnonzero(keep)], owner[keep]
    P = sp.csr_matrix(P, dtype=dtype)
    PH = P.conj().T.tocsr()
    K = (PH @ body.stiffness @ P).tocsr()
    M = (PH @ body.mass @ P).tocsr()
    K = (0.5 * (K + K.conj().T)).tocsr()  # exactly Hermitian
    M = (0.5 * (M + M.conj().T)).tocsr()
    return SectorModel(
        body=body,
        stiffness=K,
        mass=M,
        free_dofs=owner,
        expansion=P,
        nodal_diameter=int(nodal_diameter) if boundary is not None else None,
        sectors=sectors,
        clamped_nodes=clamped_nodes,
        supports=tuple(supports),
    )


def _axis_apart(tie: FaceTie) -> tuple[FaceTie, IntArray]:
    """(the tie without the DOF triples that are their own image, those triples (k, 3)): a
    sector containing the axis has its axis nodes (and edges along it) on both faces."""
    if not tie.slave_is_right or tie.weights.shape[0] != tie.weights.shape[1]:
        return tie, np.empty((0, 3), dtype=np.int64)  # (interpolated faces: none on it)
    own = tie.slave[:, 0] == tie.master[:, 0]
    if not own.any():
        return tie, np.empty((0, 3), dtype=np.int64)
    rest = np.flatnonzero(~own)
    return (FaceTie(tie.slave[rest], tie.master[rest], sp.identity(len(rest), format="csr"),
                    True), tie.slave[own])


def _tied(B: sp.csr_matrix, tie: FaceTie, T: np.ndarray, removed: np.ndarray,
          slave: np.ndarray, kept: dict[int, np.ndarray]) -> sp.csr_matrix:
    """P = D B + Pi G B: the non-slave rows of B, and each slave DOF the master's
    displacement interpolated and turned (G: u_S[a] = sum_b T[a, b] sum_j W[., j] u_M[j, b]),
    projected on the slave's own free directions (Pi: zero for a clamped slave DOF);
    ``slave``: (N,) the DOFs that follow."""
    W = tie.weights.tocoo()
    rows, cols, vals = [], [], []
    for a in range(3):
        for b in range(3):
            if T[a, b] != 0:
                rows.append(tie.slave[W.row, a])
                cols.append(tie.master[W.col, b])
                vals.append(T[a, b] * W.data)
    N = len(slave)
    G = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(N, N))
    plain = slave & ~removed
    r, c, v = [], [], []
    for k, directions in kept.items():
        if slave[k]:  # the projection on the slave's free directions
            plain[k:k + 3] = False
            r.append(np.repeat(k + np.arange(3), 3))
            c.append(np.tile(k + np.arange(3), 3))
            v.append((directions.T @ directions).ravel())
    r.append(np.flatnonzero(plain))
    c.append(r[-1])
    v.append(np.ones(len(r[-1])))
    Pi = sp.csr_matrix((np.concatenate(v), (np.concatenate(r), np.concatenate(c))),
                       shape=(N, N))
    D = sp.diags((~slave).astype(float))
    return (D @ B + Pi @ (G @ B)).tocsr()


# --- full disk: for pictures and for checking the sector model -----------------------------


def expand_to_disk(displacement: NDArray, nodal_diameter: int, sectors: int) -> NDArray:
    """Sector-by-sector displacement of the full disk from a sector solution at ND h.

    displacement: (n, 3) complex amplitudes of the fundamental sector's nodes.
    Returns (Ns, n, 3): sector s carries exp(i h s phi) R(s phi) u (same node order).
    Take the real part (times exp(i w t)) for a picture.
    """
    check_nodal_diameter(nodal_diameter, sectors)
    u = np.asarray(displacement)
    phi = 2.0 * np.pi / sectors
    out = np.empty((sectors, *u.shape), dtype=np.complex128)
    for s in range(sectors):
        out[s] = np.exp(1j * nodal_diameter * s * phi) * (u @ rotation_z(s * phi).T)
    return out
