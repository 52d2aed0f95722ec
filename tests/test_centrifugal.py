"""Centrifugal load (issue 11): the consistent FE load per unit Omega^2, its Craig-Bampton
projection, and its place in the reduced model and the model cache."""

import dataclasses

import h5py
import numpy as np
import pytest
import scipy.sparse.linalg as spla

from microslip import geometry
from microslip.fe import bodies, craig_bampton, cyclic, eigen, fem, linalg, modal, reduced_model
from microslip.geometry.mesh import signed_volumes

STEEL = fem.Material(2.1e11, 0.3, 7800.0)
NS = 6
R_IN, R_OUT, WIDTH = 0.05, 0.12, 0.01
DAMPER_PATCHES = ["contact/damper_left/damper", "contact/damper_right/damper"]


@pytest.fixture(scope="module")
def disk_mesh():
    return geometry.annular_sector(sectors=NS, r_inner=R_IN, r_outer=R_OUT, width=WIDTH,
                                   size=0.015)


@pytest.fixture(scope="module")
def blisk_mesh():
    return geometry.blisk_sector()


def _rim_masters(mesh):
    """Rim nodes off the eliminated right cyclic face."""
    return np.setdiff1d(fem.node_set(mesh, "disk/rim"), mesh.cyclic["disk"].right)


def _components(body):
    """(N,) Cartesian direction 0/1/2 of every DOF (vertex and P2 edge DOFs)."""
    comp = np.zeros(body.n_dofs, dtype=np.int64)
    comp[body.node_dofs.ravel()] = np.tile([0, 1, 2], len(body.nodes))
    if len(body.edge_dofs):
        comp[body.edge_dofs.ravel()] = np.tile([0, 1, 2], len(body.edge_dofs))
    return comp


def _dof_locations(body, mesh):
    """(N, 3) location of every DOF: the vertex, or the edge's mid node (P2: on the arc
    where the edge is curved)."""
    locs = np.zeros((body.n_dofs, 3))
    locs[body.node_dofs.ravel()] = np.repeat(body.points, 3, axis=0)
    if len(body.edge_dofs):
        locs[body.edge_dofs.ravel()] = np.repeat(mesh.mid_edge_points(body.edges), 3, axis=0)
    return locs


def _straight(mesh):
    """The mesh with straight edges (its tets' closed-form moments are exact for it)."""
    return dataclasses.replace(mesh, curved_edges=np.empty((0, 2), np.int64),
                               edge_nodes=np.empty((0, 3)))


def _moments(mesh, body_name, density):
    """Mass-weighted integrals over the body's straight-sided tets, in closed form per tet:
    first moments rho int x_i dV (3,) and second moments rho int x_i x_j dV (3, 3), with
    int x_i x_j dV = V / 20 (sum_a x_ai x_aj + (sum_a x_ai)(sum_a x_aj)) on a tet."""
    tets = mesh.body_cells(body_name)["tetra"]
    p = mesh.points[tets]  # (m, 4, 3)
    V = np.abs(signed_volumes(mesh.points, tets))
    first = density * np.einsum("e,ei->i", V, p.mean(axis=1))
    s = p.sum(axis=1)
    second = density * np.einsum("e,eij->ij", V / 20.0,
                                 np.einsum("eai,eaj->eij", p, p) + s[:, :, None] * s[:, None, :])
    return first, second


def _largest_arc_step(mesh, name, radius):
    """Largest angle [rad] between consecutive nodes of a cylindrical node set on one z level:
    the largest chord angle of the faceted boundary."""
    nodes = fem.node_set(mesh, name)
    pts = mesh.points[nodes]
    top = pts[np.isclose(pts[:, 2], pts[:, 2].max())]
    assert np.allclose(np.hypot(top[:, 0], top[:, 1]), radius, rtol=1e-9)
    return float(np.diff(np.sort(np.arctan2(top[:, 1], top[:, 0]))).max())


# --- the FE load ------------------------------------------------------------------------


