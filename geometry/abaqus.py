"""A small reader of CalculiX / Abaqus input decks (.inp): nodes, solid elements, sets.

meshio reads .inp too, but it keeps only the last of several ``*ELSET`` cards (or
``ELSET=`` parameters) of one name, so the body of a deck that mixes element types (C3D20
and C3D15 under one ELSET, as Abaqus/CAE and CalculiX write them) comes out wrong. This
reader keeps the keywords a model needs and follows Abaqus' rules for them:

* ``*NODE`` (``NSET=``), ``*ELEMENT`` (``TYPE=``, ``ELSET=``; a solid's data runs over as
  many lines as its node count needs, another element's while a line ends with a comma),
  ``*NSET`` / ``*ELSET`` (``GENERATE``; members may be other sets; a repeated name adds to
  the set), ``*INCLUDE`` (``INPUT=``, relative to the deck); names are case-insensitive, as
  in Abaqus, and keep their first spelling;
* solid types C3D4, C3D10, C3D8, C3D20, C3D27, C3D6, C3D15 with any suffix (H, R, I, M,
  T...); another solid (C3D5 pyramids...) is reported by name. Elements of lower dimension (the
  surface elements Gmsh writes for physical surfaces, shells, beams) are not part of the
  model: their nodes join their ELSET's node set, and their count is reported
  (``info["skipped"]``).

* ``*MATERIAL`` (``NAME=``) with ``*ELASTIC`` (``TYPE=ISO``, CalculiX's default, or
  ``ISOTROPIC``: E, nu; another type is named as the material's fault) and ``*DENSITY``, and
  ``*SOLID SECTION`` (``ELSET=``, ``MATERIAL=``): each element's material, for ``material =
  "file"`` (``info["materials"]``: name -> (E, nu, rho); ``info["element_materials"]``: per
  cell block, each element's material name or "").

* ``*BOUNDARY`` (data lines ``node or node set, first DOF[, last DOF[, 0]]``, or ``set,
  ENCASTRE / PINNED / XSYMM ...``) as supports: the translations held (``info["boundary"]``:
  (node or set, held DOFs 1-3, line)); a non-zero magnitude is a prescribed motion, a load,
  and refused; rotational DOFs (4-6) mean nothing on solid nodes and are dropped;
  ``*TRANSFORM`` (``NSET=``, ``TYPE=R`` or ``C``: two points) as the
  local frame of its set's supports (``info["transforms"]``: set -> (type, a, b)).

* ``*SURFACE`` (``NAME=``; ``TYPE=ELEMENT``, the default: data lines ``element or element
  set, S1..S6`` in Abaqus' face numbering; ``TYPE=NODE``: nodes or node sets) as a node set of
  that name (of the faces' nodes): what contacts, loads and outputs name.

Everything else (steps, loads) is skipped. It returns a meshio.Mesh,
so the importer treats every format alike. Tested on decks meshio and Gmsh write.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .elements import SOLID_TYPES

if TYPE_CHECKING:
    import meshio

# Abaqus type (without suffix letters) -> meshio cell type
_SOLIDS = {"C3D4": "tetra", "C3D10": "tetra10", "C3D8": "hexahedron",
           "C3D20": "hexahedron20", "C3D27": "hexahedron27", "C3D6": "wedge", "C3D15": "wedge15"}
_WIDTH = {"tetra": 4, "tetra10": 10, "hexahedron": 8, "hexahedron20": 20, "hexahedron27": 27,
          "wedge": 6, "wedge15": 15}  # nodes per element
_TYPE = re.compile(r"^(C3D(?:4|10|8|20|27|6|15))[A-Z]*$")
_Block = tuple[str, list[int], list[list[int]]]  # an *ELEMENT card: (type, ids, their nodes)


class DeckError(ValueError):
    """The deck cannot be read; one line naming the file, the line and why."""


def _lines(path: Path, seen: tuple[Path, ...] = ()):
    """(path, line number, text) of every non-comment line, ``*INCLUDE`` files inlined."""
    if path in seen:
        raise DeckError(f"{path}: *INCLUDE loop")
    try:
        text = path.read_text(errors="strict")
    except (OSError, UnicodeDecodeError) as exc:
        raise DeckError(f"{path}: cannot read ({exc})") from None
    for number, line in enumerate(text.splitlines(), 1):
        stripped = line.strip()
        if not stripped or stripped.startswith("**"):
            continue
        if stripped.upper().startswith("*INCLUDE"):
            target = _params(stripped).get("INPUT")
            if not target:
                raise DeckError(f"{path}:{number}: *INCLUDE without INPUT=")
            yield from _lines((path.parent / target.strip('"')).resolve(), (*seen, path))
            continue
        yield path, number, stripped


def _params(line: str) -> dict[str, str]:
    """KEY=VALUE parameters of a keyword line (keys upper case; flags map to "")."""
    out = {}
    for part in line.split(",")[1:]:
        key, _, value = part.partition("=")
        if key.strip():
            out[key.strip().upper()] = value.strip()
    return out


def read(path: str | Path) -> meshio.Mesh:
    """The deck as a meshio.Mesh: points in file order, one cell block per *ELEMENT card,
    point_sets and cell_sets (per block) by name; DeckError on what it cannot read."""
    path = Path(path)
    deck = _Deck()
    for where, number, line in _lines(path):
        if line.startswith("*"):
            deck.keyword_line(line, f"{where}:{number}")
        else:
            deck.data_line(line, f"{where}:{number}")
    return _mesh(deck, path)


@dataclass
class _Deck:
    """What the reader collects from a deck, line by line, and the card it is in."""

    ids: list[int] = field(default_factory=list)  # node ids, in file order
    xyz: list[list[float]] = field(default_factory=list)  # their coordinates
    blocks: list[_Block] = field(default_factory=list)
    nsets: dict[str, list[int | str]] = field(default_factory=dict)  # members: ids or sets
    elsets: dict[str, list[int | str]] = field(default_factory=dict)
    materials: dict[str, list[float]] = field(default_factory=dict)  # [E, nu, rho]; nan: none
    sections: list[tuple[str, str]] = field(default_factory=list)  # (ELSET, MATERIAL)
    # (node or node set, DOFs held, where)
    boundary: list[tuple[int | str, tuple[int, ...], str]] = field(default_factory=list)
    # node set -> (TYPE, point a, point b)
    transforms: dict[str, tuple[str, list[float], list[float]]] = field(default_factory=dict)
    elastic_types: dict[str, str] = field(default_factory=dict)  # if not isotropic
    # name -> (element or set, face); face "" for a node or node set (TYPE=NODE)
    surfaces: dict[str, list[tuple[int | str, str]]] = field(default_factory=dict)
    # names are case-insensitive in a deck: each keeps its first spelling
    spelled: dict[tuple[str, str], str] = field(default_factory=dict)
    keyword: str = ""  # the current card's keyword, upper case
    params: dict[str, str] = field(default_factory=dict)  # and its parameters
    pending: list[int] = field(default_factory=list)  # an element's id and nodes so far
    current: str = ""  # the *MATERIAL that *ELASTIC and *DENSITY cards describe

    def name_of(self, kind: str, name: str) -> str:
        """The first spelling of a name of this kind ("n", "e", "m" or "s")."""
        return self.spelled.setdefault((kind, name.upper()), name)

    def keyword_line(self, line: str, at: str) -> None:
        """Start a card: its keyword and parameters (names in their first spelling)."""
        if self.pending:
            raise DeckError(f"{at}: element {self.pending[0]} has "
                            f"{len(self.pending) - 1} nodes before the next keyword")
        self.keyword, self.params = line.split(",")[0].strip().upper(), _params(line)
        for key, kind in (("NSET", "n"), ("ELSET", "e"), ("NAME", "m"), ("MATERIAL", "m")):
            if self.params.get(key) and not (key == "NAME" and self.keyword != "*MATERIAL"):
                self.params[key] = self.name_of(kind, self.params[key])
        match self.keyword:
            case "*ELEMENT":
                self._element_card(at)
            case "*NSET" | "*ELSET":
                self._set_card(at)
            case "*MATERIAL":
                self.current = self.params.get("NAME", "")
                self.materials.setdefault(self.current, [np.nan, np.nan, np.nan])
            case "*SOLID SECTION":
                self.sections.append((self.params.get("ELSET", ""),
                                      self.params.get("MATERIAL", "")))
            case "*BOUNDARY":
                self._boundary_card(at)
            case "*SURFACE":
                self._surface_card(at)
            case "*TRANSFORM":
                self._transform_card(at)
        self.pending = []

    def _element_card(self, at: str) -> None:
        """A new cell block: a solid's meshio type, another element's Abaqus type."""
        kind = self.params.get("TYPE", "").upper()
        solid = _TYPE.match(kind)
        if solid is None and (kind.startswith("C3D") or not kind):
            raise DeckError(f"{at}: element type {kind or '?'} not "
                            f"supported; solids read: {sorted(_SOLIDS)}")
        self.blocks.append((_SOLIDS[solid.group(1)] if solid else kind, [], []))

    def _set_card(self, at: str) -> None:
        """*NSET / *ELSET: the set named (a repeated name adds to it)."""
        name = self.params.get(self.keyword[1:])
        if not name:
            raise DeckError(f"{at}: {self.keyword} without {self.keyword[1:]}=")
        (self.nsets if self.keyword == "*NSET" else self.elsets).setdefault(name, [])

    def _boundary_card(self, at: str) -> None:
        if self.params.get("TYPE", "DISPLACEMENT").upper() != "DISPLACEMENT":
            raise DeckError(f"{at}: *BOUNDARY, TYPE={self.params['TYPE']}: only "
                            "supports (zero displacements) are read")

    def _surface_card(self, at: str) -> None:
        """*SURFACE: the surface named, by element faces or by nodes."""
        if not self.params.get("NAME"):
            raise DeckError(f"{at}: *SURFACE without NAME=")
        kind = self.params.get("TYPE", "ELEMENT").upper()
        if kind not in ("ELEMENT", "NODE"):
            raise DeckError(f"{at}: *SURFACE, TYPE={kind}: only TYPE="
                            "ELEMENT (element faces) and TYPE=NODE are read")
        self.params["NAME"] = self.name_of("s", self.params["NAME"])
        self.surfaces.setdefault(self.params["NAME"], [])

    def _transform_card(self, at: str) -> None:
        if self.params.get("TYPE", "R").upper() not in ("R", "C"):
            raise DeckError(f"{at}: *TRANSFORM, TYPE={self.params['TYPE']}: only "
                            "TYPE=R (rectangular) and TYPE=C (cylindrical) are read")

    def data_line(self, line: str, at: str) -> None:
        """One data line of the current card (of a keyword not read: skipped)."""
        try:
            values = [v.strip() for v in line.split(",") if v.strip()]
            match self.keyword:
                case "*NODE":
                    self._node(values)
                case "*ELEMENT":
                    self._element(values, line)
                case "*ELASTIC":
                    self._elastic(values)
                case "*DENSITY":
                    self._density(values)
                case "*BOUNDARY":
                    self._boundary(values, at)
                case "*SURFACE":
                    self._surface(values, at)
                case "*TRANSFORM":
                    self._transform(values, at)
                case "*NSET" | "*ELSET":
                    self._set_members(values)
        except DeckError:
            raise
        except (ValueError, IndexError):
            raise DeckError(f"{at}: cannot read {self.keyword} data line "
                            f"{line[:60]!r}") from None

    def _node(self, values: list[str]) -> None:
        """id, x[, y[, z]] (missing coordinates are 0)."""
        self.ids.append(int(values[0]))
        self.xyz.append([float(v) for v in values[1:4]] + [0.0] * (4 - len(values)))
        if "NSET" in self.params:
            self.nsets.setdefault(self.params["NSET"], []).append(int(values[0]))

    def _element(self, values: list[str], line: str) -> None:
        """id, nodes...: a solid's list runs over lines until its node count, another
        element's while a line ends with a comma."""
        self.pending += [int(v) for v in values]
        kind, eids, nodes = self.blocks[-1]
        width = _WIDTH.get(kind)
        if (len(self.pending) < 1 + width) if width else line.rstrip().endswith(","):
            return  # the element continues on the next line
        eids.append(self.pending[0])
        nodes.append(self.pending[1:])
        if "ELSET" in self.params:
            self.elsets.setdefault(self.params["ELSET"], []).append(self.pending[0])
        self.pending = []

    def _elastic(self, values: list[str]) -> None:
        """E, nu of the current material (its first card counts); another type noted."""
        if not self.current:
            return  # (not within a *MATERIAL)
        kind = self.params.get("TYPE", "ISO").upper()
        if kind not in ("ISO", "ISOTROPIC"):
            self.elastic_types[self.current] = kind
        elif np.isnan(self.materials[self.current][0]):
            self.materials[self.current][:2] = [float(values[0]), float(values[1])]

    def _density(self, values: list[str]) -> None:
        if self.current and np.isnan(self.materials[self.current][2]):
            self.materials[self.current][2] = float(values[0])

    def _boundary(self, values: list[str], at: str) -> None:
        """node or node set, DOFs: the translations it holds (rotations mean nothing on a
        solid's nodes)."""
        dofs = _held(values, at)
        target = int(values[0]) if _is_int(values[0]) else self.name_of("n", values[0])
        self.boundary.append((target, tuple(d for d in dofs if d <= 3), at))

    def _surface(self, values: list[str], at: str) -> None:
        """element or element set, face S1-S6; or (TYPE=NODE) node or node set[, weight]."""
        by_faces = self.params.get("TYPE", "ELEMENT").upper() == "ELEMENT"
        face = values[1].upper() if by_faces and len(values) > 1 else ""  # (a weight)
        if by_faces and face not in _FACES:
            raise DeckError(f"{at}: *SURFACE face {face or '?'}: solid "
                            "element faces are S1-S6")
        target = int(values[0]) if _is_int(values[0]) else values[0]
        self.surfaces[self.params["NAME"]].append((target, face))

    def _transform(self, values: list[str], at: str) -> None:
        """Two points, a and b (six numbers): the local frame of the card's node set."""
        name = self.params.get("NSET")
        if not name:
            raise DeckError(f"{at}: *TRANSFORM without NSET=")
        numbers = [float(v) for v in values[:6]]
        if len(numbers) != 6:
            raise ValueError("a *TRANSFORM line holds six numbers")  # (cannot read it)
        self.transforms[name] = (self.params.get("TYPE", "R").upper(), numbers[:3], numbers[3:])

    def _set_members(self, values: list[str]) -> None:
        """Ids or other sets' names; with GENERATE: first, last[, step]."""
        target = (self.nsets if self.keyword == "*NSET" else self.elsets)[
            self.params[self.keyword[1:]]]
        if "GENERATE" in self.params:
            a, b, *step = (int(v) for v in values)
            target.extend(range(a, b + 1, step[0] if step else 1))
        else:
            target.extend(int(v) if _is_int(v) else self.name_of(self.keyword[1].lower(), v)
                          for v in values)


