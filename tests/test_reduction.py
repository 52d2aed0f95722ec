"""Craig-Bampton and modal reduction against the unreduced sector model."""

import dataclasses

import numpy as np
import pytest
import scipy.linalg as sla

import geometry
from pipeline import cyclic, fem, linalg, reduction

STEEL = fem.Material(2.1e11, 0.3, 7800.0)
NS = 6


@pytest.fixture(scope="module")
def disk():
    """Annular sector, clamped bore; masters = a rim 'contact patch' around theta = 0."""
    mesh = geometry.annular_sector(sectors=NS, r_inner=0.05, r_outer=0.12, width=0.01,
                                   size=0.015)
    body = fem.assemble(mesh, "disk", STEEL)
    rim = fem.node_set(mesh, "disk/rim")
    theta = np.arctan2(mesh.points[rim, 1], mesh.points[rim, 0])
    masters = rim[np.abs(theta) < np.pi / NS / 3]
    return mesh, body, masters


def _sector(disk, h):
    mesh, body, _ = disk
    return cyclic.sector_model(body, fem.node_set(mesh, "disk/bore"), mesh.cyclic["disk"], h)


def test_complete_slave_basis_is_exact():
    """With every fixed-interface mode kept, CB is a change of basis: same spectrum."""
    mesh = geometry.annular_sector(sectors=NS, r_inner=0.05, r_outer=0.12, width=0.01,
                                   size=0.03)
    body = fem.assemble(mesh, "disk", STEEL, order=1)
    model = cyclic.sector_model(body, fem.node_set(mesh, "disk/bore"), mesh.cyclic["disk"], 1)
    masters = np.setdiff1d(fem.node_set(mesh, "disk/rim"), mesh.cyclic["disk"].right)[:4]
    n_slave = model.n_free - 3 * len(masters)
    red = reduction.craig_bampton(model, masters, n_slave)
    lam_full = sla.eigh(model.stiffness.toarray(), model.mass.toarray(), eigvals_only=True)
    lam_red = sla.eigh(red.stiffness, red.mass, eigvals_only=True)
    # Round-off only (dense LAPACK on a few hundred DOFs): 1e-9 relative.
    np.testing.assert_allclose(lam_red, lam_full, rtol=1e-9)


# CB error of the first ten frequencies vs fixed-interface modes, measured on this model
# (max over the ten; ND 0 / 1 / 2 / 3):
#   modes  10: 5.6e-2 2.4e-2 1.3e-2 6.0e-2     modes 40: 2.6e-3 1.7e-3 1.3e-3 1.6e-3
#   modes  20: 8.4e-3 5.7e-3 3.6e-3 8.6e-3     modes 80: 6.6e-4 (ND 0)
#   modes  30: 5.0e-3 3.5e-3 1.5e-3 2.1e-3
# The disk's tenth mode is a high-order one: the error follows (f_10 / f_cut)^2, so 0.1 % on
# all ten needs the cut-off at ~4.5 f_10 (80 modes here); at 30 the first five are < 0.1 %.
def _cb_errors(disk, h, mode_counts):
    """(len(mode_counts), 10) relative errors of the first ten CB frequencies."""
    model = _sector(disk, h)
    lam, _ = linalg.lowest_modes(model.stiffness, model.mass, 10)
    f_ref = np.sqrt(lam) / (2 * np.pi)
    errors = []
    for n_modes in mode_counts:
        f = reduction.craig_bampton(model, disk[2], n_modes).frequencies(10)
        assert np.all(f >= f_ref * (1 - 1e-10))  # CB is a Rayleigh-Ritz: upper bounds
        errors.append(np.abs(f / f_ref - 1))
    errors = np.array(errors)
    assert np.all(errors[1:].max(axis=1) < errors[:-1].max(axis=1))  # converging
    return errors


@pytest.mark.parametrize("h", [0, 1])
def test_craig_bampton_converges(disk, h):
    errors = _cb_errors(disk, h, (10, reduction.DEFAULT_MODES))
    assert errors[-1][:5].max() < 1e-3  # default modes: first five within 0.1 %


