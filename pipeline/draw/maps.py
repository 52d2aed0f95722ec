"""Contact-status and static-load maps of contact patches (Firrone & Zucca Fig. 20, 23), off screen.

Each node pair of a patch's structured grid is drawn as the cell of its own tributary area
(the dual grid: corners halfway between neighbouring nodes, the outer ones extrapolated), so
a map shows one solid colour per node and never blends two states; a contact between named
surfaces likewise, each facet of side a cut into one cell per corner. The patch is drawn flat
in its own plane, seen from body b onto body a's face, turned so that the direction of
growing radius (at the patch centre, projected onto the plane) points up; the edge at the
highest radius is also drawn thick and labelled, so the orientation reads without the text.

Colours of the states over the period follow Firrone & Zucca's Fig. 23 (white: stick; grey:
alternate stick-slip; black: partial lift-off); gross slip and open, which that figure does
not show, get colours of their own.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from microslip.draw import text
from microslip.draw.files import written
from microslip.laws.states import (
    GROSS_SLIP,
    OPEN,
    PARTIAL_LIFTOFF,
    STATE_NAMES,
    STICK,
    STICK_SLIP,
)

#: Colour of each state over the period (matplotlib/VTK colour names or #rrggbb).
STATE_COLOURS: dict[int, str] = {STICK: "white", STICK_SLIP: "#a0a0a0", GROSS_SLIP: "#e6550d",
                                 PARTIAL_LIFTOFF: "black", OPEN: "#3182bd"}
#: Pixels of one map panel (width, height); a grid of panels multiplies them (a single
#: column is drawn two panels wide: its title and the legend need the room).
PANEL = (520, 420)
EDGES = ("first row (i = 0)", "last row (i = n1 - 1)", "first column (j = 0)",
         "last column (j = n2 - 1)")
HIGH_RADIUS = "#d62728"  # the high-radius edge


@dataclass(frozen=True, eq=False)
class PatchGrid:
    """Where a contact's node pairs sit, and how its map is drawn.

    name: contact name; points: side a's coordinates [m], (n1, n2, 3) for a structured
    patch, (P, 3) for named surfaces; frame: (3, 3) rows t1, t2, n (n from body a into body
    b; named surfaces: their mean normal's); axes: (2, 3) the map's right and up directions
    in space (up: growing radius; right x up = n); high_edge: index into EDGES of the grid
    edge at the highest mean radius (-1: named surfaces); nodes_a: mesh nodes of the pairs
    (grid-shaped, or (P,)); nodes_b: side b's (none on the ground, body_b "ground"); faces:
    None for a grid, else (F, 4) side a's facets as indices into ``cell_points`` (a
    triangle's 4th corner -1); cell_points: (m, 3) [m] their nodes (None: the pairs'
    points); owner: (m,) the pair each of them stands in (None: itself)."""

    name: str
    body_a: str
    body_b: str
    points: np.ndarray
    frame: np.ndarray
    axes: np.ndarray
    high_edge: int
    nodes_a: np.ndarray
    nodes_b: np.ndarray
    faces: np.ndarray | None = None
    cell_points: np.ndarray | None = None
    owner: np.ndarray | None = None

    @property
    def structured(self) -> bool:
        return self.faces is None

    @property
    def cell_xyz(self) -> np.ndarray:
        """(m, 3) [m] the facets' nodes (named surfaces): the pairs' own points but for
        averaged points."""
        return self.points if self.cell_points is None else self.cell_points

    @property
    def cell_plane(self) -> np.ndarray:
        """(m, 2) map coordinates [m] of the facets' nodes (named surfaces), about the
        pairs' centre."""
        return (self.cell_xyz - self.points.reshape(-1, 3).mean(axis=0)) @ self.axes.T

    @property
    def cell_owner(self) -> np.ndarray:
        """(m,) the pair each facet node stands in (named surfaces)."""
        return np.arange(len(self.points)) if self.owner is None else self.owner

    @property
    def shape(self) -> tuple[int, ...]:
        """(n1, n2) of a grid, (P,) of named surfaces."""
        return self.points.shape[:-1]

    @property
    def plane(self) -> np.ndarray:
        """(..., 2) map coordinates [m] of the nodes (right, up) about the patch centre."""
        centred = self.points - self.points.reshape(-1, 3).mean(axis=0)
        return centred @ self.axes.T

    @property
    def connectivity(self) -> np.ndarray:
        """(F, 4) quads of the node grid, node indices row-major (i n2 + j),
        counter-clockwise in (i, j); named surfaces: their facets."""
        if not self.structured:
            return self.faces
        n1, n2 = self.shape
        idx = np.arange(n1 * n2).reshape(n1, n2)
        return np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]],
                        axis=-1).reshape(-1, 4)

    @classmethod
    def from_mesh(cls, mesh, name: str) -> PatchGrid:
        from microslip.geometry.pairing import normal_frames, paired_contact

        c = paired_contact(mesh, name)
        p = c.pairing
        body_b = c.body_b if c.body_b is not None else "ground"
        if c.grid is not None:
            points = mesh.points[p.nodes_a].reshape(*c.grid, 3)
            frame = c.frames[0]
            return cls(name, c.body_a, body_b, points, frame, map_axes(points, frame),
                       high_radius_edge(points), p.nodes_a.reshape(c.grid),
                       p.nodes_b.reshape(c.grid))
        points = mesh.points[p.nodes_a]
        mean = (p.areas[:, None] * p.normals).sum(axis=0)
        # the area-weighted mean normal, or where the normals nearly cancel (a ring) the
        # largest pair's
        n = mean if np.linalg.norm(mean) > 0.5 * p.areas.sum() else p.normals[
            np.argmax(p.areas)]
        frame = normal_frames(n[None])[0]
        nodes, owner, faces = c.map_cells()
        return cls(name, c.body_a, body_b, points, frame, map_axes(points, frame), -1,
                   p.nodes_a, p.nodes_b, faces, None if owner is None else mesh.points[nodes],
                   owner)

    def datasets(self) -> dict[str, np.ndarray]:
        """What results.h5 keeps under /contact_grids/<patch> (attrs: body_a, body_b,
        high_edge)."""
        out = {"points": self.points, "frame": self.frame, "map_axes": self.axes,
               "map_coordinates": self.plane, "connectivity": self.connectivity,
               "nodes_a": self.nodes_a, "nodes_b": self.nodes_b}
        if self.owner is not None:  # averaged points
            out |= {"cell_points": self.cell_xyz, "cell_owner": self.owner}
        return out

    @classmethod
    def from_group(cls, name: str, g) -> PatchGrid:
        """A PatchGrid read back from its results.h5 group (h5py)."""
        points = g["points"][()]
        cells = [g[k][()] if k in g else None for k in ("cell_points", "cell_owner")]
        return cls(name, str(g.attrs["body_a"]), str(g.attrs["body_b"]), points,
                   g["frame"][()], g["map_axes"][()], int(g.attrs["high_edge"]),
                   g["nodes_a"][()], g["nodes_b"][()],
                   None if points.ndim == 3 else g["connectivity"][()], *cells)