def _resultant(mesh, order):
    """(3,) the sums of the x / y / z components of the disk's centrifugal load [kg m]."""
    body = fem.assemble(mesh, "disk", STEEL, order)
    f = fem.centrifugal_load(body)
    assert f.shape == (body.n_dofs,) and f.dtype == np.float64
    comp = _components(body)
    return np.array([f[comp == k].sum() for k in range(3)])


@pytest.mark.parametrize("order", [1, 2])
def test_resultant_of_the_annular_sector(disk_mesh, order):
    """Sum of the x / y / z components = m Omega^2 r_cg per unit Omega^2."""
    # Straight-edged, against its own mass and first moment (exact per tet): the shape
    # functions sum to one (P1 and P2), so the sums are the integral of rho (x, y, 0), exact
    # but for the round-off of sums over ~1000 entries (measured 3e-16 of the x resultant;
    # 1e-12 allows any summation order).
    F = _resultant(_straight(disk_mesh), order)
    first, _ = _moments(disk_mesh, "disk", STEEL.density)
    assert F[2] == 0.0  # no axial body force at all
    np.testing.assert_allclose(F[:2], first[:2], rtol=0, atol=1e-12 * first[0])
    # Against the hand closed form of the (curved) annular sector, centroid on the x axis:
    #   m r_cg = rho w (r_o^3 - r_i^3) / 3 * 2 sin(phi / 2).
    # Chords instead of arcs: a chord over the angle d scales the first moment of its fan
    # (origin to arc) by cos^2(d / 2); the rim loses moment, the bore gains some. So their
    # relative error is at most r_o^3 sin^2(d_max / 2) / (r_o^3 - r_i^3), d_max the largest
    # chord angle on bore and rim (15 deg here: bound 1.8e-2, measured 1.2e-3). The mesh as
    # Gmsh curves it (its mid nodes on the arcs) is within d^4: measured 1e-6 (a wrong
    # density, factor or axis would be off by O(1)).
    phi = 2 * np.pi / NS
    closed = STEEL.density * WIDTH * (R_OUT**3 - R_IN**3) / 3 * 2 * np.sin(phi / 2)
    d_max = max(_largest_arc_step(disk_mesh, "disk/bore", R_IN),
                _largest_arc_step(disk_mesh, "disk/rim", R_OUT))
    bound = R_OUT**3 * np.sin(d_max / 2) ** 2 / (R_OUT**3 - R_IN**3)
    assert abs(1.0 - F[0] / closed) < bound
    curved = _resultant(disk_mesh, order)
    assert abs(1.0 - curved[0] / closed) < 1e-2 * bound
    # y: the sector is symmetric about y = 0, the mesh only nearly: ~1e-10 N s^2 against
    # 4e-2 for x (the mesh's own first moment above matches it exactly).
    assert abs(F[1]) < 1e-6 * closed and abs(curved[1]) < 1e-6 * closed


@pytest.mark.parametrize("order", [1, 2])
def test_load_is_the_mass_times_the_position_field(blisk_mesh, order):
    """(x, y, 0) is linear, so P1 and P2 interpolate it exactly on straight-edged tets and
    f = M g (g its DOF values): an independent check of quadrature and of the DOF numbering
    of the rebuilt basis. On the curved mesh (Gmsh's arcs), P2 still interpolates it (the
    isoparametric map is P2) but neither integral is exact any more."""
    for name in ("damper", "blisk"):
        for mesh in (_straight(blisk_mesh), blisk_mesh):
            body = fem.assemble(mesh, name, STEEL, order)
            f = fem.centrifugal_load(body)
            locs, comp = _dof_locations(body, mesh), _components(body)
            g = np.where(comp < 2, locs[np.arange(body.n_dofs), np.minimum(comp, 1)], 0.0)
            if mesh is not blisk_mesh:
                # Both integrals exact (intorder p + 1 for the load, 2p for M); differences
                # are sum round-off over a row (~10-100 terms; measured <= 2e-15 of the
                # largest entry).
                np.testing.assert_allclose(f, body.mass @ g, rtol=0,
                                           atol=1e-13 * np.abs(f).max())
            elif order == 2:
                # Curved tets: the integrands gain det J's degree 3, the rules stay those of
                # straight tets (as CalculiX's and Abaqus' do): measured 5.2e-6 of the
                # largest entry, and the resultants (partition of unity) still exact
                # (1.2e-15)
                d = f - body.mass @ g
                assert np.abs(d).max() < 2e-5 * np.abs(f).max()
                assert np.abs(d[comp == 0].sum()) < 1e-12 * np.abs(f[comp == 0].sum())