@pytest.mark.slow
@pytest.mark.parametrize("h", range(NS // 2 + 1))
def test_craig_bampton_converges_every_nd(disk, h):
    errors = _cb_errors(disk, h, (10, 30, 80))
    assert errors[-1].max() < 1e-3  # all ten within 0.1 % with the cut-off at ~4.5 f_10


def test_reduced_matrices_hermitian_and_definite(disk):
    for h in (0, 1, NS // 2):
        red = reduction.craig_bampton(_sector(disk, h), disk[2], 20)
        K, M = red.stiffness, red.mass
        assert np.iscomplexobj(K) == (0 < h < NS / 2)
        assert np.abs(K - K.conj().T).max() == 0.0
        assert np.abs(M - M.conj().T).max() == 0.0
        # Clamped bore: K positive definite, M positive definite.
        assert np.linalg.eigvalsh(M).min() > 0.0
        assert np.linalg.eigvalsh(K).min() > 0.0


def test_free_free_body_has_six_rigid_body_modes():
    """A free body held by nothing, its 'contact faces' (both beam ends) as masters."""
    mesh = geometry.beam(0.1, 0.03, 0.02, 0.015)
    body = fem.assemble(mesh, "beam", STEEL)
    model = cyclic.sector_model(body)  # no clamps
    masters = fem.node_sets_union(mesh, ["beam/clamp", "beam/tip"])
    red = reduction.craig_bampton(model, masters, 10)
    lam = sla.eigh(red.stiffness, red.mass, eigvals_only=True)
    # Six zeros up to round-off (relative to the first elastic eigenvalue), then elastic modes.
    assert np.all(np.abs(lam[:6]) < 1e-8 * lam[6])
    assert lam[6] > 0.0
    # The reduced stiffness is positive semi-definite with a 6-dimensional null space.
    k_eig = np.linalg.eigvalsh(red.stiffness)
    assert np.sum(np.abs(k_eig) < 1e-9 * k_eig.max()) == 6
    assert k_eig.min() > -1e-9 * k_eig.max()


def test_mass_scaling_equals_re_reduction(disk):
    mesh, body, masters = disk
    scale = 2.5
    red = reduction.craig_bampton(_sector(disk, 1), masters, 15)
    heavy_body = fem.assemble(mesh, "disk", fem.Material(2.1e11, 0.3, 7800.0 * scale))
    heavy = cyclic.sector_model(heavy_body, fem.node_set(mesh, "disk/bore"),
                                mesh.cyclic["disk"], 1)
    red_heavy = reduction.craig_bampton(heavy, masters, 15)
    scaled = red.with_mass_scale(scale)
    # Same subspace, modal coordinates scaled by sqrt(scale): identical spectra.
    np.testing.assert_allclose(scaled.frequencies(), red_heavy.frequencies(), rtol=1e-9)
    np.testing.assert_allclose(scaled.frequencies(5), red.frequencies(5) / np.sqrt(scale),
                               rtol=1e-9)
    assert scaled.key == red.key and scaled.mass_scale == scale


def test_recovery_and_master_map(disk):
    mesh, body, masters = disk
    right = mesh.cyclic["disk"].right[:2]
    left = mesh.cyclic["disk"].left[:2]
    recovery = np.concatenate([masters[:3], left, right])
    red = reduction.craig_bampton(_sector(disk, 1), masters, 10, recovery_nodes=recovery,
                                  patches={"rim_patch": masters[:5]})
    idx = red.dof_index(masters[:3])  # (3, 3)
    np.testing.assert_array_equal(idx, 3 * np.arange(3)[:, None] + np.arange(3))
    np.testing.assert_array_equal(red.master_dof_nodes[idx.ravel()], np.repeat(masters[:3], 3))
    np.testing.assert_array_equal(red.master_dof_directions[idx.ravel()], np.tile([0, 1, 2], 3))
    np.testing.assert_array_equal(red.patch_dofs("rim_patch"), red.dof_index(masters[:5]))
    np.testing.assert_allclose(red.master_coordinates, mesh.points[masters])
    # A master node's recovery row is the unit vector of its own coordinate.
    q = np.random.default_rng(0).standard_normal(red.size)
    np.testing.assert_allclose(red.recover(q, masters[:3]), q[idx], atol=1e-14)
    # Right-face nodes: u_R = exp(i h phi) R(phi) u_L (cyclic condition, h = 1).
    u_left, u_right = red.recover(q, left), red.recover(q, right)
    T = np.exp(2j * np.pi / NS) * cyclic.rotation(2 * np.pi / NS)
    np.testing.assert_allclose(u_right, u_left @ T.T, atol=1e-12 * np.abs(u_left).max())


def test_hdf5_roundtrip_and_cache(disk, tmp_path, monkeypatch):
    mesh, _, masters = disk
    mesh = dataclasses.replace(mesh, node_sets={**mesh.node_sets, "disk/patch": masters})
    spec = reduction.BodySpec(body="disk", material=STEEL, master_sets=("disk/patch",),
                              recovery_sets=("disk/rim",), clamped_sets=("disk/bore",),
                              n_modes=5, order=1, damping=fem.Damping(rayleigh_beta=1e-6))
    first = reduction.reduce_body(mesh, spec, [0, 1], cache_dir=tmp_path)
    assert len(list(tmp_path.glob("*.h5"))) == 2

    def no_assembly(*args, **kwargs):
        raise AssertionError("cache miss: assembled again")

    monkeypatch.setattr(fem, "assemble", no_assembly)
    second = reduction.reduce_body(mesh, spec, [0, 1], cache_dir=tmp_path)
    for h in (0, 1):
        a, b = first[h], second[h]
        assert a.key == b.key and a.nodal_diameter == h
        np.testing.assert_array_equal(a.stiffness, b.stiffness)
        np.testing.assert_array_equal(a.mass, b.mass)
        np.testing.assert_array_equal(a.recovery, b.recovery)
        np.testing.assert_allclose(b.damping, 1e-6 * b.stiffness)
        assert b.stiffness.dtype == (np.complex128 if h == 1 else np.float64)


def test_modal_superposition(disk):
    model = _sector(disk, 1)
    nodes = disk[2][:4]
    red = reduction.modal_reduction(model, 6, recovery_nodes=nodes)
    lam, V = linalg.lowest_modes(model.stiffness, model.mass, 6)
    np.testing.assert_allclose(np.diag(red.stiffness).real, lam, rtol=1e-10)
    np.testing.assert_allclose(red.mass, np.eye(6), atol=1e-14)
    # Recovery = mode shapes at the nodes (up to a unit phase per mode).
    u = (model.expansion @ V)[model.body.dofs_of_nodes(np.sort(nodes)).ravel()]
    R = red.recovery.reshape(-1, 6)
    for j in range(6):
        ratio = np.vdot(u[:, j], R[:, j]) / np.vdot(u[:, j], u[:, j])
        assert abs(abs(ratio) - 1) < 1e-8
        np.testing.assert_allclose(R[:, j], ratio * u[:, j], atol=1e-8 * np.abs(u).max())


def test_bad_input_before_factorization(disk, monkeypatch):
    mesh, body, masters = disk
    model = _sector(disk, 1)

    def no_factorization(*args, **kwargs):
        raise AssertionError("factorized before validating")

    monkeypatch.setattr(linalg, "factorize", no_factorization)
    n_slave = model.n_free - 3 * len(masters)
    with pytest.raises(ValueError, match="n_modes"):
        reduction.craig_bampton(model, masters, n_slave + 1)
    with pytest.raises(ValueError, match="clamped"):
        reduction.craig_bampton(model, fem.node_set(mesh, "disk/bore")[:2], 5)
    with pytest.raises(ValueError, match="patches"):
        reduction.craig_bampton(model, masters[:2], 5, patches={"p": masters[2:4]})
    with pytest.raises(ValueError, match="backend"):
        reduction.craig_bampton(model, masters, 5, backend="cholmod-magic")
    spec = reduction.BodySpec(body="disk", material=STEEL, master_sets=("disk/nope",))
    with pytest.raises(ValueError, match="node set 'disk/nope' does not exist"):
        reduction.reduce_body(mesh, spec, [0])
    spec = reduction.BodySpec(body="disk", material=STEEL, master_sets=("disk/rim",))
    with pytest.raises(ValueError, match="nodal_diameter"):
        reduction.reduce_body(mesh, spec, [NS // 2 + 1])