def map_axes(points: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """(2, 3) right and up of a patch's map: up along the radius (from the disk axis +z
    through the patch centre) projected onto the patch plane, right = up x n. A patch whose
    plane is normal to the radius (no projection to speak of) keeps t2 up."""
    n = frame[2]
    c = points.reshape(-1, 3).mean(axis=0)
    radial = np.array([c[0], c[1], 0.0])
    up = radial - (radial @ n) * n
    if np.linalg.norm(up) < 0.2 * max(np.linalg.norm(radial), 1e-300):
        up = frame[1]
    up = up / np.linalg.norm(up)
    return np.stack([np.cross(up, n), up])


def high_radius_edge(points: np.ndarray) -> int:
    """Index into EDGES of the grid edge whose nodes have the highest mean radius."""
    r = np.hypot(points[..., 0], points[..., 1])
    return int(np.argmax([r[0].mean(), r[-1].mean(), r[:, 0].mean(), r[:, -1].mean()]))


#: Grey of the lines between node pairs' cells, and of the borders of averaged points'
CELL_EDGES, BORDERS = "#c8c8c8", "#707070"


def cell_corners(plane: np.ndarray) -> np.ndarray:
    """(n1 + 1, n2 + 1, 2) corners of the nodes' tributary cells: halfway between
    neighbouring nodes, half a spacing beyond the outer ones (a grid of one node along an
    axis gets a unit-free zero-width cell, which the caller avoids)."""
    out = plane
    for axis in (0, 1):
        a = np.moveaxis(out, axis, 0)
        mid = 0.5 * (a[1:] + a[:-1])
        first, last = a[0] - (mid[0] - a[0]), a[-1] + (a[-1] - mid[-1])
        out = np.moveaxis(np.concatenate([first[None], mid, last[None]]), 0, axis)
    return out


def state_rgb(states: np.ndarray, colours: Mapping[int, str] = STATE_COLOURS) -> np.ndarray:
    """(..., 3) uint8 colour of each state."""
    from matplotlib.colors import to_rgb

    table = np.array([to_rgb(colours[s]) for s in range(len(STATE_NAMES))])
    return np.round(255 * table[np.asarray(states, dtype=int)]).astype(np.uint8)


def cells(grid: PatchGrid, values: np.ndarray, name: str):
    """pyvista grid of the nodes' tributary cells in map coordinates [mm] with ``values``
    (P,) or (P, k) per node (grid order) as cell data ``name``: a structured patch's dual
    grid, or for named surfaces each facet cut into one quad per corner (the corner, its
    edges' midpoints and the facet's centroid) in its corner's pair's value (averaged
    points: the patch the corner belongs to)."""
    import pyvista as pv

    if not grid.structured:
        return _dual_cells(grid, values, name)
    corners = 1e3 * cell_corners(grid.plane)
    x, y = corners[..., 0], corners[..., 1]
    sg = pv.StructuredGrid(x, y, np.zeros_like(x))
    n1, n2 = grid.shape
    v = np.asarray(values).reshape(n1, n2, -1)
    # VTK orders the cells of a structured grid with the first index fastest
    sg.cell_data[name] = v.transpose(1, 0, 2).reshape(n1 * n2, -1).squeeze()
    return sg


def _dual_cells(grid: PatchGrid, values: np.ndarray, name: str):
    import pyvista as pv

    xy = 1e3 * grid.cell_plane
    pair = grid.cell_owner
    pts, quads, owner = [], [], []
    for face in grid.faces:
        corners = face[face >= 0]
        c = xy[corners]
        centre = c.mean(axis=0)
        mids = 0.5 * (c + np.roll(c, -1, axis=0))  # mid of edge (k, k + 1)
        for k, node in enumerate(corners):
            start = len(pts)
            pts += [c[k], mids[k], centre, mids[k - 1]]
            quads.append([4, start, start + 1, start + 2, start + 3])
            owner.append(pair[node])
    xyz = np.column_stack([np.array(pts), np.zeros(len(pts))])
    mesh = pv.PolyData(xyz, faces=np.array(quads).ravel())
    v = np.asarray(values).reshape(len(grid.points), -1)
    mesh.cell_data[name] = v[np.array(owner)].squeeze()
    return mesh


def boundary_edges(faces: np.ndarray) -> np.ndarray:
    """(e, 2) edges of the facets (F, 4; a triangle's 4th corner -1) that belong to one
    facet only: the outline."""
    edges = []
    for face in faces:
        corners = face[face >= 0]
        edges += [tuple(sorted(e)) for e in zip(corners, np.roll(corners, -1))]
    found, counts = np.unique(np.array(edges), axis=0, return_counts=True)
    return found[counts == 1]


@dataclass(frozen=True)
class Panel:
    """One map: a patch, a value per node pair (a state, or a force [N]) and a caption."""

    grid: PatchGrid
    values: np.ndarray
    caption: str


def _plotter(title: str, rows: int, cols: int, panel: tuple[int, int], bottom: int):
    """Off-screen plotter: a title strip as tall as the title (broken into lines to fit
    the width), rows x cols panels (one column as wide as two: the title and the legend
    need the room), a strip ``bottom`` pixels tall for the legend or the colour scale."""
    import pyvista as pv

    from microslip.draw.previews import title_strip, vtk_warnings_off

    width = _panel_width(cols, panel) * cols
    title, top = text.strip(title, width, text.TITLE)
    size = [width, panel[1] * rows + top + bottom]
    with vtk_warnings_off():
        pl = pv.Plotter(off_screen=True, window_size=size, shape=(rows + 2, cols),
                        row_weights=[top] + [panel[1]] * rows + [bottom],
                        groups=[(0, np.s_[:]), (rows + 1, np.s_[:])], border=False)
    title_strip(pl, title)
    return pl


def _panel_width(cols: int, panel: tuple[int, int]) -> int:
    """Pixels of one panel's width: the panel's, twice it in a single column."""
    return panel[0] * (2 if cols == 1 else 1)


def patch_borders(grid: PatchGrid) -> np.ndarray:
    """(e, 2, 2) [mm] map segments between averaged points' areas: in each facet, from an
    edge's midpoint to the centroid where the edge's two corners stand in different points
    (the corner quads of :func:`cells` meet there); none for node pairs."""
    if grid.owner is None:
        return np.empty((0, 2, 2))
    xy, owner, out = 1e3 * grid.cell_plane, grid.owner, []
    for face in grid.faces:
        corners = face[face >= 0]
        c = xy[corners]
        centre = c.mean(axis=0)
        for k, (a, b) in enumerate(zip(corners, np.roll(corners, -1))):
            if owner[a] != owner[b]:
                out.append([0.5 * (c[k] + c[(k + 1) % len(c)]), centre])
    return np.array(out).reshape(-1, 2, 2)


def _outline(pl, grid: PatchGrid) -> np.ndarray | None:
    """The patch outline (black) and its high-radius edge (thick): a grid's outer row or
    column at the highest radius; named surfaces' outline edges within a twentieth of the
    radius range of the highest; averaged points' borders (grey). The high-radius edge's
    points (k, 2) [mm] (None: none found), for its label."""
    import pyvista as pv

    borders = patch_borders(grid)
    if len(borders):
        pts = np.column_stack([borders.reshape(-1, 2), np.full(2 * len(borders), 0.005)])
        lines = np.column_stack([np.full(len(borders), 2),
                                 np.arange(2 * len(borders)).reshape(-1, 2)]).ravel()
        pl.add_mesh(pv.PolyData(pts, lines=lines), color=BORDERS, line_width=1.5)

    if grid.structured:
        c = 1e3 * cell_corners(grid.plane)
        ring = np.concatenate([c[:, 0], c[-1, 1:], c[-2::-1, -1], c[0, -2::-1]])
        pts = np.column_stack([ring, np.full(len(ring), 0.01)])
        pl.add_mesh(pv.lines_from_points(pts, close=True), color="black", line_width=2)
        edges = [(c[0], c[-1], c[:, 0], c[:, -1])[grid.high_edge]]
    else:
        xy = 1e3 * grid.cell_plane
        outline = boundary_edges(grid.faces)
        pl.add_mesh(_segments(xy, outline, 0.01), color="black", line_width=2)
        r = np.hypot(grid.cell_xyz[:, 0], grid.cell_xyz[:, 1])
        top = r.max() - 0.05 * max(np.ptp(r), 1e-300)
        high = outline[(r[outline] >= top).all(axis=1)]
        edges = [xy[e] for e in high]
    for edge in edges:
        e = np.column_stack([edge, np.full(len(edge), 0.02)])
        pl.add_mesh(pv.lines_from_points(e), color=HIGH_RADIUS, line_width=6)
    return np.vstack(edges) if edges else None


def _segments(xy: np.ndarray, edges: np.ndarray, z: float):
    """pyvista line segments (e, 2) between map points xy [mm] at height z."""
    import pyvista as pv

    pts = np.column_stack([xy, np.full(len(xy), z)])
    lines = np.column_stack([np.full(len(edges), 2), edges]).ravel()
    return pv.PolyData(pts, lines=lines)


FILL = 0.9  # share of the room below the caption the patch fills at most, in height
FILL_WIDTH = 0.85  # and in width


def _view(pl, caption: str, grid: PatchGrid, panel: tuple[int, int],
          high: np.ndarray | None) -> None:
    """The caption at the top of the panel (``panel``: its width and height [px]), the
    camera on the map plane with the patch filling the room below it, and the high-radius
    edge (``high``: (k, 2) [mm]) labelled just above the patch."""
    w, h = panel
    caption = text.fit(caption, w - 2 * text.GAP, text.CAPTION)
    text.place(pl, caption, 0.5, 1 - text.GAP / h, size=text.CAPTION, v="top")
    label = text.measure(HIGH_LABEL, text.CAPTION)[1] if high is not None else 0
    room_top = h - 3 * text.GAP - text.measure(caption, text.CAPTION)[1] - label
    room = max(room_top - text.GAP, 1)  # [px] from GAP up to room_top
    pl.view_xy()
    pl.enable_parallel_projection()
    pl.reset_camera()
    c = 1e3 * (cell_corners(grid.plane) if grid.structured else grid.cell_plane).reshape(-1, 2)
    lo, (pw, ph) = c.min(axis=0), np.ptp(c, axis=0)
    mm = max(ph / (FILL * room), pw / (FILL_WIDTH * w), 1e-300)  # [mm / px]
    # the patch's centre at the room's: the camera's centre that far above or below it
    centre = lo + 0.5 * np.array([pw, ph]) + np.array([0.0, (h / 2 - (text.GAP + room / 2)) * mm])
    pl.camera.focal_point = (*centre, 0.0)
    pl.camera.position = (*centre, 10 * max(pw, ph))
    pl.camera.parallel_scale = 0.5 * h * mm
    if high is not None:  # centred on the edge, just above the patch's top
        x = 0.5 + (high[:, 0].mean() - centre[0]) / (w * mm)
        y = 0.5 + (lo[1] + ph - centre[1]) / (h * mm) + text.GAP / h
        text.place(pl, HIGH_LABEL, x, y, size=text.CAPTION, color=HIGH_RADIUS, v="bottom")


#: the label of a patch's high-radius edge
HIGH_LABEL = "high radius"
#: a legend entry's square [px]
SQUARE = 18


def legend_rows(names: Sequence[str], width: int) -> list[list[tuple[int, str]]]:
    """The legend's entries flowed into rows of ``width`` pixels: per row (x [px] of the
    entry's square, its index)."""
    rows, x = [[]], text.GAP
    for k, name in enumerate(names):
        w = SQUARE + text.GAP + text.measure(name, text.NAME)[0] + 3 * text.GAP
        if rows[-1] and x + w > width - text.GAP:
            rows.append([])
            x = text.GAP
        rows[-1].append((x, k))
        x += w
    return rows


#: pixels of a legend row
LEGEND_ROW = SQUARE + 2 * text.GAP


def _legend(pl, entries: Sequence[tuple[str, str]], width: int, height: int) -> None:
    """Squares with black outlines and black names (VTK's legend writes each name in its
    entry's colour: white is unreadable on white), flowed into rows across the strip
    (``width`` x ``height`` pixels; the camera's unit is the strip's pixel)."""
    import pyvista as pv

    rows = legend_rows([n for n, _ in entries], width)
    top = height - (height - len(rows) * LEGEND_ROW) / 2  # the rows centred in the strip
    for r, row in enumerate(rows):
        y = top - (r + 0.5) * LEGEND_ROW  # [px] the row's middle
        for x, k in row:
            name, colour = entries[k]
            y0 = y - SQUARE / 2
            pl.add_mesh(pv.Rectangle([[x, y0, 0], [x + SQUARE, y0, 0],
                                      [x + SQUARE, y0 + SQUARE, 0]]),
                        color=colour, show_edges=True, edge_color="black", line_width=1,
                        lighting=False)
            text.place(pl, name, (x + SQUARE + text.GAP) / width, y / height,
                       size=text.NAME, h="left")
    pl.view_xy()
    pl.enable_parallel_projection()
    pl.camera.focal_point = (width / 2, height / 2, 0.0)
    pl.camera.position = (width / 2, height / 2, 100.0)
    pl.camera.parallel_scale = height / 2


def save(pl, path: str | Path) -> Path:
    """Write an off-screen plotter's picture to ``path`` (its folder made) and close it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    from microslip.draw.previews import vtk_warnings_off

    try:
        with vtk_warnings_off(), written(path) as tmp:
            pl.screenshot(str(tmp))
    finally:
        pl.close()
    return path


def status_maps(path: str | Path, title: str, panels: Sequence[Sequence[Panel]], *,
                colours: Mapping[int, str] = STATE_COLOURS,
                panel: tuple[int, int] = PANEL) -> Path:
    """A PNG of contact-status maps: rows x columns of panels (``values``: (P,) states),
    the legend of the states below them."""
    rows, cols = len(panels), max(len(r) for r in panels)
    entries = [(STATE_NAMES[s], colours[s]) for s in range(len(STATE_NAMES))]
    width = _panel_width(cols, panel) * cols
    bottom = len(legend_rows([n for n, _ in entries], width)) * LEGEND_ROW + 2 * text.GAP
    pl = _plotter(title, rows, cols, panel, bottom)
    for i, row in enumerate(panels):
        for j, p in enumerate(row):
            pl.subplot(i + 1, j)
            pl.add_mesh(cells(p.grid, state_rgb(p.values, colours), "rgb"), scalars="rgb",
                        rgb=True, show_edges=p.grid.owner is None, edge_color=CELL_EDGES,
                        lighting=False)
            high = _outline(pl, p.grid)
            _view(pl, p.caption, p.grid, (_panel_width(cols, panel), panel[1]), high)
    pl.subplot(rows + 1, 0)
    _legend(pl, entries, width, bottom)
    return save(pl, path)


#: pixels of a colour scale's bar and of its labels above it
BAR, BAR_LABELS = 16, 28


def colour_scale(pl, label: str, width: int, height: int, cmap: str,
                 clim: tuple[float, float], fmt: str = "%.4g") -> None:
    """The colour scale ``cmap`` over ``clim`` across the current renderer's strip
    (``width`` x ``height`` pixels): a horizontal bar with its labels above, its title below
    it (VTK puts a horizontal bar's title among its labels). The bar is a hidden point's:
    the panels draw their own values on the same ``clim``."""
    import pyvista as pv

    carrier = pv.PolyData(np.zeros((1, 3)))
    carrier["scale"] = np.array([clim[0]])
    pl.add_mesh(carrier, scalars="scale", cmap=cmap, clim=clim, opacity=0.0,
                show_scalar_bar=False)
    below = text.measure(label, text.NAME)[1] + 2 * text.GAP
    pl.add_scalar_bar(title="", vertical=False, position_x=0.15, width=0.7,
                      position_y=below / height, height=(BAR + BAR_LABELS) / height,
                      color="black", label_font_size=11, fmt=fmt, n_labels=5)
    text.place(pl, label, 0.5, text.GAP / height, size=text.NAME, v="bottom")


def scale_height(label: str) -> int:
    """Pixels of the strip :func:`colour_scale` draws ``label``'s scale in."""
    return BAR + BAR_LABELS + text.measure(label, text.NAME)[1] + 4 * text.GAP


def load_maps(path: str | Path, title: str, panels: Sequence[Sequence[Panel]], *,
              label: str = "static normal load [N]", cmap: str = "viridis",
              panel: tuple[int, int] = PANEL) -> Path:
    """A PNG of maps of a force per node pair (``values``: (P,) [N]) on one colour scale
    (shared by every panel, so two distributions compare by colour), its bar below."""
    rows, cols = len(panels), max(len(r) for r in panels)
    bottom = scale_height(label)
    pl = _plotter(title, rows, cols, panel, bottom)
    values = np.concatenate([np.ravel(p.values) for row in panels for p in row])
    clim = (float(values.min()), float(values.max()))
    if clim[1] <= clim[0]:
        clim = (clim[0] - 0.5, clim[0] + 0.5)
    for i, row in enumerate(panels):
        for j, p in enumerate(row):
            pl.subplot(i + 1, j)
            pl.add_mesh(cells(p.grid, p.values, "force"), scalars="force", cmap=cmap,
                        clim=clim, show_edges=p.grid.owner is None, edge_color=CELL_EDGES,
                        lighting=False, show_scalar_bar=False)
            high = _outline(pl, p.grid)
            _view(pl, p.caption, p.grid, (_panel_width(cols, panel), panel[1]), high)
    pl.subplot(rows + 1, 0)
    colour_scale(pl, label, _panel_width(cols, panel) * cols, bottom, cmap, clim)
    return save(pl, path)