def _mesh(deck: _Deck, path: Path) -> meshio.Mesh:
    """The collected deck as a meshio.Mesh (solid blocks only; the rest in ``info``)."""
    import meshio

    if deck.pending:
        raise DeckError(f"{path}: the last element's node list is incomplete (truncated?)")
    if not deck.ids:
        raise DeckError(f"{path}: no *NODE")
    index = {nid: i for i, nid in enumerate(deck.ids)}
    if len(index) != len(deck.ids):
        raise DeckError(f"{path}: a node id is defined twice")
    skipped = _skip_lower_dimension(deck)
    blocks = [b for b in deck.blocks if b[0] in _WIDTH]
    cells, where_is = _solid_cells(blocks, index, path)
    point_sets = _point_sets(deck.nsets, index, path)
    cell_sets = _cell_sets(deck.elsets, len(blocks), where_is, path)
    element_materials = _element_materials(deck, blocks, where_is, path)
    _add_surfaces(point_sets, deck, blocks, where_is, index, path)
    held = _supports(deck, index, path)
    return meshio.Mesh(np.array(deck.xyz, dtype=np.float64), cells, point_sets=point_sets,
                       cell_sets=cell_sets, info={
                           "skipped": skipped, "element_materials": element_materials,
                           "materials": _materials(deck), "boundary": held,
                           "transforms": {n: (t, a, b, point_sets.get(n, np.empty(0, int)))
                                          for n, (t, a, b) in deck.transforms.items()}})