# --- the reduced load ---------------------------------------------------------------------


def _damper_spec(n_modes=5):
    return bodies.BodySpec(body="damper", material=STEEL, patches=("damper_left",
                                                                      "damper_right"),
                              n_modes=n_modes)


def _clamped_reactions(K, f, m_idx):
    """Master reactions of the unreduced static problem with the masters held at zero:
    K_ss u_s = f_s, r_m = K_ms u_s - f_m (the force the support puts on the body)."""
    n = K.shape[0]
    s_idx = np.setdiff1d(np.arange(n), m_idx)
    K = K.tocsr()
    u_s = spla.spsolve(K[s_idx][:, s_idx].tocsc(), f[s_idx])
    return K[m_idx][:, s_idx] @ u_s - f[m_idx]


def test_reactions_on_clamped_masters_are_exact_damper(blisk_mesh):
    """Damper (no cyclic symmetry, no clamp) held on its contact patches. Reduced: q_m = 0,
    the master rows give r = -(f_m + Psi^H f_s); unreduced: solve the slaves."""
    red = bodies.reduce_body(blisk_mesh, _damper_spec(), [0])[0]
    load = red.loads["centrifugal"]
    assert load.shape == (red.size,) and load.dtype == np.float64
    body = fem.assemble(blisk_mesh, "damper", STEEL)
    f = fem.centrifugal_load(body)
    masters = red.master_nodes
    assert np.array_equal(np.sort(masters), fem.node_sets_union(blisk_mesh, DAMPER_PATCHES))
    r_full = _clamped_reactions(body.stiffness, f, body.dofs_of_nodes(masters).ravel())
    r_red = -load[red.dof_index(masters).ravel()]
    # Psi = -K_ss^-1 K_sm makes Psi^H f_s = -K_ms u_s: the same numbers, by two sparse
    # factorizations (CB's and SciPy's). cond(K_ss) = 7e2 here, so round-off is ~1e-13 at
    # worst; measured 4e-15 of the largest reaction. Any truncation error (e.g. a missing
    # Psi^H f_s term) would be O(1).
    np.testing.assert_allclose(r_red, r_full, rtol=0, atol=1e-11 * np.abs(r_full).max())
    # The support carries the whole load: the reactions balance the resultant (exact per-tet
    # moments against sums of the projection: round-off, measured 1e-16).
    first, _ = _moments(blisk_mesh, "damper", STEEL.density)
    comp = np.tile([0, 1, 2], len(masters))
    np.testing.assert_allclose([r_red[comp == k].sum() for k in range(3)],
                               -np.array([first[0], first[1], 0.0]),
                               rtol=0, atol=1e-9 * np.abs(first).max())


def test_reactions_on_clamped_masters_are_exact_cyclic_nd0(disk_mesh):
    """Annular sector at ND 0 (bore clamped, cyclic faces coupled): the same exactness after
    the cyclic expansion (f_free = P^H f)."""
    rim = fem.node_set(disk_mesh, "disk/rim")
    theta = np.arctan2(disk_mesh.points[rim, 1], disk_mesh.points[rim, 0])
    masters = rim[np.abs(theta) < np.pi / NS / 3]
    body = fem.assemble(disk_mesh, "disk", STEEL)
    sector = cyclic.sector_model(body, fem.node_set(disk_mesh, "disk/bore"),
                                 disk_mesh.cyclic["disk"], 0)
    f = fem.centrifugal_load(body)
    red = craig_bampton.craig_bampton(sector, masters, 8, loads={"centrifugal": f})
    load = red.loads["centrifugal"]
    assert load.dtype == np.float64
    f_free = sector.expansion.T @ f
    r_full = _clamped_reactions(sector.stiffness, f_free, sector.free_index(masters).ravel())
    r_red = -load[red.dof_index(masters).ravel()]
    # As for the damper: two factorizations of K_ss (cond 3e4: round-off ~1e-12 at worst),
    # measured 7e-15.
    np.testing.assert_allclose(r_red, r_full, rtol=0, atol=1e-11 * np.abs(r_full).max())


