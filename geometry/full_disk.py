"""Full 360-degree model from a sector model by rotated copies (reference for cyclic checks)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import elements
from .boundaries import AveragedContact, ContactPatch, SurfaceContact
from .mesh import Mesh, rotation_z
from .pairing import PairedContact, keep_pairs, paired_contact, turned_copy


def sector_count(sector: Mesh) -> int:
    """Ns, the one sector count of a sector mesh's cyclic bodies (ValueError otherwise)."""
    counts = {c.sectors for c in sector.cyclic.values()}
    if len(counts) != 1:
        raise ValueError(f"the cyclic bodies need exactly one sector count, got {sorted(counts)}")
    return counts.pop()


def disk_node_map(sector: Mesh) -> np.ndarray:
    """(Ns, n) int64: full-disk index of sector node i in copy k (-1: a node no element uses).

    Copy k is the sector rotated by k phi about +z; its left cyclic face is copy k-1's right
    face, so those nodes share one index. The numbering is the one :func:`full_disk` uses.
    """
    ns = sector_count(sector)
    if not all(c.matching for c in sector.cyclic.values()):
        raise ValueError("full_disk: needs cyclic faces that match node for node")
    n = len(sector.points)
    node_map = np.full((ns, n), -1, dtype=np.int64)
    shared_left = np.zeros(n, dtype=bool)
    for cyc in sector.cyclic.values():
        shared_left[cyc.left] = True
    used = np.zeros(n, dtype=bool)
    for c in sector.cells.values():
        used[c.ravel()] = True
    used[sector.averaged_points] = True  # (a contact point averaging nodes: copied too)
    own = np.flatnonzero(used & ~shared_left)
    node_map[:, own] = np.arange(ns * len(own)).reshape(ns, len(own))
    for cyc in sector.cyclic.values():
        for k in range(ns):  # copy k's left face is copy k-1's right face
            node_map[k, cyc.left] = node_map[(k - 1) % ns, cyc.right]
    return node_map


def full_disk(sector: Mesh) -> Mesh:
    """Assemble Ns rotated copies of a sector mesh into a full-disk mesh.

    Copy k is the sector rotated by k phi about +z (k = 0..Ns-1). Each cyclic body becomes
    one body of the same name, its copies joined node for node at the cyclic faces (copy
    k's right face is copy k+1's left face). Every other body (blade, damper) becomes Ns
    bodies "<body>#k" with their own nodes. Node sets become "<set>#k" (one per copy; the
    cyclic face sets are dropped: they are interior now). Contacts become "<name>#k"; one
    whose body_b is in the neighbouring sector (b_sector_offset = s) pairs copy k of body_a
    with copy k+s of body_b, so every full-disk contact is in place (b_sector_offset = 0).
    A contact between named surfaces (an imported model's) keeps the sector's pairs on
    every copy, turned (``geometry.pairing.turned_copy``).

    Shapes: points (Ns * n_unique, 3), each element shape Ns times the sector's. Needs one
    common Ns.
    """
    ns = sector_count(sector)
    phi = 2 * np.pi / ns
    node_map = disk_node_map(sector)
    own = node_map[0] >= 0  # the nodes each copy places (its left face is the previous copy's)
    for cyc in sector.cyclic.values():
        own[cyc.left] = False
    points = np.zeros((int(node_map.max()) + 1, 3))
    for k in range(ns):
        points[node_map[k, own]] = sector.points[own] @ rotation_z(k * phi).T

    cells, bodies = _copied_bodies(sector, node_map)
    node_sets = {
        f"{name}#{k}": np.unique(node_map[k, idx])
        for name, idx in sector.node_sets.items()
        if not name.startswith("cyclic/")
        for k in range(ns)
    }
    contacts, pairs = _copied_contacts(sector, node_map, phi)
    curved_edges, edge_nodes = _copied_curved_edges(sector, node_map, phi)
    averages = np.vstack([node_map[k][sector.averages] for k in range(ns)])
    disk = Mesh(
        averages=averages.reshape(-1, 2),
        average_weights=np.tile(sector.average_weights, ns),
        model=f"{sector.model}_full",
        points=points,
        curved_edges=curved_edges,
        edge_nodes=edge_nodes,
        tetrahedra=_stacked(cells["tetra"], "tetra"),
        bodies=bodies,
        node_sets=node_sets,
        contacts=contacts,
        parameters={**sector.parameters, "full_disk": True},
        hexahedra=_stacked(cells["hexahedron"], "hexahedron"),
        wedges=_stacked(cells["wedge"], "wedge"),
    )
    for name, p in pairs.items():
        keep_pairs(disk, name, p)
    return disk


