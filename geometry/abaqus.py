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
from pathlib import Path

import numpy as np

from .elements import SOLID_TYPES

# Abaqus type (without suffix letters) -> meshio cell type
_SOLIDS = {"C3D4": "tetra", "C3D10": "tetra10", "C3D8": "hexahedron",
           "C3D20": "hexahedron20", "C3D27": "hexahedron27", "C3D6": "wedge", "C3D15": "wedge15"}
_WIDTH = {"tetra": 4, "tetra10": 10, "hexahedron": 8, "hexahedron20": 20, "hexahedron27": 27,
          "wedge": 6, "wedge15": 15}  # nodes per element
_TYPE = re.compile(r"^(C3D(?:4|10|8|20|27|6|15))[A-Z]*$")


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


def read(path: str | Path):
    """The deck as a meshio.Mesh: points in file order, one cell block per *ELEMENT card,
    point_sets and cell_sets (per block) by name; DeckError on what it cannot read."""
    import meshio

    path = Path(path)
    ids: list[int] = []
    xyz: list[list[float]] = []
    blocks: list[tuple[str, list[int], list[list[int]]]] = []  # (type, element ids, nodes)
    nsets: dict[str, list] = {}
    elsets: dict[str, list] = {}
    materials: dict[str, list[float]] = {}  # name -> [E, nu, rho] (nan: not given)
    sections: list[tuple[str, str]] = []  # (ELSET, MATERIAL)
    boundary: list[tuple[int | str, tuple[int, ...], str]] = []  # (node or set, DOFs, where)
    transforms: dict[str, tuple[str, list[float], list[float]]] = {}
    elastic_types: dict[str, str] = {}  # material -> its *ELASTIC TYPE, if not isotropic
    surfaces: dict[str, list[tuple[int | str, str]]] = {}  # name -> (element or set, face)
    # names are case-insensitive in a deck: each keeps its first spelling
    spelled: dict[tuple[str, str], str] = {}

    def name_of(kind: str, name: str) -> str:
        return spelled.setdefault((kind, name.upper()), name)

    keyword, params, pending, current = "", {}, [], ""
    for where, number, line in _lines(path):
        if line.startswith("*"):
            if pending:
                raise DeckError(f"{where}:{number}: element {pending[0]} has "
                                f"{len(pending) - 1} nodes before the next keyword")
            keyword, params = line.split(",")[0].strip().upper(), _params(line)
            for key, kind in (("NSET", "n"), ("ELSET", "e"), ("NAME", "m"),
                              ("MATERIAL", "m")):
                if params.get(key) and not (key == "NAME" and keyword != "*MATERIAL"):
                    params[key] = name_of(kind, params[key])
            if keyword == "*ELEMENT":
                kind = params.get("TYPE", "").upper()
                match = _TYPE.match(kind)
                if match is None and (kind.startswith("C3D") or not kind):
                    raise DeckError(f"{where}:{number}: element type {kind or '?'} not "
                                    f"supported; solids read: {sorted(_SOLIDS)}")
                blocks.append((_SOLIDS[match.group(1)] if match else kind, [], []))
            elif keyword in ("*NSET", "*ELSET"):
                name = params.get(keyword[1:])
                if not name:
                    raise DeckError(f"{where}:{number}: {keyword} without {keyword[1:]}=")
                (nsets if keyword == "*NSET" else elsets).setdefault(name, [])
            elif keyword == "*MATERIAL":
                current = params.get("NAME", "")
                materials.setdefault(current, [np.nan, np.nan, np.nan])
            elif keyword == "*SOLID SECTION":
                sections.append((params.get("ELSET", ""), params.get("MATERIAL", "")))
            elif keyword == "*BOUNDARY" and params.get("TYPE", "DISPLACEMENT").upper() != \
                    "DISPLACEMENT":
                raise DeckError(f"{where}:{number}: *BOUNDARY, TYPE={params['TYPE']}: only "
                                "supports (zero displacements) are read")
            elif keyword == "*SURFACE":
                if not params.get("NAME"):
                    raise DeckError(f"{where}:{number}: *SURFACE without NAME=")
                kind = params.get("TYPE", "ELEMENT").upper()
                if kind not in ("ELEMENT", "NODE"):
                    raise DeckError(f"{where}:{number}: *SURFACE, TYPE={kind}: only TYPE="
                                    "ELEMENT (element faces) and TYPE=NODE are read")
                params["NAME"] = name_of("s", params["NAME"])
                surfaces.setdefault(params["NAME"], [])
            elif keyword == "*TRANSFORM" and params.get("TYPE", "R").upper() not in ("R", "C"):
                raise DeckError(f"{where}:{number}: *TRANSFORM, TYPE={params['TYPE']}: only "
                                "TYPE=R (rectangular) and TYPE=C (cylindrical) are read")
            pending = []
            continue
        try:
            values = [v.strip() for v in line.split(",") if v.strip()]
            if keyword == "*NODE":
                ids.append(int(values[0]))
                xyz.append([float(v) for v in values[1:4]] + [0.0] * (4 - len(values)))
                if "NSET" in params:
                    nsets.setdefault(params["NSET"], []).append(int(values[0]))
            elif keyword == "*ELEMENT":
                pending += [int(v) for v in values]
                kind, eids, nodes = blocks[-1]
                width = _WIDTH.get(kind)
                if (len(pending) < 1 + width) if width else line.rstrip().endswith(","):
                    continue  # the element continues on the next line
                eids.append(pending[0])
                nodes.append(pending[1:])
                if "ELSET" in params:
                    elsets.setdefault(params["ELSET"], []).append(pending[0])
                pending = []
            elif keyword == "*ELASTIC" and current and params.get("TYPE", "ISO").upper() \
                    not in ("ISO", "ISOTROPIC"):
                elastic_types[current] = params["TYPE"].upper()
            elif keyword == "*ELASTIC" and current and np.isnan(materials[current][0]):
                materials[current][:2] = [float(values[0]), float(values[1])]
            elif keyword == "*DENSITY" and current and np.isnan(materials[current][2]):
                materials[current][2] = float(values[0])
            elif keyword == "*BOUNDARY":
                dofs = _held(values, f"{where}:{number}")
                target = int(values[0]) if _is_int(values[0]) else name_of("n", values[0])
                boundary.append((target, tuple(d for d in dofs if d <= 3),
                                 f"{where}:{number}"))
            elif keyword == "*SURFACE":
                by_faces = params.get("TYPE", "ELEMENT").upper() == "ELEMENT"
                face = values[1].upper() if by_faces and len(values) > 1 else ""  # (a weight)
                if by_faces and face not in _FACES:
                    raise DeckError(f"{where}:{number}: *SURFACE face {face or '?'}: solid "
                                    "element faces are S1-S6")
                target = int(values[0]) if _is_int(values[0]) else values[0]
                surfaces[params["NAME"]].append((target, face))
            elif keyword == "*TRANSFORM":
                name = params.get("NSET")
                if not name:
                    raise DeckError(f"{where}:{number}: *TRANSFORM without NSET=")
                numbers = [float(v) for v in values[:6]]
                if len(numbers) != 6:
                    raise IndexError
                transforms[name] = (params.get("TYPE", "R").upper(), numbers[:3], numbers[3:])
            elif keyword in ("*NSET", "*ELSET"):
                target = (nsets if keyword == "*NSET" else elsets)[params[keyword[1:]]]
                if "GENERATE" in params:
                    a, b, *step = (int(v) for v in values)
                    target.extend(range(a, b + 1, step[0] if step else 1))
                else:
                    target.extend(int(v) if _is_int(v) else name_of(keyword[1].lower(), v)
                                  for v in values)
        except DeckError:
            raise
        except (ValueError, IndexError):
            raise DeckError(f"{where}:{number}: cannot read {keyword} data line "
                            f"{line[:60]!r}") from None
    if pending:
        raise DeckError(f"{path}: the last element's node list is incomplete (truncated?)")
    if not ids:
        raise DeckError(f"{path}: no *NODE")
    index = {nid: i for i, nid in enumerate(ids)}
    if len(index) != len(ids):
        raise DeckError(f"{path}: a node id is defined twice")
    skipped: dict[str, int] = {}
    for kind, eids, nodes in blocks:  # not solids: their nodes join their element sets
        if kind not in _WIDTH:
            skipped[kind] = skipped.get(kind, 0) + len(eids)
            members = dict(zip(eids, nodes, strict=True))
            for name, ids_ in elsets.items():
                extra = [n for e in ids_ if e in members for n in members[e]]
                if extra:
                    nsets.setdefault(name, []).extend(extra)
    blocks = [b for b in blocks if b[0] in _WIDTH]
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
    point_sets = {name: np.unique([index[n] for n in _members(name, nsets, path)
                                   if n in index]) for name in nsets}
    cell_sets = {}
    for name in elsets:
        per_block = [[] for _ in blocks]
        for e in _members(name, elsets, path):
            if e in where_is:
                k, i = where_is[e]
                per_block[k].append(i)
        cell_sets[name] = [np.unique(np.array(p, dtype=np.int64)) for p in per_block]
    element_materials = [np.full(len(b[1]), "", dtype=object) for b in blocks]
    for elset, name in sections:
        if elset in elsets:
            for e in _members(elset, elsets, path):
                if e in where_is:
                    k, i = where_is[e]
                    element_materials[k][i] = name
    for name, faces in surfaces.items():
        nodes = _surface_nodes(faces, blocks, where_is, elsets, nsets, spelled, path)
        key = name if name not in point_sets else f"surface/{name}"
        point_sets[key] = np.unique([index[n] for n in nodes if n in index]).astype(np.int64)
    held = [(sorted(index[n] for n in ([t] if isinstance(t, int) else
                                       _members(t, nsets, path)) if n in index), dofs, at)
            for t, dofs, at in boundary if dofs]
    return meshio.Mesh(np.array(xyz, dtype=np.float64), cells, point_sets=point_sets,
                       cell_sets=cell_sets, info={
                           "skipped": skipped, "element_materials": element_materials,
                           "materials": {n: (f"*ELASTIC, TYPE={elastic_types[n]}: only "
                                             "isotropic elasticity is modelled"
                                             if n in elastic_types else tuple(v))
                                         for n, v in materials.items()},
                           "boundary": held,
                           "transforms": {n: (t, a, b, point_sets.get(n, np.empty(0, int)))
                                          for n, (t, a, b) in transforms.items()}})


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
