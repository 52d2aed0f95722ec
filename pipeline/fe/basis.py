"""The scikit-fem elements, meshes and quadrature rules of each solid shape a mesh holds.

Shape (corner order: ``geometry.elements``) -> linear / quadratic element:

* ``tetra``: ElementTetP1 / ElementTetP2 (10 nodes), on MeshTet1;
* ``hexahedron``: ElementHex1 / ElementHexS2 (20-node serendipity), on MeshHex1;
* ``wedge``: ElementWedge1 / :class:`ElementWedgeS2` (15-node serendipity, written here:
  scikit-fem has no quadratic wedge), on MeshWedge1.

The quadratic elements' extra DOFs are one per edge (its midpoint), so bodies that mix
shapes share them edge by edge. Quadrature is Gauss, exact for the stiffness and mass
integrands of undistorted elements: tetrahedra as before (P1: 0 / 2, P2: 2 / 4); a
hexahedron or wedge of order p integrates degree 2p per direction (the products of two
shape functions or of two gradients of a tensor-product element). The wedge's rule is a
triangle rule times a Gauss line rule, built here: scikit-fem 12's own rule for its
reference wedge is wrong (its weights sum to 1/4, not the volume 1/2, and some points
lie outside the element; test_elements checks ours).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import skfem as fe
from numpy import ndarray
from skfem.element.element_h1 import ElementH1
from skfem.io.meshio import INV_HEX_MAPPING
from skfem.mapping import MappingIsoparametric
from skfem.quadrature import get_quadrature_line, get_quadrature_tri
from skfem.refdom import RefWedge


class ElementWedgeS2(ElementH1):
    """The 15-node serendipity wedge: corners, then the midpoints of the 9 edges in
    RefWedge's edge order. With L = (1 - x - y, x, y) the triangle's area coordinates
    and s = 2 z - 1 in [-1, 1] along the axis (s_i = -1 below, +1 above):

    * corner i: L_i (2 L_i - 1)(1 + s_i s) / 2 - L_i (1 - s^2) / 2;
    * mid-edge of the triangle edge i-j: 2 L_i L_j (1 + s_i s);
    * mid-edge of the axial edge at i: L_i (1 - s^2).
    """

    nodal_dofs = 1
    edge_dofs = 1
    maxdeg = 4
    dofnames = ["u", "u"]
    refdom = RefWedge
    doflocs = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0],
                        [0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0],
                        [0.5, 0.0, 0.0], [0.5, 0.5, 0.0], [0.0, 0.5, 0.0],
                        [0.5, 0.0, 1.0], [0.5, 0.5, 1.0], [0.0, 0.5, 1.0],
                        [0.0, 0.0, 0.5], [1.0, 0.0, 0.5], [0.0, 1.0, 0.5]])
    # (triangle corner, its pair or -1, side of the axis: -1 below, +1 above, 0 axial edge)
    _NODES = [(0, -1, -1), (1, -1, -1), (2, -1, -1), (0, -1, 1), (1, -1, 1), (2, -1, 1),
              (0, 1, -1), (1, 2, -1), (0, 2, -1), (0, 1, 1), (1, 2, 1), (0, 2, 1),
              (0, -1, 0), (1, -1, 0), (2, -1, 0)]
    _DL = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])  # grad L_i in (x, y)

    def lbasis(self, X, i):
        if not 0 <= i < 15:
            self._index_error()
        x, y, z = X
        s = 2.0 * z - 1.0
        L = (1.0 - x - y, x, y)
        a, b, side = self._NODES[i]
        La, dLa = L[a], self._DL[a]
        zero = 0.0 * x
        if b >= 0:  # a triangle edge's midpoint
            Lb, dLb = L[b], self._DL[b]
            axis = 1.0 + side * s
            phi = 2.0 * La * Lb * axis
            gx = 2.0 * axis * (Lb * dLa[0] + La * dLb[0])
            gy = 2.0 * axis * (Lb * dLa[1] + La * dLb[1])
            gs = 2.0 * La * Lb * side
        elif side == 0:  # an axial edge's midpoint
            phi = La * (1.0 - s * s)
            gx, gy, gs = (1.0 - s * s) * dLa[0], (1.0 - s * s) * dLa[1], -2.0 * s * La
        else:  # a corner
            axis = 1.0 + side * s
            phi = 0.5 * La * (2.0 * La - 1.0) * axis - 0.5 * La * (1.0 - s * s)
            dphi_dl = 0.5 * (4.0 * La - 1.0) * axis - 0.5 * (1.0 - s * s)
            gx, gy = dphi_dl * dLa[0], dphi_dl * dLa[1]
            gs = 0.5 * La * (2.0 * La - 1.0) * side + La * s
        return phi, np.array([gx + zero, gy + zero, 2.0 * gs + zero])  # d/dz = 2 d/ds


def wedge_quadrature(degree: int) -> tuple[np.ndarray, np.ndarray]:
    """(3, q) points and (q,) weights on the reference wedge (triangle (0,0) (1,0) (0,1)
    in x, y times [0, 1] in z), exact for polynomials of ``degree`` in (x, y) and in z."""
    Xt, Wt = get_quadrature_tri(degree)
    Xl, Wl = get_quadrature_line(degree)
    points = np.vstack([np.repeat(Xt, Xl.shape[1], axis=1), np.tile(Xl[0], Xt.shape[1])])
    return points, np.repeat(Wt, Xl.shape[1]) * np.tile(Wl, Xt.shape[1])


@dataclass(repr=False)
class MeshHexS2(fe.MeshHex1):
    """Hexahedra whose geometry is the 20-node serendipity map (corners and mid-edge nodes:
    ``doflocs`` holds the vertices, then one node per edge in the mesh's edge order)."""

    doflocs: ndarray = field(default_factory=lambda: fe.MeshHex1().doflocs)
    elem: type = fe.ElementHexS2
    affine: bool = False


@dataclass(repr=False)
class MeshWedgeS2(fe.MeshWedge1):
    """Wedges whose geometry is the 15-node serendipity map (as :class:`MeshHexS2`)."""

    doflocs: ndarray = field(default_factory=lambda: fe.MeshWedge1().doflocs)
    elem: type = ElementWedgeS2
    affine: bool = False


@dataclass(frozen=True)
class Shape:
    """How one solid shape is assembled: scikit-fem mesh class, the permutation from the
    mesh's corner order to scikit-fem's, the element of each order and the quadrature
    degrees (stiffness, mass) of each order."""

    mesh: type
    to_skfem: tuple[int, ...]
    linear: type
    quadratic: type
    degrees: dict[int, tuple[int, int]]
    curved: type

    def curved_mapping(self, mesh: fe.Mesh, mid_edge: np.ndarray) -> MappingIsoparametric:
        """The isoparametric map of ``mesh``'s elements through their quadratic geometry:
        ``mid_edge`` (n_edges, 3) [m] the mid-edge node of each of ``mesh.edges``."""
        geometry = self.curved(np.hstack([mesh.doflocs, np.asarray(mid_edge).T]), mesh.t)
        return MappingIsoparametric(geometry, geometry.elem(), geometry.bndelem)

    def element(self, order: int) -> fe.ElementVector:
        """The vector (3-component) element of ``order`` (1 or 2)."""
        return fe.ElementVector(self.quadratic() if order == 2 else self.linear())

    def basis(self, mesh: fe.Mesh, order: int, degree: int,
              mapping: MappingIsoparametric | None = None) -> fe.CellBasis:
        """Basis of ``order`` on a scikit-fem mesh of this shape, integrating ``degree``;
        through ``mapping`` (the curved geometry's) if given, else the corner map."""
        if self.mesh is fe.MeshWedge1:
            return fe.Basis(mesh, self.element(order), mapping=mapping,
                            quadrature=wedge_quadrature(degree))
        return fe.Basis(mesh, self.element(order), mapping=mapping, intorder=degree)


SHAPES = {
    "tetra": Shape(fe.MeshTet1, (0, 1, 2, 3), fe.ElementTetP1, fe.ElementTetP2,
                   {1: (0, 2), 2: (2, 4)}, fe.MeshTet2),
    "hexahedron": Shape(fe.MeshHex1, tuple(INV_HEX_MAPPING[:8]), fe.ElementHex1,
                        fe.ElementHexS2, {1: (2, 2), 2: (4, 4)}, MeshHexS2),
    "wedge": Shape(fe.MeshWedge1, (0, 1, 2, 3, 4, 5), fe.ElementWedge1, ElementWedgeS2,
                   {1: (2, 2), 2: (4, 4)}, MeshWedgeS2),
}
