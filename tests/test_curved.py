"""Curved quadratic geometry kept as the deck has it: a quarter ring in tet10, hex20 and
wedge15, its mid-edge nodes on the arcs, written as CalculiX, Nastran, Gmsh and Ansys write
it, read back curved; its mass, polar inertia and centrifugal load against their closed
forms, and its free vibration against a fine straight-edged reference, where straight edges
fail both."""

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from exports import write

from microslip.fe import fem
from microslip.geometry.imported import import_mesh
from microslip.geometry.structured import annulus

STEEL = fem.Material(2.1e11, 0.3, 7850.0)
R0, R1, WIDTH, SECTORS = 0.09, 0.11, 0.01, 4  # [m]: a quarter of a ring
ANGLE = 2 * np.pi / SECTORS


def _ring(shape: str, cells: tuple[int, int, int], curved: bool):
    return annulus(shape, SECTORS, cells, radii=(R0, R1), width=WIDTH, curved=curved)


def _read(mesh, path):
    """``mesh`` written quadratic to ``path`` and imported again (the body "ring")."""
    suffix = path.suffix
    bodies = {"ring": {".bdf": "pid1", ".cdb": "mat1"}.get(suffix, "ring")}
    return import_mesh(write(mesh, path, quadratic=True), bodies=bodies).mesh


def _rigid_measures(body: fem.BodyModel, mesh) -> tuple[float, float, float]:
    """(mass [kg], polar inertia about z [kg m^2], centrifugal resultant along x per
    Omega^2 [kg m]) from the FE matrices: u^T M u of a rigid translation and rotation
    (interpolated exactly by isoparametric elements: nodal values at the geometric nodes),
    and the x components of the centrifugal load summed."""
    xyz = np.vstack([body.points, mesh.mid_edge_points(body.edges)])
    dofs = np.vstack([body.node_dofs, body.edge_dofs])
    shift, turn = np.zeros(body.n_dofs), np.zeros(body.n_dofs)
    shift[dofs[:, 0]] = 1.0
    turn[dofs[:, 0]], turn[dofs[:, 1]] = -xyz[:, 1], xyz[:, 0]
    load = fem.centrifugal_load(body)
    return (shift @ body.mass @ shift, turn @ body.mass @ turn, load[dofs[:, 0]].sum())


# the closed forms of the annular sector of angle phi about +x
MASS = STEEL.density * WIDTH * ANGLE * (R1**2 - R0**2) / 2
INERTIA = STEEL.density * WIDTH * ANGLE * (R1**4 - R0**4) / 4
RESULTANT = STEEL.density * WIDTH * (R1**3 - R0**3) / 3 * 2 * np.sin(ANGLE / 2)


@pytest.mark.parametrize("suffix", [".inp", ".bdf", ".msh", ".cdb"])
@pytest.mark.parametrize("shape", ["tetra", "hexahedron", "wedge"])
def test_curved_deck_keeps_its_arcs(tmp_path, shape, suffix):
    errors = {}
    for curved in (True, False):
        mesh = _ring(shape, (1, 8, 1), curved)
        read = _read(mesh, tmp_path / f"ring{suffix}")
        body = fem.assemble(read, "ring", STEEL)
        if curved:  # the arcs come back as written (.bdf keeps 11 digits of 0.1 m)
            assert len(read.curved_edges) > 0
            assert np.abs(read.mid_edge_points(body.edges)
                          - mesh.mid_edge_points(body.edges)).max() < 1e-11
        else:
            assert len(read.curved_edges) == 0
        measured = np.array(_rigid_measures(body, read))
        errors[curved] = np.abs(measured / [MASS, INERTIA, RESULTANT] - 1)
    # Eight quadratic arcs over 90 degrees follow the circle to ~3e-6 of these integrals
    # (measured 3.1e-6 mass, 6.2e-6 inertia); the polygon of their chords misses them by
    # dtheta^2 / 6 = 6.4e-3 (mass) and twice that (inertia): 3e-5 separates the two
    assert errors[True].max() < 3e-5
    assert errors[False].min() > 3e-3


def _linear_field(body: fem.BodyModel, mesh, gradient: np.ndarray) -> np.ndarray:
    """(n_dofs,) the displacement u(x) = gradient @ x at every geometric node: interpolated
    exactly by isoparametric elements (x itself is), so u^T K u is exact but for the
    geometry."""
    xyz = np.vstack([body.points, mesh.mid_edge_points(body.edges)])
    dofs = np.vstack([body.node_dofs, body.edge_dofs])
    u = np.zeros(body.n_dofs)
    u[dofs] = xyz @ gradient.T
    return u


@pytest.mark.parametrize("shape", ["tetra", "hexahedron", "wedge"])
def test_curved_stiffness_passes_the_patch_test(shape):
    """u^T K u of a uniform strain (a linear field) is sigma : epsilon times the volume: the
    stiffness integrated over the curved geometry, exact where straight edges lose the
    chords' segments."""
    gradient = np.array([[1.0, 0.3, -0.2], [0.1, -0.5, 0.4], [0.2, 0.6, 0.7]]) * 1e-4
    strain = 0.5 * (gradient + gradient.T)
    E, nu = STEEL.youngs_modulus, STEEL.poisson_ratio
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    exact = (lam * np.trace(strain) ** 2 + 2 * mu * np.sum(strain**2)) * MASS / STEEL.density
    error = {}
    for curved in (True, False):
        mesh = _ring(shape, (1, 8, 1), curved)
        body = fem.assemble(mesh, "ring", STEEL)
        u = _linear_field(body, mesh, gradient)
        error[curved] = abs(u @ body.stiffness @ u / exact - 1)
    # the volume's error: 3.1e-6 curved (the arcs' own), 6.4e-3 with the chords (as the mass)
    assert error[True] < 3e-5 < 3e-3 < error[False]