def _skip_lower_dimension(deck: _Deck) -> dict[str, int]:
    """Element count per type of the blocks that are not solids; their nodes join (or make)
    the node set named as their element set."""
    skipped: dict[str, int] = {}
    for kind, eids, nodes in deck.blocks:
        if kind not in _WIDTH:
            skipped[kind] = skipped.get(kind, 0) + len(eids)
            members = dict(zip(eids, nodes, strict=True))
            for name, ids in deck.elsets.items():
                extra = [n for e in ids if e in members for n in members[e]]
                if extra:
                    deck.nsets.setdefault(name, []).extend(extra)
    return skipped


def _solid_cells(blocks: list[_Block], index: dict[int, int], path: Path
                 ) -> tuple[list[tuple[str, np.ndarray]], dict[int, tuple[int, int]]]:
    """The solid blocks as meshio cells (type, (m, nodes per element) point indices), and
    where each element is: element id -> (block, row)."""
    cells, where_is = [], {}
    for k, (kind, eids, nodes) in enumerate(blocks):
        want = _WIDTH[kind]
        if any(len(n) != want for n in nodes):
            raise DeckError(f"{path}: a {kind} element has not {want} nodes (truncated?)")
        try:
            cells.append((kind, np.array([[index[n] for n in row] for row in nodes],
                                         dtype=np.int64).reshape(-1, want)))
        except KeyError as exc:
            raise DeckError(f"{path}: an element uses node {exc.args[0]}, which no *NODE "
                            "defines") from None
        where_is.update({e: (k, i) for i, e in enumerate(eids)})
    return cells, where_is


