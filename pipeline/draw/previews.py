"""Off-screen PNG previews of a mesh (pyvista): bodies, contact patches, full disk.

They draw a :class:`MeshView`: what a preview shows of a mesh (each body's outer surface,
the cyclic faces, each patch's node grids), read from results.h5 (``run`` and ``render``)
or taken from a ``Mesh`` (``microslip mesh``, which writes no results file)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyvista as pv
from vtkmodules.vtkCommonCore import vtkObject

from microslip.draw import text
from microslip.draw.files import written
from microslip.geometry.mesh import Mesh, rotation_z
from microslip.geometry.pairing import paired_contact
from microslip.results import schema
from microslip.results.writer import ATTRS, attr_text

BODY_COLOURS = ("lightsteelblue", "orange", "palegreen", "plum", "khaki")
PATCH_COLOURS = ("red", "blue", "magenta", "darkgreen")
WINDOW = (1200, 900)  # pixels of every preview


@dataclass(frozen=True)
class BodyView:
    """One body's outer surface: its mesh nodes (p,) (where the shapes are given), their
    points (p, 3) [m], triangles (t, 3) into them (normals out of the body); whether the
    body is a cyclic sector."""

    name: str
    nodes: np.ndarray
    points: np.ndarray
    triangles: np.ndarray
    cyclic: bool

    def polydata(self) -> pv.PolyData:
        faces = np.hstack([np.full((len(self.triangles), 1), 3), self.triangles]).ravel()
        return pv.PolyData(self.points, faces)


@dataclass(frozen=True)
class CyclicView:
    """A sector body's cyclic faces: left and right (k, 3) node positions [m]."""

    body: str
    left: np.ndarray
    right: np.ndarray
    sectors: int


@dataclass(frozen=True)
class PatchView:
    """A contact: side a's node grid (n1, n2, 3) [m] (named surfaces: (P, 3) and side a's
    ``faces`` (F, 4) into ``cell_points`` (m, 3) [m], a triangle's 4th corner -1; None:
    into the points), side b's own (fundamental sector) nodes (..., 3) [m] (none on the
    ground) and its sector offset (a neighbour's patch: +-1)."""

    name: str
    body_a: str
    body_b: str
    points_a: np.ndarray
    points_b: np.ndarray
    b_sector_offset: int
    faces: np.ndarray | None = None
    cell_points: np.ndarray | None = None

    def surface(self) -> pv.DataSet:
        """Side a as a surface: the grid's quads, or the facets."""
        if self.faces is None:
            return patch_surface(self.points_a)
        cells = [[int((f >= 0).sum()), *f[f >= 0]] for f in self.faces]
        at = self.points_a if self.cell_points is None else self.cell_points
        return pv.PolyData(at, faces=np.concatenate(cells))

    @property
    def size(self) -> str:
        """"6x4" of a grid, "57 nodes" of named surfaces."""
        if self.faces is None:
            return f"{self.points_a.shape[0]}x{self.points_a.shape[1]}"
        return f"{len(self.points_a)} nodes"


@dataclass(frozen=True)
class MeshView:
    """What the previews show of a mesh; bodies and patches in name order."""

    model: str
    nodes: int
    elements: str  # the element count per shape ("4210 tetrahedra")
    bodies: tuple[BodyView, ...]
    cyclic: tuple[CyclicView, ...]
    patches: tuple[PatchView, ...]

    @classmethod
    def from_mesh(cls, mesh: Mesh) -> MeshView:
        bodies = []
        for body in sorted(mesh.bodies):
            triangles = mesh.surface(body)
            nodes = np.unique(triangles)
            bodies.append(BodyView(body, nodes, mesh.points[nodes],
                                   np.searchsorted(nodes, triangles), body in mesh.cyclic))
        cyclic = tuple(CyclicView(b, mesh.points[c.left], mesh.points[c.right], c.sectors)
                       for b, c in sorted(mesh.cyclic.items()))
        patches = tuple(_patch_view(mesh, name) for name in sorted(mesh.contacts))
        return cls(mesh.model, len(mesh.points), mesh.element_summary(), tuple(bodies), cyclic,
                   patches)

    @classmethod
    def from_results(cls, f) -> MeshView:
        """The view a results file (h5py.File) keeps: /geometry, /surfaces, /contact_grids."""
        geo = f[schema.GEOMETRY]
        bodies = tuple(BodyView(name, g["nodes"][()], g["points"][()], g["triangles"][()],
                                bool(g.attrs["cyclic"]))
                       for name, g in sorted(f[schema.SURFACES].items()))
        cyclic = tuple(CyclicView(name, g["left"][()], g["right"][()], int(g.attrs["sectors"]))
                       for name, g in sorted(geo.get(schema.CYCLIC, {}).items()))
        patches = tuple(PatchView(name, attr_text(g.attrs["body_a"]), attr_text(g.attrs["body_b"]),
                                  g["points"][()], g["points_b"][()],
                                  int(g.attrs["b_sector_offset"]),
                                  None if g["points"].ndim == 3 else g["connectivity"][()],
                                  g["cell_points"][()] if "cell_points" in g else None)
                        for name, g in sorted(f.get(schema.CONTACT_GRIDS, {}).items()))
        elements = (attr_text(geo.attrs["elements"]) if "elements" in geo.attrs
                    else f"{int(geo.attrs['tetrahedra'])} tetrahedra")  # (before 0.24)
        return cls(attr_text(geo.attrs["model"]), int(geo.attrs["nodes"]), elements, bodies,
                   cyclic, patches)

    def surface_datasets(self) -> dict:
        """/surfaces as results.writer writes it (what the previews and shapes draw on)."""
        return {b.name: {ATTRS: {"cyclic": b.cyclic}, "nodes": b.nodes, "points": b.points,
                         "triangles": b.triangles} for b in self.bodies}

    def cyclic_datasets(self) -> dict:
        """/geometry/cyclic as results.writer writes it (the patches are /contact_grids, with
        the maps' grids)."""
        return {c.body: {"left": c.left, "right": c.right, ATTRS: {"sectors": c.sectors}}
                for c in self.cyclic}


