"""The bodies of an imported mesh from its element groups: the groups the case names, or
the file's groups that partition its solid elements into bodies sharing no node."""

from __future__ import annotations

import re

import numpy as np

from .mesh_files import MeshImportError

_NAME = re.compile(r"^[A-Za-z0-9_.\-]+(/[A-Za-z0-9_.\-]+)*$")


def bodies_of(groups, solids, raw, names, path) -> dict[str, dict[int, np.ndarray]]:
    """Body name -> solid block position (in ``solids``) -> element indices in that block."""
    position = {i: k for k, (i, _) in enumerate(solids)}
    total = sum(len(b.data) for _, b in solids)
    solid_groups = {name: {position[i]: idx for i, idx in g.items() if i in position}
                    for name, g in groups.items()}
    solid_groups = {n: g for n, g in solid_groups.items() if g}
    sizes = {n: sum(len(v) for v in g.values()) for n, g in solid_groups.items()}
    listing = ", ".join(f"{n} ({sizes[n]})" for n in sorted(solid_groups)) or "none"
    if names is not None:
        missing = [g for g in names.values() if g not in solid_groups]
        if missing:
            raise MeshImportError(f"geometry.bodies: {missing} are not element groups of "
                                  f"{path}; its element groups: {listing}")
        chosen = {n: solid_groups[g] for n, g in names.items()}
    elif not solid_groups:
        chosen = {"body": {k: np.arange(len(b.data)) for k, (_, b) in enumerate(solids)}}
    else:
        # a group repeated under another name (Gmsh's "Volume1" beside its physical name)
        # counts once, by its last name: the explicit sets come after the element cards
        distinct = {_key(g): n for n, g in solid_groups.items()}
        unique = {n: solid_groups[n] for n in distinct.values()}
        # the finest partition of bodies in contact, else the coarsest (a deck's extra
        # element sets, for loads or surfaces, beside its parts)
        covering = [c for c in (_finest_partition(unique, sizes),
                                _largest_first(unique, sizes))
                    if sum(sizes[n] for n in c) == total]
        chosen = next((c for c in covering if not _share_nodes(c, solids)), None) or \
            (covering[-1] if covering else {})
        if not covering:
            raise MeshImportError(f"{path}: {_why_unclear(unique, total)}, so the bodies are "
                                  f"not clear; name them in geometry.bodies, e.g. bodies = "
                                  f"{{ blade = \"<group>\" }} (element groups: {listing})")
    covered = sum(sum(len(v) for v in g.values()) for g in chosen.values())
    if covered != total or any(not _disjoint(g, h) for n, g in chosen.items()
                               for m, h in chosen.items() if n < m):
        raise MeshImportError(f"geometry.bodies = {sorted(chosen)}: must hold every solid "
                              f"element of {path} once ({total} elements)")
    for name in chosen:
        if not _NAME.match(name):
            raise MeshImportError(f"{path}: body name {name!r} must be letters, digits, "
                                  "'_', '.', '-'")
    nodes = {n: np.unique(np.concatenate([np.asarray(solids[k][1].data)[idx].ravel()
                                          for k, idx in g.items()])) for n, g in chosen.items()}
    for n in chosen:
        for m in chosen:
            shared = np.intersect1d(nodes[n], nodes[m]).size if n < m else 0
            if shared:
                raise MeshImportError(
                    f"{path}: bodies {n!r} and {m!r} share {shared} nodes; bodies in contact "
                    "carry distinct, coincident nodes (or make them one body: name a group "
                    "holding both in geometry.bodies)")
    return chosen


def _finest_partition(groups: dict[str, dict[int, np.ndarray]], sizes: dict[str, int]
                      ) -> dict[str, dict[int, np.ndarray]]:
    """The groups left when the largest of those that overlap another is dropped, until none
    overlaps: a group of every element (Abaqus' EALL) beside the parts gives way to them."""
    left = dict(groups)
    while True:
        overlapping = [n for n in left if any(not _disjoint(left[n], left[m])
                                              for m in left if m != n)]
        if not overlapping:
            return left
        del left[max(overlapping, key=lambda n: (sizes[n], n))]


def _largest_first(groups: dict[str, dict[int, np.ndarray]], sizes: dict[str, int]
                   ) -> dict[str, dict[int, np.ndarray]]:
    """The groups taken largest first, each disjoint from those taken."""
    taken: dict[str, dict[int, np.ndarray]] = {}
    for n in sorted(groups, key=lambda n: (-sizes[n], n)):
        if all(_disjoint(groups[n], g) for g in taken.values()):
            taken[n] = groups[n]
    return taken


def _share_nodes(groups: dict[str, dict[int, np.ndarray]], solids) -> bool:
    """Whether two of the groups share a node."""
    seen: set[int] = set()
    for g in groups.values():
        nodes = set(np.concatenate([np.asarray(solids[k][1].data)[idx].ravel()
                                    for k, idx in g.items()]).tolist())
        if nodes & seen:
            return True
        seen |= nodes
    return False


def _why_unclear(groups: dict[str, dict[int, np.ndarray]], total: int) -> str:
    """Why the element groups are not the bodies: the first pair that overlaps (how many
    elements in both), or how many elements no group holds."""
    names = sorted(groups)
    for i, n in enumerate(names):
        for m in names[i + 1:]:
            both = sum(np.intersect1d(groups[n][k], groups[m][k]).size
                       for k in groups[n].keys() & groups[m].keys())
            if both:
                return (f"element groups {n!r} and {m!r} overlap ({both} elements in both: a "
                        "group of all elements, or a material beside a part?)")
    held = sum(sum(len(v) for v in g.values()) for g in groups.values())
    return f"{total - held} of its {total} solid elements are in no element group"


def _key(g: dict[int, np.ndarray]) -> tuple:
    """A hashable identity of a group of elements."""
    return tuple((k, np.sort(g[k]).tobytes()) for k in sorted(g))


def _disjoint(g: dict[int, np.ndarray], h: dict[int, np.ndarray]) -> bool:
    return all(np.intersect1d(g[k], h[k]).size == 0 for k in g.keys() & h.keys())