def _point_sets(nsets: dict[str, list[int | str]], index: dict[int, int], path: Path
                ) -> dict[str, np.ndarray]:
    """Each node set's (k,) sorted point indices (nodes no *NODE defines left out)."""
    return {name: np.unique([index[n] for n in _members(name, nsets, path) if n in index])
            for name in nsets}


def _cell_sets(elsets: dict[str, list[int | str]], n_blocks: int,
               where_is: dict[int, tuple[int, int]], path: Path) -> dict[str, list[np.ndarray]]:
    """Each element set as meshio wants it: per solid block, the sorted rows (int64)."""
    cell_sets = {}
    for name in elsets:
        per_block: list[list[int]] = [[] for _ in range(n_blocks)]
        for e in _members(name, elsets, path):
            if e in where_is:
                k, i = where_is[e]
                per_block[k].append(i)
        cell_sets[name] = [np.unique(np.array(p, dtype=np.int64)) for p in per_block]
    return cell_sets


def _element_materials(deck: _Deck, blocks: list[_Block], where_is: dict[int, tuple[int, int]],
                       path: Path) -> list[np.ndarray]:
    """Per solid block, (m,) object: each element's material by *SOLID SECTION ("": none)."""
    element_materials = [np.full(len(b[1]), "", dtype=object) for b in blocks]
    for elset, name in deck.sections:
        if elset in deck.elsets:
            for e in _members(elset, deck.elsets, path):
                if e in where_is:
                    k, i = where_is[e]
                    element_materials[k][i] = name
    return element_materials


