"""Off-screen PNG previews of a mesh (pyvista): bodies, contact patches, full disk."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pyvista as pv
from vtkmodules.vtkCommonCore import vtkObject

from microslip.geometry.mesh import Mesh, rotation_z

BODY_COLOURS = ("lightsteelblue", "orange", "palegreen", "plum", "khaki")
PATCH_COLOURS = ("red", "blue", "magenta", "darkgreen")
WINDOW = (1200, 900)  # pixels of every preview
TITLE_ROWS = (1, 12)  # heights of the title strip and of the model below it


def body_surface(mesh: Mesh, body: str) -> pv.PolyData:
    """Outer surface (triangles) of one body, as pyvista PolyData (m)."""
    tets = mesh.tetrahedra[mesh.bodies[body]]
    cells = np.hstack([np.full((len(tets), 1), 4), tets]).ravel()
    grid = pv.UnstructuredGrid(cells, np.full(len(tets), pv.CellType.TETRA), mesh.points)
    return grid.extract_surface(algorithm="dataset_surface")


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
    with vtk_warnings_off():
        pl = pv.Plotter(off_screen=True, window_size=list(WINDOW), shape=(2, 1),
                        row_weights=TITLE_ROWS, border=False)
    title_strip(pl, title, 12)
    pl.subplot(1, 0)
    return pl


def title_strip(pl: pv.Plotter, title: str, font_size: int) -> None:
    """White background everywhere and ``title`` centred in the first renderer (the strip
    a picture keeps for its title)."""
    pl.set_background("white", all_renderers=True)
    pl.subplot(0, 0)
    text = pl.add_text(title, position=(0.5, 0.5), viewport=True, font_size=font_size,
                       color="black")
    text.prop.justification_horizontal = "center"
    text.prop.justification_vertical = "center"


def _save(pl: pv.Plotter, path: Path) -> Path:
    with vtk_warnings_off():
        pl.screenshot(str(path))
    pl.close()
    return path


def _legend(pl: pv.Plotter, width: float, entries: int) -> None:
    """The legend in the lower right corner of the model's view, one text size whatever
    the number of entries (VTK fits the text to the box). Placed explicitly: pyvista
    places a right-hand legend by its height, pushing a wide one off the picture."""
    size = (width, 0.04 * entries)
    legend = pl.add_legend(bcolor="white", size=size, loc="lower right")
    legend.SetPosition(1.0 - width - 0.01, 0.02)


def render_sector(mesh: Mesh, path: Path) -> Path:
    """The sector (or plain model) with each body in its own colour and mesh edges."""
    pl = _plotter(f"{mesh.model}: {len(mesh.points)} nodes, {len(mesh.tetrahedra)} tets")
    for i, body in enumerate(mesh.bodies):
        pl.add_mesh(body_surface(mesh, body), color=BODY_COLOURS[i % len(BODY_COLOURS)],
                    show_edges=True, edge_color="dimgray", line_width=0.5, label=body)
    for cyc_body, cyc in mesh.cyclic.items():
        for side, colour in (("left", "green"), ("right", "purple")):
            pl.add_points(mesh.points[getattr(cyc, side)], color=colour, point_size=4,
                          render_points_as_spheres=True, label=f"cyclic {cyc_body} {side}")
    _legend(pl, 0.26, len(mesh.bodies) + 2 * len(mesh.cyclic))
    pl.add_axes()
    axial_view(pl, mesh.points.mean(axis=0), np.ptp(mesh.points, axis=0).max())
    pl.reset_camera()
    pl.camera.zoom(0.92)  # a margin: the tilted view otherwise puts a tall blade on the edge
    return _save(pl, path)


def axial_view(pl: pv.Plotter, focus: np.ndarray, span: float) -> None:
    """Look along +z from z < 0 (pocket and slot profiles lie in the xy plane), tilted so
    the axial faces show; +x (the blade) up, +y (theta > 0) to the right."""
    pl.camera.focal_point = focus
    pl.camera.position = focus + 2.5 * span * np.array([-0.15, 0.55, -1.0])
    pl.camera.up = (1.0, 0.0, 0.0)


def render_contacts(mesh: Mesh, path: Path) -> Path:
    """Contact patches highlighted on translucent bodies, zoomed on the patches.

    Side a is drawn as a coloured grid; side b as spheres at its own (fundamental-sector)
    nodes, so a neighbour-sector patch (b_sector_offset != 0) appears on the opposite
    cyclic side of the sector - which is where its nodes are."""
    pl = _plotter(f"{mesh.model}: contact patches")
    for i, body in enumerate(mesh.bodies):
        pl.add_mesh(body_surface(mesh, body), color=BODY_COLOURS[i % len(BODY_COLOURS)],
                    opacity=0.25, show_edges=True, edge_color="gray", line_width=0.3)
    centres = []
    for i, (name, patch) in enumerate(mesh.contacts.items()):
        colour = PATCH_COLOURS[i % len(PATCH_COLOURS)]
        a = mesh.patch_points(name, "a")
        pl.add_mesh(patch_surface(a), color=colour, show_edges=True, edge_color="black",
                    label=f"{name} {patch.shape[0]}x{patch.shape[1]}: {patch.body_a} face")
        b_own = mesh.points[patch.nodes_b]
        pl.add_points(b_own.reshape(-1, 3), color=colour, point_size=8,
                      render_points_as_spheres=True,
                      label=f"{name}: {patch.body_b} nodes, offset {patch.b_sector_offset}")
        centres.append(a.reshape(-1, 3).mean(axis=0))
        centres.append(b_own.reshape(-1, 3).mean(axis=0))
    _legend(pl, 0.42, 2 * len(mesh.contacts))  # a corner away from the centred patches
    pl.add_axes()
    if centres:
        pts = np.array(centres)
        axial_view(pl, pts.mean(axis=0), max(np.ptp(pts, axis=0).max(), 1e-3))
    return _save(pl, path)


def render_full_disk(mesh: Mesh, path: Path) -> Path:
    """The full disk made of Ns rotated copies of the sector's body surfaces."""
    if not mesh.cyclic:
        raise ValueError(f"{mesh.model} has no cyclic body: no full disk to draw")
    ns = next(iter(mesh.cyclic.values())).sectors
    surfaces = {b: body_surface(mesh, b) for b in mesh.bodies}
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


def render_previews(mesh: Mesh, out_dir) -> list[Path]:
    """Write PNG previews (sector, contact patches if any, full disk if cyclic) to out_dir.

    Files: "<model>_sector.png", "<model>_contacts.png", "<model>_full_disk.png"."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [render_sector(mesh, out / f"{mesh.model}_sector.png")]
    if mesh.contacts:
        paths.append(render_contacts(mesh, out / f"{mesh.model}_contacts.png"))
    if mesh.cyclic:
        paths.append(render_full_disk(mesh, out / f"{mesh.model}_full_disk.png"))
    return paths