def _patch_view(mesh: Mesh, name: str) -> PatchView:
    c = paired_contact(mesh, name)
    p = c.pairing
    points = mesh.points[p.nodes_a]
    if c.grid is not None:
        return PatchView(name, c.body_a, c.body_b or "ground", points.reshape(*c.grid, 3),
                         mesh.points[p.nodes_b], c.b_sector_offset)
    nodes, owner, faces = c.map_cells()
    return PatchView(name, c.body_a, c.body_b or "ground", points, mesh.points[p.nodes_b],
                     c.b_sector_offset, faces, None if owner is None else mesh.points[nodes])


def patch_surface(points: np.ndarray) -> pv.StructuredGrid:
    """Structured quad surface through an (n1, n2, 3) grid of points."""
    return pv.StructuredGrid(points[..., 0], points[..., 1], points[..., 2])


@contextmanager
def vtk_warnings_off() -> Iterator[None]:
    """VTK's warnings muted while a render window is made and read: without a display it
    first tries the X server and prints that failure (raw colour codes) before falling
    back to off-screen rendering (EGL, OSMesa), which is what a preview wants anyway."""
    shown = vtkObject.GetGlobalWarningDisplay()
    vtkObject.GlobalWarningDisplayOff()
    try:
        yield
    finally:
        vtkObject.SetGlobalWarningDisplay(shown)


def _plotter(title: str) -> pv.Plotter:
    """An off-screen plotter with the title in a strip of its own (a title drawn over the
    model hides part of it, and a tall model runs into it); the model's renderer, below
    the strip, is left active."""
    title, top = text.strip(title, WINDOW[0], text.TITLE)
    with vtk_warnings_off():
        pl = pv.Plotter(off_screen=True, window_size=list(WINDOW), shape=(2, 1),
                        row_weights=[top, WINDOW[1] - top], border=False)
    title_strip(pl, title)
    pl.subplot(1, 0)
    return pl


def title_strip(pl: pv.Plotter, title: str) -> None:
    """White background everywhere and ``title`` centred in the first renderer (the strip
    a picture keeps for its title, as tall as the title: :func:`text.strip` breaks a
    long one into lines to fit its width)."""
    pl.set_background("white", all_renderers=True)
    pl.subplot(0, 0)
    text.place(pl, title, 0.5, 0.5, size=text.TITLE)


def _save(pl: pv.Plotter, path: Path) -> Path:
    try:
        with vtk_warnings_off(), written(path) as tmp:
            pl.screenshot(str(tmp))
    finally:
        pl.close()
    return path


def _legend(pl: pv.Plotter, width: float, entries: list[dict]) -> None:
    """The legend in the lower right corner of the model's view, one text size whatever
    the number of entries (VTK fits the text to the box); ``entries``: {label, color,
    face}, the face as drawn (a surface a rectangle, points a circle). Placed explicitly:
    pyvista places a right-hand legend by its height, pushing a wide one off the picture."""
    size = (width, 0.04 * len(entries))
    legend = pl.add_legend(entries, bcolor="white", size=size, loc="lower right")
    legend.SetPosition(1.0 - width - 0.01, 0.02)


#: where a patch's side b lies, by its sector offset
SECTOR = {0: "this sector", 1: "the next sector", -1: "the previous sector"}


def render_sector(mesh: MeshView, path: Path) -> Path:
    """The sector (or plain model) with each body in its own colour and mesh edges."""
    pl = _plotter(f"{mesh.model}: {mesh.nodes} nodes, {mesh.elements}")
    entries = []
    for i, body in enumerate(mesh.bodies):
        colour = BODY_COLOURS[i % len(BODY_COLOURS)]
        pl.add_mesh(body.polydata(), color=colour, show_edges=True, edge_color="dimgray",
                    line_width=0.5)
        entries.append({"label": body.name, "color": colour, "face": "rectangle"})
    for cyc in mesh.cyclic:
        for side, colour in (("left", "green"), ("right", "purple")):
            pl.add_points(getattr(cyc, side), color=colour, point_size=4,
                          render_points_as_spheres=True)
            entries.append({"label": f"cyclic {cyc.body} {side}", "color": colour,
                            "face": "circle"})
    _legend(pl, 0.26, entries)
    pl.add_axes()
    points = np.concatenate([b.points for b in mesh.bodies])
    axial_view(pl, points.mean(axis=0), np.ptp(points, axis=0).max())
    pl.reset_camera()
    pl.camera.zoom(0.92)  # a margin: the tilted view otherwise puts a tall blade on the edge
    return _save(pl, path)