def test_free_free_damper_rigid_motion_gives_resultant_and_moment(blisk_mesh):
    """No clamps: rigid motions of all masters are reproduced by the static modes (eta = 0),
    so q^T f_red is the virtual work of the FE load on the rigid motion: the resultant for a
    translation, the moment about the rotation's centre for a rotation."""
    red = bodies.reduce_body(blisk_mesh, _damper_spec(), [0])[0]
    load = red.loads["centrifugal"]
    idx = red.dof_index(red.master_nodes)  # (n, 3)
    x = red.master_coordinates
    first, second = _moments(blisk_mesh, "damper", STEEL.density)
    force = np.array([first[0], first[1], 0.0])
    # About the origin r x rho (x, y, 0) = rho (-y z, x z, 0) (~0: the damper is symmetric
    # about z = 0); about a centre c off every symmetry plane M_c = M_0 - c x F, nonzero.
    centre = x.mean(axis=0) + np.array([0.003, -0.002, 0.004])
    moment = np.array([-second[1, 2], second[0, 2], 0.0]) - np.cross(centre, force)
    assert np.all(np.abs(moment) > 1e-4 * np.abs(force).max() * np.abs(x).max())
    scale = np.abs(force).max()
    arm = np.abs(x - centre).max()
    for k in range(3):
        q = np.zeros(red.size)
        q[idx[:, k]] = 1.0  # unit translation along axis k
        # Exact values from the per-tet closed forms; the difference is round-off of the
        # projection, measured <= 1.2e-16 of the force: 1e-12 leaves any summation order.
        assert q @ load == pytest.approx(force[k], abs=1e-12 * scale)
        w = np.zeros(3)
        w[k] = 1.0
        q = np.zeros(red.size)
        q[idx.ravel()] = np.cross(w, x - centre).ravel()  # small rotation about axis k at c
        # Same relative round-off on the moment, scaled by the moment arm.
        assert q @ load == pytest.approx(moment[k], abs=1e-12 * scale * arm)
    # The damper model serves every ND with its load (a body without cyclic symmetry).
    models = bodies.reduce_body(blisk_mesh, _damper_spec(), [0, 3])
    assert models[0] is models[3] and "centrifugal" in models[3].loads


def test_modal_reduction_projects_loads(disk_mesh):
    body = fem.assemble(disk_mesh, "disk", STEEL, order=1)
    sector = cyclic.sector_model(body, fem.node_set(disk_mesh, "disk/bore"),
                                 disk_mesh.cyclic["disk"], 0)
    f = fem.centrifugal_load(body)
    red = modal.modal_reduction(sector, 6, loads={"centrifugal": f})
    _, V = eigen.lowest_modes(sector.stiffness, sector.mass, 6)
    # Modal forces Phi^H P^H f, up to the sign of each mode (real at ND 0). Same solver on the
    # same matrices (measured identical); 1e-8 would still admit modes converged only to the
    # solver's tolerance, while a projection through the wrong basis or without P^H is O(1).
    expected = V.T @ (sector.expansion.T @ f)
    np.testing.assert_allclose(np.abs(red.loads["centrifugal"]), np.abs(expected), rtol=0,
                               atol=1e-8 * np.abs(expected).max())