def _copied_bodies(sector: Mesh, node_map: np.ndarray
                   ) -> tuple[dict[str, list[np.ndarray]], dict[str, np.ndarray]]:
    """Every body's elements in every copy: shape -> the copies' (m, corners) node arrays,
    and body -> its full-disk element indices (a cyclic body's copies as one body, another
    body's as "<body>#k")."""
    ns = len(node_map)
    cells = {shape: [] for shape in elements.SHAPES}  # shape -> copies' corner arrays
    count = dict.fromkeys(elements.SHAPES, 0)
    owned: dict[tuple[str, int], list[tuple[str, np.ndarray]]] = {}  # (body, k) -> elements
    for name, idx in sector.bodies.items():
        for k in range(ns):
            for shape, c in sector.element_cells(idx).items():
                cells[shape].append(node_map[k][c])
                owned.setdefault((name, k), []).append(
                    (shape, np.arange(count[shape], count[shape] + len(c))))
                count[shape] += len(c)
    # element indices run over the shapes in order: a shape's start is the earlier ones' count
    start = dict(zip(elements.SHAPES, np.cumsum([0, *count.values()])[:-1], strict=True))
    bodies = {}
    for name in sector.bodies:
        copies = [np.concatenate([start[shape] + i for shape, i in owned[name, k]])
                  for k in range(ns)]
        if name in sector.cyclic:
            bodies[name] = np.concatenate(copies)
        else:
            bodies.update({f"{name}#{k}": c for k, c in enumerate(copies)})
    return cells, bodies


def _copied_contacts(sector: Mesh, node_map: np.ndarray, phi: float
                     ) -> tuple[dict[str, ContactPatch | SurfaceContact | AveragedContact],
                                dict[str, PairedContact]]:
    """Every contact in every copy, "<name>#k": copy k of body_a against copy
    k + b_sector_offset of body_b (so each is in place, no offset), and the pairs of the
    copies of contacts between named surfaces: the sector's pairs turned, in their order
    (the sector's per-pair stiffness follows it; pairing the copy afresh could order its
    pairs otherwise, and its default frames do not turn with a near-axial normal)."""
    ns = len(node_map)

    def body_copy(body: str | None, k: int) -> str | None:
        return body if body is None or body in sector.cyclic else f"{body}#{k % ns}"

    contacts: dict[str, ContactPatch | SurfaceContact | AveragedContact] = {}
    pairs = {}
    for name, p in sector.contacts.items():
        sector_pairs = None if isinstance(p, ContactPatch) else paired_contact(sector, name)
        for k in range(ns):
            kb = (k + p.b_sector_offset) % ns
            copy, a, b = f"{name}#{k}", body_copy(p.body_a, k), body_copy(p.body_b, kb)
            if isinstance(p, ContactPatch):
                contacts[copy] = ContactPatch(
                    copy, a, b, node_map[k][p.nodes_a], node_map[kb][p.nodes_b],
                    rotation_z(k * phi) @ p.normal, p.area)
                continue
            place = _Copy(copy, a, b, k, kb, node_map[k], node_map[kb], k * phi)
            contacts[copy] = _named_copy(p, place)
            pairs[copy] = turned_copy(sector_pairs, copy, a, b, place.map_a, place.map_b,
                                      place.angle)
    return contacts, pairs


@dataclass(frozen=True, eq=False)  # (arrays: no field-wise equality)
class _Copy:
    """Where a sector's contact goes in the whole disk: its name and bodies there, side a on
    copy k and side b on copy kb with their node maps (sector node -> disk node), turned by
    ``angle`` [rad] about +z."""

    name: str
    body_a: str
    body_b: str | None
    k: int
    kb: int
    map_a: np.ndarray
    map_b: np.ndarray
    angle: float


def _named_copy(c: SurfaceContact | AveragedContact, place: _Copy
                ) -> SurfaceContact | AveragedContact:
    """The definition of a contact between named surfaces in ``place``: its node sets'
    copies "<set>#k", or an averaged contact's points and facets through the copies' node
    maps, turned."""
    k, a, b, map_a = place.k, place.body_a, place.body_b, place.map_a
    set_b = f"{c.set_b}#{place.kb}" if c.set_b else c.set_b  # (None or "": the ground)
    if isinstance(c, SurfaceContact):
        return SurfaceContact(place.name, a, f"{c.set_a}#{k}", b, set_b, 0, c.tolerance,
                              c.spread)
    faces = np.where(c.faces < 0, -1, map_a[np.maximum(c.faces, 0)])
    nodes = np.unique(c.faces[c.faces >= 0])
    return AveragedContact(
        place.name, a, b, map_a[c.nodes_a], place.map_b[c.nodes_b],
        c.normals @ rotation_z(place.angle).T, c.areas, c.gaps, faces,
        c.owner[np.argsort(map_a[nodes])], 0, c.spread, c.spacing, f"{c.set_a}#{k}", set_b,
        c.dropped, c.reach)


def _copied_curved_edges(sector: Mesh, node_map: np.ndarray, phi: float
                         ) -> tuple[np.ndarray, np.ndarray]:
    """The sector's curved edges in every copy: (c Ns, 2) sorted node pairs, (c Ns, 3) their
    mid-edge points turned with the copy (an edge on a cyclic face, shared by two copies,
    once)."""
    pairs = np.vstack([np.sort(node_map[k][sector.curved_edges], axis=1)
                       for k in range(len(node_map))])
    xyz = np.vstack([sector.edge_nodes @ rotation_z(k * phi).T for k in range(len(node_map))])
    pairs, first = np.unique(pairs, axis=0, return_index=True)
    return pairs.reshape(-1, 2), xyz[first].reshape(-1, 3)


def _stacked(parts: list[np.ndarray], shape: str) -> np.ndarray:
    return np.vstack(parts) if parts else elements.empty(shape)