def _add_surfaces(point_sets: dict[str, np.ndarray], deck: _Deck, blocks: list[_Block],
                  where_is: dict[int, tuple[int, int]], index: dict[int, int],
                  path: Path) -> None:
    """Each *SURFACE as a point set of its nodes ("surface/<name>" if a node set has its
    name)."""
    for name, faces in deck.surfaces.items():
        nodes = _surface_nodes(faces, blocks, where_is, deck.elsets, deck.nsets, deck.spelled,
                               path)
        key = name if name not in point_sets else f"surface/{name}"
        point_sets[key] = np.unique([index[n] for n in nodes if n in index]).astype(np.int64)


def _supports(deck: _Deck, index: dict[int, int], path: Path
              ) -> list[tuple[list[int], tuple[int, ...], str]]:
    """Each *BOUNDARY line holding a translation: (sorted point indices, DOFs, where)."""
    return [(sorted(index[n] for n in ([t] if isinstance(t, int) else
                                       _members(t, deck.nsets, path)) if n in index), dofs, at)
            for t, dofs, at in deck.boundary if dofs]


def _materials(deck: _Deck) -> dict[str, tuple[float, ...] | str]:
    """name -> (E, nu, rho) (nan: not given), or why the material cannot be modelled."""
    return {n: (f"*ELASTIC, TYPE={deck.elastic_types[n]}: only isotropic elasticity is "
                "modelled" if n in deck.elastic_types else tuple(v))
            for n, v in deck.materials.items()}


