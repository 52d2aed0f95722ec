"""Deformed shapes at a map point: the sector (every body, the damper included) and the full
disk, drawn off screen from what results.h5 holds (/surfaces and a map point's shapes/).

A harmonic-balance solution is periodic: each body's surface vertices carry real
coefficients (p, 3, n_coeffs) of the kept orders. A picture shows the vibration, orders >= 1
(the static part is the same at every instant), at the instant of the largest motion of the
sector, scaled so that the largest displacement is a set share of the sector's size. Sector
s of the disk carries harmonic n with the phase exp(i k_n s 2 pi / Ns) of its travelling
wave (k_n: the order's signed nodal diameter) and is turned by s 2 pi / Ns about +z.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from microslip.fourier import Harmonics
from microslip.geometry.mesh import rotation_z
from microslip.results import schema

from . import text
from .maps import colour_scale, save, scale_height

SCALE_SHARE = 0.08  # the largest displacement drawn as this share of the sector's size
INSTANTS = 72  # phases tried for the instant of the largest motion (5 degrees apart)
#: Pixels of one panel of a shape picture (sector, full disk).
PANEL = (800, 700)


@dataclass(frozen=True, eq=False)
class Surface:
    """One body's outer surface: points (p, 3) [m], triangles (t, 3) into them, and whether
    the body is a cyclic sector."""

    body: str
    points: np.ndarray
    triangles: np.ndarray
    cyclic: bool


@dataclass(frozen=True, eq=False)
class Shape:
    """A solution's displacements on the surfaces: body -> (p, 3, n_coeffs) [m]; orders
    and their signed nodal diameters (wave numbers); sectors Ns (0: no disk)."""

    coefficients: Mapping[str, np.ndarray]
    orders: tuple[int, ...]
    wave_numbers: tuple[int, ...]
    sectors: int

    @cached_property
    def _phasors(self) -> dict[str, dict[int, np.ndarray]]:
        h = Harmonics(self.orders)
        return {b: {n: x for n, x in h.to_complex(c).items() if n > 0}
                for b, c in self.coefficients.items()}

    def phasors(self, body: str) -> dict[int, np.ndarray]:
        """{order n >= 1: (p, 3) complex amplitude X_n}: u(t) = sum_n Re(X_n e^(i n w t))."""
        return self._phasors[body]

    def vibration(self, body: str, theta: float, sector: int = 0) -> np.ndarray:
        """(p, 3) vibration [m] of the body in copy ``sector`` of the disk at phase
        ``theta`` = w t, in the disk's frame (the copy turned by sector 2 pi / Ns)."""
        phi = 2 * np.pi / self.sectors if self.sectors else 0.0
        waves = dict(zip(self.orders, self.wave_numbers))
        u = np.zeros(self.coefficients[body].shape[:2])
        for n, x in self.phasors(body).items():
            u += np.real(x * np.exp(1j * (waves[n] * sector * phi + n * theta)))
        return u @ rotation_z(sector * phi).T

    def instant(self) -> float:
        """The phase w t in [0, 2 pi) of the largest motion of sector 0 (sum over every
        surface vertex of |u|^2), among INSTANTS phases."""
        theta = 2 * np.pi * np.arange(INSTANTS) / INSTANTS
        energy = [sum(float(np.sum(self.vibration(b, t) ** 2)) for b in self.coefficients)
                  for t in theta]
        return float(theta[int(np.argmax(energy))])


def read(f, point) -> tuple[dict[str, Surface], Shape] | None:
    """The surfaces of a results file and a map point's shape; None if either is missing."""
    if schema.SURFACES not in f or schema.SHAPES not in point:
        return None
    sg, pg = f[schema.SURFACES], point[schema.SHAPES]
    surfaces = {b: Surface(b, g["points"][()], g["triangles"][()], bool(g.attrs["cyclic"]))
                for b, g in sg.items() if b in pg}
    shape = Shape({b: pg[b][()] for b in surfaces},
                  tuple(int(x) for x in np.atleast_1d(pg.attrs["orders"])),
                  tuple(int(x) for x in np.atleast_1d(pg.attrs["wave_numbers"])),
                  int(sg.attrs["sectors"]))
    return surfaces, shape


def scale(surfaces: Mapping[str, Surface], shape: Shape, theta: float) -> float:
    """The factor that draws the largest displacement of sector 0 at ``theta`` as
    SCALE_SHARE of the sector's largest extent."""
    size = np.ptp(np.concatenate([s.points for s in surfaces.values()]), axis=0).max()
    u = max(float(np.abs(shape.vibration(b, theta)).max()) for b in surfaces)
    return SCALE_SHARE * size / u if u > 0 else 1.0


