"""The blade in prism layers (``blade_layers``) and its root edges graded (``root_size``):
the prisms join the disk's tetrahedra conformally (one body, no more zero modes
free-free, as the
tetrahedra alone), and the graded root is finer where its stress singularity is."""

import numpy as np
import pytest
import scipy.linalg as sla

from microslip import geometry
from microslip.pipeline.fe import fem

STEEL = fem.Material(2.0e11, 0.3, 7850.0)

MODELS = {
    "blisk_sector": (lambda **kw: geometry.blisk_sector(
        sectors=6, size=0.03, blade_size=0.006, contact_n_axial=3, contact_n_flank=2, **kw),
        "blisk"),
    "root_joint": (lambda **kw: geometry.root_joint(size=0.02, blade_size=0.008, **kw),
                   "blade"),
}


def _free_modes(mesh, body: str) -> int:
    """Eigenvalues of the free-free body below 1e-4 of its 10th (dense; the zero ones are
    round-off about zero, < 1e-9 of it here)."""
    b = fem.assemble(mesh, body, STEEL, order=1)
    assert b.n_dofs < 6000  # (dense)
    lam = sla.eigh(b.stiffness.toarray(), b.mass.toarray(), eigvals_only=True,
                   subset_by_index=[0, 9])
    return int(np.sum(np.abs(lam) < 1e-4 * lam[9]))


@pytest.mark.parametrize("name", MODELS)
def test_prism_layers_join_the_tetrahedra(name):
    build, body = MODELS[name]
    mesh = build(blade_layers=6)
    wedges = len(mesh.wedges)
    assert wedges > 0 and mesh.element_summary().endswith("wedges")
    owned = mesh.bodies[body]
    assert np.all(owned[-wedges:] == len(mesh.tetrahedra) + np.arange(wedges))
    # 6 layers of a section cut into triangles
    assert wedges % 6 == 0
    # a blade floating apart (a non-conformal interface) would add zero modes of its own
    assert _free_modes(mesh, body) == _free_modes(build(), body) >= 3


@pytest.mark.parametrize("name", MODELS)
def test_the_root_edges_are_graded(name):
    """More nodes within 1 mm of the blade's root plane (x of the platform under it),
    around its section, where root_size asks for 0.5 mm."""
    build, body = MODELS[name]
    coarse, graded = build(blade_layers=6), build(blade_layers=6, root_size=0.0005)
    params = geometry.PARAMETERS[name]()
    x_root = params.r_platform if name == "blisk_sector" else params.x_platform_top

    def near_root(mesh):
        x = mesh.points[mesh.body_nodes(body)]
        ty, tz = 0.5 * np.ptp(x[x[:, 0] > x_root + 0.01, 1:], axis=0)
        return int(np.sum((np.abs(x[:, 0] - x_root) < 1e-3) & (np.abs(x[:, 1]) < ty + 1e-3)
                          & (np.abs(x[:, 2]) < tz + 1e-3)))

    # the blade's section is 6 mm cells coarse; graded to 0.5 mm along its 4 root edges
    assert near_root(graded) > 4 * near_root(coarse)