#: Abaqus' named boundary types -> the DOFs they hold (1-3 translations, 4-6 rotations)
_NAMED = {"ENCASTRE": (1, 2, 3, 4, 5, 6), "PINNED": (1, 2, 3), "XSYMM": (1, 5, 6),
          "YSYMM": (2, 4, 6), "ZSYMM": (3, 4, 5), "XASYMM": (2, 3, 4), "YASYMM": (1, 3, 5),
          "ZASYMM": (1, 2, 6)}


def _held(values: list[str], where: str) -> tuple[int, ...]:
    """The DOFs a *BOUNDARY data line holds; DeckError for a non-zero magnitude or a DOF
    beyond the structural ones."""
    if len(values) == 2 and values[1].upper() in _NAMED:
        return _NAMED[values[1].upper()]
    first = int(values[1])
    last = int(values[2]) if len(values) > 2 and values[2] else first
    if len(values) > 3 and float(values[3]) != 0.0:
        raise DeckError(f"{where}: *BOUNDARY prescribes {values[3]} on DOF {first}-{last}: "
                        "a non-zero displacement is a load, not a support; only supports "
                        "(zero) are read")
    if not 1 <= first <= last <= 6:
        raise DeckError(f"{where}: *BOUNDARY DOFs {first}-{last}: solids have DOFs 1-3 "
                        "(translations); only those are supports")
    return tuple(range(first, last + 1))


#: Abaqus' face numbering of the solids (1-based corners of each face S1, S2, ...)
_FACE_CORNERS = {
    "tetra": [(1, 2, 3), (1, 4, 2), (2, 4, 3), (3, 4, 1)],
    "hexahedron": [(1, 2, 3, 4), (5, 8, 7, 6), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 8, 4),
                   (4, 8, 5, 1)],
    "wedge": [(1, 2, 3), (4, 6, 5), (1, 4, 5, 2), (2, 5, 6, 3), (3, 6, 4, 1)],
}
_FACES = {f"S{i}" for i in range(1, 7)}


def _surface_nodes(faces, blocks, where_is, elsets, nsets, spelled, path) -> list[int]:
    """The node ids of a *SURFACE's faces (its corners; a quadratic face's mid nodes are
    dropped with the other mid nodes) or nodes."""
    out: list[int] = []
    for target, face in faces:
        if not face:  # TYPE=NODE: a node or a node set
            if isinstance(target, int):
                out.append(target)
                continue
            name = spelled.get(("n", target.upper()), target)
            if name not in nsets:
                raise DeckError(f"{path}: *SURFACE names {target!r}, which is no node set")
            out += _members(name, nsets, path)
            continue
        if isinstance(target, int):
            members = [target]
        else:
            name = spelled.get(("e", target.upper()), target)
            if name not in elsets:
                raise DeckError(f"{path}: *SURFACE names {target!r}, which is no element set")
            members = _members(name, elsets, path)
        for e in members:
            if e not in where_is:
                continue  # (not a solid)
            k, i = where_is[e]
            kind = SOLID_TYPES[blocks[k][0]]
            corners = _FACE_CORNERS[kind]
            if int(face[1:]) > len(corners):
                raise DeckError(f"{path}: *SURFACE face {face} of element {e}: a {kind} "
                                f"has faces S1-S{len(corners)}")
            out += [blocks[k][2][i][c - 1] for c in corners[int(face[1:]) - 1]]
    return out


def _is_int(v: str) -> bool:
    return v.lstrip("-").isdigit()


def _members(name: str, sets: dict[str, list], path: Path, depth: int = 0) -> list[int]:
    """The ids of a set, the sets it names expanded."""
    if depth > 32:
        raise DeckError(f"{path}: set {name!r} names itself (through other sets)")
    out = []
    for m in sets[name]:
        if isinstance(m, int):
            out.append(m)
        elif m in sets:
            out += _members(m, sets, path, depth + 1)
        else:
            raise DeckError(f"{path}: set {name!r} names {m!r}, which is no set of its kind")
    return out