def axial_view(pl: pv.Plotter, focus: np.ndarray, span: float) -> None:
    """Look along +z from z < 0 (pocket and slot profiles lie in the xy plane), tilted so
    the axial faces show; +x (the blade) up, +y (theta > 0) to the right."""
    pl.camera.focal_point = focus
    pl.camera.position = focus + 2.5 * span * np.array([-0.15, 0.55, -1.0])
    pl.camera.up = (1.0, 0.0, 0.0)


def render_contacts(mesh: MeshView, path: Path) -> Path:
    """Contact patches highlighted on translucent bodies, zoomed on the patches.

    Side a is drawn as a coloured grid; side b as spheres at its own (fundamental-sector)
    nodes, so a neighbour-sector patch (b_sector_offset != 0) appears on the opposite
    cyclic side of the sector - which is where its nodes are."""
    pl = _plotter(f"{mesh.model}: contact patches")
    for i, body in enumerate(mesh.bodies):
        pl.add_mesh(body.polydata(), color=BODY_COLOURS[i % len(BODY_COLOURS)],
                    opacity=0.25, show_edges=True, edge_color="gray", line_width=0.3)
    centres, entries = [], []
    for i, patch in enumerate(mesh.patches):
        colour = PATCH_COLOURS[i % len(PATCH_COLOURS)]
        a, b_own = patch.points_a, patch.points_b
        pl.add_mesh(patch.surface(), color=colour, show_edges=True, edge_color="black")
        entries.append({"label": f"{patch.name} {patch.size}: {patch.body_a} face",
                        "color": colour, "face": "rectangle"})
        centres.append(a.reshape(-1, 3).mean(axis=0))
        if len(b_own):  # (the ground has none)
            pl.add_points(b_own.reshape(-1, 3), color=colour, point_size=8,
                          render_points_as_spheres=True)
            where = SECTOR.get(patch.b_sector_offset, f"sector {patch.b_sector_offset:+d}")
            entries.append({"label": f"{patch.name}: {patch.body_b} nodes, of {where}",
                            "color": colour, "face": "circle"})
            centres.append(b_own.reshape(-1, 3).mean(axis=0))
    _legend(pl, 0.42, entries)  # a corner away from the centred patches
    pl.add_axes()
    if centres:
        pts = np.array(centres)
        axial_view(pl, pts.mean(axis=0), max(np.ptp(pts, axis=0).max(), 1e-3))
    return _save(pl, path)


def render_full_disk(mesh: MeshView, path: Path) -> Path:
    """The full disk made of Ns rotated copies of the sector's body surfaces."""
    if not mesh.cyclic:
        raise ValueError(f"{mesh.model} has no cyclic body: no full disk to draw")
    ns = mesh.cyclic[0].sectors
    surfaces = {b.name: b.polydata() for b in mesh.bodies}
    pl = _plotter(f"{mesh.model}: full disk, {ns} sectors (sector 0 in red)")
    for k in range(ns):
        rot = np.eye(4)
        rot[:3, :3] = rotation_z(2 * np.pi * k / ns)
        for i, surf in enumerate(surfaces.values()):
            colour = "tomato" if k == 0 else BODY_COLOURS[i % len(BODY_COLOURS)]
            pl.add_mesh(surf.transform(rot, inplace=False), color=colour, smooth_shading=False)
    pl.add_axes()
    pl.view_isometric()
    return _save(pl, path)


def preview_names(mesh: MeshView) -> list[str]:
    """The files of a mesh's previews: "<model>_sector.png", with contact patches
    "<model>_contacts.png", with a cyclic body "<model>_full_disk.png"."""
    return [f"{mesh.model}_{x}.png" for x, shown in (
        ("sector", True), ("contacts", bool(mesh.patches)), ("full_disk", bool(mesh.cyclic)))
        if shown]


def render_previews(mesh: Mesh | MeshView, out_dir) -> list[Path]:
    """Write the PNG previews (:func:`preview_names`) of a mesh to out_dir."""
    view = mesh if isinstance(mesh, MeshView) else MeshView.from_mesh(mesh)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [render_sector(view, out / f"{view.model}_sector.png")]
    if view.patches:
        paths.append(render_contacts(view, out / f"{view.model}_contacts.png"))
    if view.cyclic:
        paths.append(render_full_disk(view, out / f"{view.model}_full_disk.png"))
    return paths


def geometry_previews(g, name: str, out: Path, options=None) -> list[Path]:
    """The drawer of a results file's /geometry group (``render`` draws it): the previews of
    the mesh it keeps."""
    return render_previews(MeshView.from_results(g.file), out)