def _free_frequencies(mesh, count: int = 3) -> np.ndarray:
    """The first ``count`` elastic natural frequencies [Hz] of the free body."""
    body = fem.assemble(mesh, "ring", STEEL)
    lam = spla.eigsh(body.stiffness, count + 6, body.mass, sigma=-1e4, which="LM")[0]
    return np.sqrt(np.sort(lam)[6:]) / (2 * np.pi)


def test_curved_hexahedra_converge_where_straight_edges_stall(tmp_path):
    """A free quarter ring (no clamp, whose corner singularity would slow every mesh alike):
    curved hex20 along the arc against a straight-edged reference refined 4x further and
    extrapolated (the straight edges' error is O(h^2): the chords' sagitta)."""
    fine = [_free_frequencies(_ring("hexahedron", (1, n, 1), False)) for n in (64, 128)]
    reference = fine[1] + (fine[1] - fine[0]) / 3  # Richardson, order 2
    # (the extrapolation's own size: 2.4e-5 of the frequencies, the reference's uncertainty)
    assert np.abs((fine[1] - fine[0]) / 3 / reference).max() < 5e-5
    error = {}
    for curved in (True, False):
        error[curved] = [np.abs(_free_frequencies(_read(_ring("hexahedron", (1, n, 1),
                                                              curved), tmp_path / "r.inp"))
                                / reference - 1).max() for n in (16, 32)]
    # measured: curved 5.4e-4 -> 3.8e-5 (ratio 14: the elements' own h^4), straight
    # 1.9e-3 -> 4.1e-4 (ratio 4.7: the chords' h^2)
    assert error[True][1] < 1e-4 < 3e-4 < error[False][1]
    assert error[True][0] / error[True][1] > 8 > 6 > error[False][0] / error[False][1]


@pytest.mark.parametrize("shape", ["tetra", "hexahedron", "wedge"])
def test_a_mid_node_that_folds_its_element_is_one_line(shape):
    """A mid-edge node pushed across its element (a deck's typo, a mesher's bend): the
    isoparametric map turns the element inside out, which no straight-edged check sees; it
    is refused by name, from the assembly and from the reduction stage as an input fault."""
    import dataclasses

    from microslip.app.structure import reduce_structure
    from microslip.case import InputError

    mesh = _ring(shape, (1, 8, 1), True)
    nodes = mesh.edge_nodes.copy()
    # three radial thicknesses off the edge: past every neighbour's far face
    nodes[0] = nodes[0] + 3 * (R1 - R0) * np.array([1.0, 0.0, 0.0])
    bad = dataclasses.replace(mesh, edge_nodes=nodes)
    fem.assemble(mesh, "ring", STEEL)  # the arcs as they are: fine
    with pytest.raises(fem.InvertedElements, match=rf"curved {shape} element\(s\) turned"):
        fem.assemble(bad, "ring", STEEL)
    table = {"order": 2, "modes": 4, "bodies": {"ring": {"clamped": ["cyclic/left"],
                                                          "masters": ["cyclic/right"]}}}
    with pytest.raises(InputError, match="body 'ring': .* inside out"):
        reduce_structure(dataclasses.replace(bad, cyclic={}), table, None,
                         progress=lambda s: None)


def test_the_full_disk_keeps_every_copys_arcs():
    """A curved ring sector copied round the disk: each copy's mid nodes turned with it, so
    the whole ring's mass is Ns times the sector's (to round-off) and the closed form's to
    the arcs' 3e-6 (the chords would lose 6.4e-3)."""
    import dataclasses

    from microslip import geometry
    from microslip.geometry._gmsh import pair_cyclic

    sector = _ring("hexahedron", (1, 8, 1), True)
    left, right = sector.node_sets["cyclic/left"], sector.node_sets["cyclic/right"]
    sector = dataclasses.replace(sector, cyclic={"ring": pair_cyclic(sector.points, left,
                                                                      right, SECTORS)})
    disk = geometry.full_disk(sector)
    # the annulus lists every edge (straight ones too): a face's are shared by two copies
    on_face = np.isin(sector.curved_edges, left).all(axis=1).sum()
    assert len(disk.curved_edges) == SECTORS * (len(sector.curved_edges) - on_face)
    masses = []
    for mesh in (sector, disk):
        body = fem.assemble(mesh, "ring", STEEL)
        shift = np.zeros(body.n_dofs)
        shift[np.vstack([body.node_dofs, body.edge_dofs])[:, 0]] = 1.0
        masses.append(shift @ body.mass @ shift)
    assert masses[1] == pytest.approx(SECTORS * masses[0], rel=1e-12)
    assert masses[1] == pytest.approx(SECTORS * MASS, rel=3e-5)
