"""The blade in prism layers (``blade_layers``) and its root edges graded (``root_size``):
the prisms join the disk's tetrahedra conformally (one body, no more zero modes
free-free, as the
tetrahedra alone), and the graded root is finer where its stress singularity is."""

import numpy as np
import pytest
import scipy.linalg as sla

from microslip import geometry
from microslip.fe import fem

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


def test_a_folded_quadratic_tetrahedron_is_found():
    """The 10-node map of the unit tetrahedron: straight, no fold; one mid-edge node moved
    far enough, det J < 0 at a node (the closed form: with the mid node of edge 0-1 at
    (0.5, 0, t), det J at corner 1 is 1 - 4 t, below zero for t > 1/4)."""
    from microslip.geometry.elements import EDGES, folded_tets

    points = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    tets = np.array([[0, 1, 2, 3]])
    mids = np.array([[0.5 * (points[a] + points[b]) for a, b in EDGES["tetra"]]])
    assert folded_tets(points, tets, mids).size == 0
    bent = mids.copy()
    bent[0, 0, 2] = 0.2  # bent within the element's reach: still one-to-one
    assert folded_tets(points, tets, bent).size == 0
    bent[0, 0, 2] = 0.3  # past a quarter of the edge: folded at corner 1
    assert folded_tets(points, tets, bent).tolist() == [0]


@pytest.mark.slow  # three Gmsh meshes and reductions (~11 s): a convergence study
def test_a_filleted_root_converges_fast_and_its_curved_elements_do_not_fold():
    """A 1.5 mm fillet where the blade meets the platform: no singularity, so the free
    blisk's first bending at ND 12 converges fast in the fillet's element size (measured:
    3159.78, 3156.22, 3155.52 rad/s at 1, 0.5, 0.25 mm: order 2.3); Gmsh's curved mid nodes
    on the tight fillet fold some small tetrahedra, whose edges are then straight (before,
    the assembly refused the mesh)."""
    from microslip.fe import cyclic, eigen

    w = []
    for size in (0.001, 0.0005):
        mesh = geometry.blisk_sector(root_fillet=0.0015, blade_layers=20, blade_size=0.002,
                                     root_size=size)
        body = fem.assemble(mesh, "blisk", STEEL, order=2)  # no InvertedElements
        s = cyclic.sector_model(body, fem.node_set(mesh, "blisk/bore"),
                                mesh.cyclic["blisk"], 12)
        lam, _ = eigen.lowest_modes(s.stiffness, s.mass, 1)
        w.append(float(np.sqrt(lam[0])))
    # the halving changes the frequency by 0.11 % (measured 3.56 rad/s); a sharp corner
    # graded alike by ~0.07 % per halving for ever (order ~0.5-0.9): here the next halving
    # changes it 5x less
    assert 0.0 < w[0] - w[1] < 0.003 * w[1]


def test_a_fillet_that_runs_over_the_platform_is_refused():
    with pytest.raises(geometry.GeometryParameterError, match="root_fillet"):
        geometry.blisk_sector(root_fillet=0.003)


def test_the_root_joint_airfoil_takes_a_fillet_too():
    """1 mm (Gmsh meshes the sliver to the platform's edge at 1 mm, not at 1.5: the
    room is 1.6 mm); its faces graded, its folding curved edges straight: the blade
    assembles."""
    mesh = geometry.root_joint(root_fillet=0.001, root_size=0.0005, blade_layers=6,
                               blade_size=0.004)
    fem.assemble(mesh, "blade", STEEL, order=1)  # no InvertedElements
    with pytest.raises(geometry.GeometryParameterError, match="root_fillet"):
        geometry.root_joint(root_fillet=0.002)