def _polydata(s: Surface, points: np.ndarray, u: np.ndarray | None = None):
    """The surface's triangles over ``points``; with ``u``, its magnitude [mm] as a point
    array "|u| [mm]"."""
    import pyvista as pv

    faces = np.hstack([np.full((len(s.triangles), 1), 3), s.triangles]).ravel()
    mesh = pv.PolyData(points, faces)
    if u is not None:
        mesh["|u| [mm]"] = 1e3 * np.linalg.norm(u, axis=1)
    return mesh


def sector_mesh(surfaces: Mapping[str, Surface], shape: Shape, theta: float, factor: float,
                sector: int = 0):
    """Copy ``sector`` of every body, deformed by ``factor`` x its vibration at ``theta``,
    as one PolyData with the point array "|u| [mm]" (the true, unscaled magnitude)."""
    import pyvista as pv

    phi = 2 * np.pi / shape.sectors if shape.sectors else 0.0
    parts = []
    for b, s in surfaces.items():
        u = shape.vibration(b, theta, sector)
        parts.append(_polydata(s, s.points @ rotation_z(sector * phi).T + factor * u, u))
    return pv.merge(parts) if len(parts) > 1 else parts[0]


def draw(path: str | Path, title: str, surfaces: Mapping[str, Surface], shape: Shape,
         panel: tuple[int, int] = PANEL) -> Path:
    """A PNG: the deformed sector (left) and full disk (right, when the model is cyclic) on
    one colour scale of |u| [mm], the undeformed sector in light grey behind."""
    import pyvista as pv

    from microslip.draw.previews import axial_view, title_strip, vtk_warnings_off

    theta = shape.instant()
    factor = scale(surfaces, shape, theta)
    disk = shape.sectors > 0
    cols = 2 if disk else 1
    width = panel[0] * cols
    title, top = text.strip(f"{title}\nvibration (orders >= 1) at the instant of largest "
                            f"motion, drawn x {factor:.3g}", width, text.TITLE)
    label = "displacement [mm] (true scale)"
    bottom = scale_height(label)
    waves = ", ".join(f"order {n}: ND {k:+d}" for n, k in zip(shape.orders,
                                                               shape.wave_numbers) if n)
    captions, heights = zip(*(text.strip(c, panel[0], text.CAPTION) for c in
                              ["sector, every body (undeformed in grey)",
                               f"full disk, {shape.sectors} sectors ({waves})"][:cols]))
    high = max(heights)
    copies = [sector_mesh(surfaces, shape, theta, factor, s)
              for s in range(max(shape.sectors, 1))]
    sector = copies[0]
    values = sector["|u| [mm]"]
    clim = (0.0, float(values.max()) if values.max() > 0 else 1.0)
    with vtk_warnings_off():  # title, the captions (a row of their own: a model's view
        # may reach its panel's top), the panels, the colour scale
        pl = pv.Plotter(off_screen=True,
                        window_size=[width, top + high + panel[1] + bottom],
                        shape=(4, cols), row_weights=[top, high, panel[1], bottom],
                        groups=[(0, np.s_[:]), (3, np.s_[:])], border=False)
    title_strip(pl, title)
    for j, caption in enumerate(captions):
        pl.subplot(1, j)
        text.place(pl, caption, 0.5, 0.5, size=text.CAPTION)
    pl.subplot(2, 0)
    for s in surfaces.values():
        pl.add_mesh(_polydata(s, s.points), color="lightgrey", opacity=0.25)
    pl.add_mesh(sector, scalars="|u| [mm]", cmap="plasma", clim=clim, show_scalar_bar=False)
    points = np.concatenate([s.points for s in surfaces.values()])
    axial_view(pl, points.mean(axis=0), np.ptp(points, axis=0).max())
    pl.reset_camera()
    if disk:
        pl.subplot(2, 1)
        pl.add_mesh(pv.merge(copies), scalars="|u| [mm]", cmap="plasma", clim=clim,
                    show_scalar_bar=False)
        pl.view_xy()
        pl.camera.elevation = -25.0
        pl.reset_camera()
    pl.subplot(3, 0)
    colour_scale(pl, label, width, bottom, "plasma", clim, "%.3g")
    return save(pl, path)