def test_bad_load_before_factorization(disk_mesh, monkeypatch):
    body = fem.assemble(disk_mesh, "disk", STEEL, order=1)
    sector = cyclic.sector_model(body, fem.node_set(disk_mesh, "disk/bore"),
                                 disk_mesh.cyclic["disk"], 0)
    masters = _rim_masters(disk_mesh)[:3]

    def no_factorization(*args, **kwargs):
        raise AssertionError("factorized before validating")

    monkeypatch.setattr(linalg, "factorize", no_factorization)
    with pytest.raises(ValueError, match=r"loads\['c'\]: shape"):
        craig_bampton.craig_bampton(sector, masters, 2, loads={"c": np.zeros(body.n_dofs - 1)})
    with pytest.raises(ValueError, match="finite"):
        craig_bampton.craig_bampton(sector, masters, 2, loads={"c": np.full(body.n_dofs, np.nan)})


# --- storage and cache --------------------------------------------------------------------


def test_loads_in_hdf5_and_cache(disk_mesh, tmp_path, monkeypatch):
    rim = _rim_masters(disk_mesh)
    mesh = dataclasses.replace(disk_mesh, node_sets={**disk_mesh.node_sets, "disk/patch": rim})
    spec = bodies.BodySpec(body="disk", material=STEEL, master_sets=("disk/patch",),
                              clamped_sets=("disk/bore",), n_modes=4, order=1)
    nds = [0, 1, NS // 2]
    first = bodies.reduce_body(mesh, spec, nds, cache_dir=tmp_path)
    # Axisymmetric: only ND 0 carries it; ND 1 (complex) and ND Ns/2 (real) have no loads.
    assert set(first[0].loads) == {"centrifugal"}
    assert first[1].loads == {} and first[NS // 2].loads == {}
    load = first[0].loads["centrifugal"]
    assert load.shape == (first[0].size,) and load.dtype == first[0].stiffness.dtype
    assert np.abs(load[: first[0].n_masters]).max() > 0.0
    assert first[0].dof_index(rim).shape == (len(rim), 3)

    # Round trip through a group of another file: bitwise.
    path = first[0].save(tmp_path / "other.h5", group="/models/nd0")
    back = reduced_model.ReducedModel.load(path, group="/models/nd0")
    assert set(back.loads) == {"centrifugal"}
    np.testing.assert_array_equal(back.loads["centrifugal"], load)
    assert back.loads["centrifugal"].dtype == load.dtype
    with h5py.File(path, "r") as f:
        assert list(f["models/nd0/loads"]) == ["centrifugal"]
        assert f["models/nd0"].attrs["format_version"] == reduced_model.FORMAT_VERSION

    calls = []
    assemble = fem.assemble

    def counting(*args, **kwargs):
        calls.append(args)
        return assemble(*args, **kwargs)

    monkeypatch.setattr(fem, "assemble", counting)
    second = bodies.reduce_body(mesh, spec, nds, cache_dir=tmp_path)
    assert calls == []  # every ND from the cache
    for h in nds:
        assert second[h].key == first[h].key
        assert set(second[h].loads) == set(first[h].loads)
    np.testing.assert_array_equal(second[0].loads["centrifugal"], load)

    # A file of an older format (no loads) is reduced again and replaced, with its load.
    old = bodies.model_path(mesh, spec, 0, tmp_path)
    with h5py.File(old, "a") as f:
        f.attrs["format_version"] = reduced_model.FORMAT_VERSION - 1
        del f["loads"]
    third = bodies.reduce_body(mesh, spec, [0], cache_dir=tmp_path)
    assert len(calls) == 1
    np.testing.assert_allclose(third[0].loads["centrifugal"], load, rtol=0,
                               atol=1e-9 * np.abs(load).max())  # a fresh reduction: round-off
    assert reduced_model.ReducedModel.load(old).loads.keys() == {"centrifugal"}
    assert not list(tmp_path.glob("*.part"))
    # The load enters the key by name: a model without it is a different reduction.
    sector = cyclic.sector_model(assemble(mesh, "disk", STEEL, 1),
                                 fem.node_set(mesh, "disk/bore"), mesh.cyclic["disk"], 0)
    bare = craig_bampton.craig_bampton(sector, rim, 4)
    assert bare.loads == {} and bare.key != first[0].key
