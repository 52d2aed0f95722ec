"""Meshes written as other tools write them, for the import tests: a Mesh moved into another
frame and unit, optionally quadratic (mid-edge nodes where the mesh has them: its curved edges'
nodes, the other edges' midpoints), to .inp, .bdf,
.msh or any meshio format, with the bodies as element sets and the node sets as node sets
(Gmsh: physical groups; Nastran: the property id of each body, no sets)."""

from __future__ import annotations

import warnings
from pathlib import Path

import meshio
import numpy as np

from microslip.geometry import Mesh, elements

QUADRATIC = {"tetra": "tetra10", "hexahedron": "hexahedron20", "wedge": "wedge15"}
FORMATS = {".inp": "abaqus", ".bdf": "nastran", ".msh": "gmsh22"}


def write(mesh: Mesh, path: Path, *, scale: float = 1.0, rotation=None, origin=(0, 0, 0),
          quadratic: bool = False) -> Path:
    """Write ``mesh`` with x_file = (rotation x + origin) / scale (``scale``: metres per
    file length unit). Corner nodes keep their numbers; mid nodes follow."""
    R = np.eye(3) if rotation is None else np.asarray(rotation)
    points = (mesh.points @ R.T + np.asarray(origin)) / scale
    blocks, extra = [], {}  # (type, body, cells); mid node of each corner pair
    for body in mesh.bodies:
        for shape, corners in mesh.body_cells(body).items():
            if not quadratic:
                blocks.append((shape, body, corners))
                continue
            mids = np.empty((len(corners), len(elements.EDGES[shape])), dtype=np.int64)
            for e, (a, b) in enumerate(elements.EDGES[shape]):
                for i, pair in enumerate(np.sort(corners[:, [a, b]], axis=1)):
                    mids[i, e] = extra.setdefault(tuple(pair), len(points) + len(extra))
            blocks.append((QUADRATIC[shape], body, np.hstack([corners, mids])))
    if extra:
        mid = mesh.mid_edge_points(np.array(list(extra)))
        points = np.vstack([points, (mid @ R.T + np.asarray(origin)) / scale])
    fmt = FORMATS.get(Path(path).suffix, None)
    cells = [(t, c) for t, _, c in blocks]
    names = list(mesh.bodies)
    tags = [np.full(len(c), names.index(b) + 1) for _, b, c in blocks]
    if fmt == "gmsh22":
        field = {b: np.array([i + 1, 3]) for i, b in enumerate(names)}
        for j, (name, idx) in enumerate(mesh.node_sets.items()):
            cells.append(("vertex", idx.reshape(-1, 1)))
            tags.append(np.full(len(idx), len(names) + j + 1))
            field[name] = np.array([len(names) + j + 1, 0])
        out = meshio.Mesh(points, cells, cell_data={"gmsh:physical": tags,
                                                    "gmsh:geometrical": tags},
                          field_data=field)
        meshio.write(path, out, file_format=fmt, binary=False)
        return Path(path)
    if fmt == "nastran":
        # meshio 5.3's large-field writer asserts 16 characters, which a negative number at
        # its precision (12 digits) or an exponent beyond +-9 exceeds: 11 digits, and
        # round-off zeros written as zeros
        points = np.where(np.abs(points) < 1e-9 * np.abs(points).max(), 0.0, points)
        points = np.vectorize(lambda v: float(f"{v:.10e}"))(points)
        out = meshio.Mesh(points, cells, cell_data={"nastran:ref": tags})
        meshio.write(path, out, file_format=fmt)
        return Path(path)
    if Path(path).suffix == ".cdb":
        return _ansys_archive(path, points, blocks, names, mesh.node_sets)
    cell_sets = {b: [np.arange(len(c)) if bb == b else np.empty(0, dtype=np.int64)
                     for _, bb, c in blocks] for b in names}
    out = meshio.Mesh(points, cells, point_sets=dict(mesh.node_sets), cell_sets=cell_sets)
    meshio.write(path, out, file_format=fmt)
    return Path(path)


# meshio type -> VTK cell type, and the corner order VTK wants (its wedge is mirrored)
_VTK = {"tetra": 10, "tetra10": 24, "hexahedron": 12, "hexahedron20": 25, "wedge": 13,
        "wedge15": 26}


def _ansys_archive(path, points, blocks, names, node_sets) -> Path:
    """An Ansys archive as ansys-mapdl-reader writes it: the bodies as material ids 1, 2, ...
    (``mat<N>`` when read), node sets as node components (named in capitals, '/' -> '_')."""
    import pyvista as pv
    from ansys.mapdl.reader import save_as_archive
    from pyvista.core.errors import PyVistaDeprecationWarning

    cells, types, material = [], [], []
    for kind, body, c in blocks:
        c = c.copy()
        if kind.startswith("wedge"):  # VTK's wedge: the bottom triangle the other way round
            c[:, :6] = c[:, elements.MIRROR["wedge"]]
            if kind == "wedge15":
                c[:, 6:] = c[:, [8, 7, 6, 11, 10, 9, 12, 14, 13]]
        cells.append(np.hstack([np.full((len(c), 1), c.shape[1]), c]).ravel())
        types += [_VTK[kind]] * len(c)
        material += [names.index(body) + 1] * len(c)
    grid = pv.UnstructuredGrid(np.concatenate(cells), np.array(types, np.uint8), points)
    grid.cell_data["ansys_material_type"] = np.array(material, dtype=np.int32)
    for name, idx in node_sets.items():
        mask = np.zeros(len(points), dtype=bool)
        mask[idx] = True
        grid.point_data[name.replace("/", "_").upper()] = mask
    with warnings.catch_warnings():  # its writer uses a name pyvista 0.49 deprecates
        warnings.simplefilter("ignore", PyVistaDeprecationWarning)
        save_as_archive(str(path), grid)
    return Path(path)
