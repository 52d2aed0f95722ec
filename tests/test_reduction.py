"""Craig-Bampton and modal reduction against the unreduced sector model."""

import dataclasses

import numpy as np
import pytest
import scipy.linalg as sla

from microslip import geometry
from microslip.fe import bodies, craig_bampton, cyclic, eigen, fem, linalg, modal, reduced_model
from microslip.fourier import Harmonics
from microslip.geometry.mesh import rotation_z
from microslip.solve.linear import LinearDynamics, OperatingPoint

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
    red = craig_bampton.craig_bampton(model, masters, n_slave)
    lam_full = sla.eigh(model.stiffness.toarray(), model.mass.toarray(), eigvals_only=True)
    lam_red = sla.eigh(red.stiffness, red.mass, eigvals_only=True)
    # Round-off only (dense LAPACK on a few hundred DOFs): 1e-9 relative.
    np.testing.assert_allclose(lam_red, lam_full, rtol=1e-9)


@pytest.fixture(scope="module")
def blisk():
    """The default blisk sector: masters = both contact patches + excitation + response."""
    mesh = geometry.blisk_sector()
    body = fem.assemble(mesh, "blisk", STEEL)
    masters = fem.node_sets_union(mesh, [
        "contact/damper_left/blisk", "contact/damper_right/blisk",
        "blisk/excitation", "blisk/response"])
    return mesh, body, masters


def _cb_errors(model, masters, selections):
    """(len(selections), 10) relative errors of the first ten CB frequencies, and mode counts.

    selections: n_modes values (an integer or "auto"). Reference: the unreduced model.
    """
    lam, _ = eigen.lowest_modes(model.stiffness, model.mass, 10)
    f_ref = np.sqrt(lam) / (2 * np.pi)
    errors, counts = [], []
    for n_modes in selections:
        red = craig_bampton.craig_bampton(model, masters, n_modes)
        f = red.frequencies(10)
        assert np.all(f >= f_ref * (1 - 1e-10))  # CB is a Rayleigh-Ritz: upper bounds
        errors.append(np.abs(f / f_ref - 1))
        counts.append(red.n_modes)
    return np.array(errors), counts


# CB error of the first ten frequencies (max over the ten) on the annular test model, ND 0-3:
#   10 modes: 5.6e-2 2.4e-2 1.3e-2 6.0e-2     30 modes: 5.0e-3 3.5e-3 1.5e-3 2.1e-3
#   default "auto" (cut-off 4 x the 10th fixed-interface frequency, 69-85 modes):
#             4.1e-4 3.2e-4 3.1e-4 3.5e-4
# The error follows (f_10 / f_cut)^2: a fixed count of 30 gives 0.1 % only on the first five.
# ND 0 and 2 repeat what ND 1 (complex) and ND 3 (real, the other end) check: slow.
@pytest.mark.parametrize("h", [pytest.param(0, marks=pytest.mark.slow), 1,
                               pytest.param(2, marks=pytest.mark.slow), 3])
def test_craig_bampton_default_within_a_tenth_of_a_percent(disk, h):
    errors, counts = _cb_errors(_sector(disk, h), disk[2], (10, 30, reduced_model.DEFAULT_MODES))
    assert reduced_model.DEFAULT_MODES == "auto" and counts[-1] > 30
    assert np.all(np.diff(errors.max(axis=1)) < 0)  # converging with more modes
    # The default: all ten within 0.1 % (measured max 4.1e-4, a margin of 2.4).
    assert errors[-1].max() < 1e-3


# Same on the default blisk sector (masters: contact patches, excitation, response), ND 0 / 1 /
# 12 / 24 (microslip bench reduction --cb blisk --nds 0,1,12,24):
#   30 modes 3.7e-4 5.3e-4 2.7e-3 1.6e-3;  default (40 / 40 / 51 / 45 modes) 2.3e-4 3.4e-4
#   6.4e-4 6.2e-4 (the tightest margin, 1.6, is at ND 12).
# Slow (~5 s each): the annular model checks the same default fast, at real and complex NDs.
@pytest.mark.slow
@pytest.mark.parametrize("h", [0, 1, 12, 24])
def test_craig_bampton_default_blisk(blisk, h):
    mesh, body, masters = blisk
    model = cyclic.sector_model(body, fem.node_set(mesh, "blisk/bore"), mesh.cyclic["blisk"], h)
    errors, counts = _cb_errors(model, masters, (reduced_model.DEFAULT_MODES,))
    assert errors[0].max() < 1e-3


def test_mode_selection_by_cutoff(disk):
    """'auto' keeps exactly the fixed-interface modes below the cut-off, whichever reference."""
    model = _sector(disk, 1)
    masters = disk[2]
    red = craig_bampton.craig_bampton(model, masters, "auto", cutoff=3.0)
    f = red.mode_frequencies
    # All modes below 3 x the 10th, and the next fixed-interface mode above it: compare with a
    # complete computation of one more mode than were kept.
    full = craig_bampton.craig_bampton(model, masters, red.n_modes + 1).mode_frequencies
    np.testing.assert_allclose(f, full[:-1], rtol=1e-9)
    assert f[-1] <= 3.0 * f[9] < full[-1]
    # With the highest frequency of interest given instead:
    red = craig_bampton.craig_bampton(model, masters, "auto", cutoff=2.0, f_max=10_000.0)
    assert 0 < red.n_modes < len(full)  # 20 kHz is below 3 x f_10 (~90 kHz)
    assert red.mode_frequencies[-1] <= 20_000.0 < full[red.n_modes]
    assert red.key != craig_bampton.craig_bampton(model, masters, red.n_modes).key


def test_reduced_matrices_hermitian_and_definite(disk):
    for h in (0, 1, NS // 2):
        red = craig_bampton.craig_bampton(_sector(disk, h), disk[2], 20)
        K, M = red.stiffness, red.mass
        assert np.iscomplexobj(K) == (0 < h < NS / 2)
        assert np.abs(K - K.conj().T).max() == 0.0
        assert np.abs(M - M.conj().T).max() == 0.0
        # Clamped bore: K positive definite, M positive definite.
        assert np.linalg.eigvalsh(M).min() > 0.0
        assert np.linalg.eigvalsh(K).min() > 0.0


@pytest.mark.slow  # a long verification (4 s); the free damper is reduced in every assembly test
def test_free_free_damper_has_six_rigid_body_modes():
    """The blisk's wedge damper, held by nothing, every contact DOF a master (as in a case);
    a coarse blisk (the damper alone is assembled)."""
    mesh = geometry.blisk_sector(sectors=6, size=0.03, blade_size=0.012)
    body = fem.assemble(mesh, "damper", STEEL)
    model = cyclic.sector_model(body)  # no clamps, no cyclic symmetry
    masters = fem.node_sets_union(mesh, ["contact/damper_left/damper",
                                         "contact/damper_right/damper"])
    red = craig_bampton.craig_bampton(model, masters)
    lam = sla.eigh(red.stiffness, red.mass, eigvals_only=True)
    # Six zeros up to round-off (relative to the first elastic eigenvalue), then elastic modes.
    assert np.all(np.abs(lam[:6]) < 1e-8 * lam[6])
    assert lam[6] > 0.0
    # The reduced stiffness is positive semi-definite with a 6-dimensional null space.
    k_eig = np.linalg.eigvalsh(red.stiffness)
    assert np.sum(np.abs(k_eig) < 1e-9 * k_eig.max()) == 6
    assert k_eig.min() > -1e-9 * k_eig.max()
    # The reduced mass carries the damper's mass: a unit x translation of every master moves
    # the whole body rigidly (static modes), with kinetic energy m / 2.
    u = np.zeros(red.size)
    u[red.dof_index(masters)[:, 0]] = 1.0
    assert u @ red.mass @ u == pytest.approx(STEEL.density * mesh.body_volume("damper"), 1e-10)


def test_mass_scaling_equals_re_reduction(disk):
    mesh, body, masters = disk
    scale = 2.5
    red = craig_bampton.craig_bampton(_sector(disk, 1), masters, 15)
    heavy_body = fem.assemble(mesh, "disk", fem.Material(2.1e11, 0.3, 7800.0 * scale))
    heavy = cyclic.sector_model(heavy_body, fem.node_set(mesh, "disk/bore"),
                                mesh.cyclic["disk"], 1)
    red_heavy = craig_bampton.craig_bampton(heavy, masters, 15)
    # The one mechanism of mass studies: the harmonic balance's mass multiplier on the whole
    # reduced body (mass_part = M), no re-reduction.
    linear = LinearDynamics.create(red.stiffness, red.mass, harmonics=Harmonics((1,)),
                                   mass_part=red.mass)
    M = linear.mass(OperatingPoint(1.0, mass_multiplier=scale))[0]

    def frequencies(K, M):
        return np.sqrt(np.clip(sla.eigh(K, M, eigvals_only=True), 0.0, None)) / (2 * np.pi)

    # Same subspace, modal coordinates scaled by sqrt(scale): identical spectra.
    np.testing.assert_allclose(frequencies(red.stiffness, M), red_heavy.frequencies(), rtol=1e-9)
    np.testing.assert_allclose(frequencies(red.stiffness, M)[:5],
                               red.frequencies(5) / np.sqrt(scale), rtol=1e-9)


def test_recovery_and_master_map(disk):
    mesh, body, masters = disk
    right = mesh.cyclic["disk"].right[:2]
    left = mesh.cyclic["disk"].left[:2]
    recovery = np.concatenate([masters[:3], left, right])
    red = craig_bampton.craig_bampton(_sector(disk, 1), masters, 10, recovery_nodes=recovery,
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
    T = np.exp(2j * np.pi / NS) * rotation_z(2 * np.pi / NS)
    np.testing.assert_allclose(u_right, u_left @ T.T, atol=1e-12 * np.abs(u_left).max())


def test_hdf5_roundtrip_and_cache(disk, tmp_path, monkeypatch):
    mesh, _, masters = disk
    mesh = dataclasses.replace(mesh, node_sets={**mesh.node_sets, "disk/patch": masters})
    spec = bodies.BodySpec(body="disk", material=STEEL, master_sets=("disk/patch",),
                              recovery_sets=("disk/rim",), clamped_sets=("disk/bore",),
                              n_modes=5, order=1, damping=fem.Damping(rayleigh_beta=1e-6))
    first = bodies.reduce_body(mesh, spec, [0, 1], cache_dir=tmp_path)
    assert len(list(tmp_path.glob("*.h5"))) == 2

    def no_assembly(*args, **kwargs):
        raise AssertionError("cache miss: assembled again")

    monkeypatch.setattr(fem, "assemble", no_assembly)
    second = bodies.reduce_body(mesh, spec, [0, 1], cache_dir=tmp_path)
    for h in (0, 1):
        a, b = first[h], second[h]
        assert a.key == b.key and a.nodal_diameter == h
        np.testing.assert_array_equal(a.stiffness, b.stiffness)
        np.testing.assert_array_equal(a.mass, b.mass)
        np.testing.assert_array_equal(a.recovery, b.recovery)
        np.testing.assert_allclose(b.damping, 1e-6 * b.stiffness)
        assert b.stiffness.dtype == (np.complex128 if h == 1 else np.float64)
    # A damaged cache file is reduced again and replaced, not taken for a model.
    monkeypatch.undo()
    damaged = bodies.model_path(mesh, spec, 1, tmp_path)
    damaged.write_bytes(b"not an HDF5 file")
    third = bodies.reduce_body(mesh, spec, [1], cache_dir=tmp_path)
    np.testing.assert_allclose(third[1].stiffness, first[1].stiffness, rtol=1e-10,
                               atol=1e-12 * np.abs(first[1].stiffness).max())
    assert reduced_model.ReducedModel.load(damaged).key == first[1].key
    assert not list(tmp_path.glob("*.part"))


def test_modal_superposition(disk):
    model = _sector(disk, 1)
    nodes = disk[2][:4]
    red = modal.modal_reduction(model, 6, recovery_nodes=nodes)
    lam, V = eigen.lowest_modes(model.stiffness, model.mass, 6)
    np.testing.assert_allclose(np.diag(red.stiffness).real, lam, rtol=1e-10)
    np.testing.assert_allclose(red.mass, np.eye(6), atol=1e-14)
    # Recovery = mode shapes at the nodes (up to a unit phase per mode).
    u = (model.expansion @ V)[model.body.dofs_of_nodes(np.sort(nodes)).ravel()]
    R = red.recovery.reshape(-1, 6)
    for j in range(6):
        ratio = np.vdot(u[:, j], R[:, j]) / np.vdot(u[:, j], u[:, j])
        assert abs(abs(ratio) - 1) < 1e-8
        np.testing.assert_allclose(R[:, j], ratio * u[:, j], atol=1e-8 * np.abs(u).max())


@pytest.fixture(scope="module")
def dense_spectrum(disk):
    """ND -> the 80 lowest eigenvalues by dense LAPACK (computed once per ND)."""
    found = {}

    def spectrum(h):
        if h not in found:
            K, M = _sector(disk, h).stiffness, _sector(disk, h).mass
            found[h] = sla.eigh(K.toarray(), M.toarray(), eigvals_only=True,
                                subset_by_index=[0, 79])
        return found[h]

    return spectrum


# ND 1 (complex Hermitian) is slow: its dense reference alone takes ~6 s; the complex block
# path stays in the fast suite through the CB tests at ND 1 and the restart tests.
# PARDISO's solves match SuperLU's (test_pardiso_* below): one backend in
# the fast suite
@pytest.mark.parametrize("backend", [pytest.param(b, marks=pytest.mark.slow) if b != "superlu"
                                     else b for b in linalg.available_backends()])
@pytest.mark.parametrize("h", [0, pytest.param(1, marks=pytest.mark.slow)])
def test_block_eigensolver_matches_dense(disk, dense_spectrum, h, backend):
    """The block shift-invert Lanczos (the default) against dense LAPACK, real and complex,
    on every installed factorization (this size would pick SuperLU by default)."""
    model = _sector(disk, h)  # 2289 free DOFs: above the dense limit, so the block path runs
    K, M = model.stiffness, model.mass
    lam_dense = dense_spectrum(h)
    lam, V = eigen.lowest_modes(K, M, 20, backend=backend)
    # tol 1e-10 on the shift-invert residual: eigenvalues to round-off (measured ~1e-12).
    np.testing.assert_allclose(lam, lam_dense[:20], rtol=1e-9)
    np.testing.assert_allclose(V.conj().T @ (M @ V), np.eye(20), atol=1e-10)
    KV = V.conj().T @ (K @ V)
    np.testing.assert_allclose(KV, np.diag(lam), atol=1e-10 * lam.max())
    # Selection by a bound: exactly the eigenvalues below it (and at least k).
    bound = 3.0**2 * lam_dense[9]
    lam_b, V_b = eigen.lowest_modes(K, M, 10, upper=lambda lam_k: 3.0**2 * lam_k[-1],
                                     backend=backend)
    assert len(lam_b) == np.sum(lam_dense <= bound) < 80
    np.testing.assert_allclose(lam_b, lam_dense[: len(lam_b)], rtol=1e-9)
    # ARPACK (the alternative) agrees.
    lam_a, _ = eigen.lowest_modes(K, M, 20, method="arpack", backend=backend)
    np.testing.assert_allclose(lam_a, lam_dense[:20], rtol=1e-9)


@pytest.mark.skipif("pardiso" not in linalg.available_backends(), reason="pypardiso absent")
def test_pardiso_complex_hermitian_matches_superlu(disk):
    """PARDISO's complex Hermitian factorization (mtype 4) solves what SuperLU solves."""
    K = _sector(disk, 1).stiffness
    b = np.random.default_rng(3).standard_normal((K.shape[0], 5)) * (1 + 2j)
    x_p = linalg.factorize(K, "pardiso").solve(b)
    x_s = linalg.factorize(K, "superlu").solve(b)
    # Both backward stable; cond(K) ~ 1e7 here, so the solutions agree to ~1e-9.
    assert np.linalg.norm(x_p - x_s) < 1e-8 * np.linalg.norm(x_s)
    assert np.linalg.norm(K @ x_p - b) < 1e-10 * np.linalg.norm(b)
    x1 = linalg.factorize(K, "pardiso").solve(b[:, 0])  # a single vector
    np.testing.assert_allclose(x1, x_p[:, 0], rtol=1e-10, atol=1e-10 * np.abs(x_p).max())


@pytest.mark.skipif("pardiso" not in linalg.available_backends(), reason="pypardiso absent")
@pytest.mark.parametrize("nd", [0, 1])
def test_pardiso_indefinite_shift_matches_superlu(disk, nd):
    """A shift between eigenvalues (K - sigma M indefinite: Bunch-Kaufman, mtype -2 / -4, with
    refinement only if pivots were perturbed) and a complex right-hand side on a real matrix."""
    model = _sector(disk, nd)
    K, M = model.stiffness, model.mass
    lam = eigen.lowest_modes(K, M, 3)[0]
    A = K - 0.5 * (lam[1] + lam[2]) * M  # two eigenvalues below the shift
    b = np.random.default_rng(4).standard_normal((K.shape[0], 4)) * (1 - 3j)
    x_p = linalg.factorize(A, "pardiso", positive_definite=False).solve(b)
    x_s = linalg.factorize(A, "superlu").solve(b)
    # cond(A) ~ 1e8 (shift half-way between modes 2 and 3): backward-stable solutions agree
    # to ~1e-8. The residual must be as small as SuperLU's (within 10x: without refinement,
    # PARDISO's restricted Bunch-Kaufman pivoting loses ~3 digits on such matrices).
    r_p, r_s = (np.linalg.norm(A @ x - b) for x in (x_p, x_s))
    assert r_p < 10 * r_s + 1e-15 * np.linalg.norm(b)
    assert np.linalg.norm(x_p - x_s) < 1e-6 * np.linalg.norm(x_s)


@pytest.mark.parametrize("dtypes", [(float, float), (complex, complex), (float, complex)])
def test_parallel_sparse_product_matches_scipy(monkeypatch, dtypes):
    """linalg.spmm (compiled, parallel over rows) against SciPy's product, for thin
    column-major and wide row-major blocks (the two layouts it keeps)."""
    import scipy.sparse as sp

    monkeypatch.setattr(linalg, "_SPMM_MIN_WORK", 0)  # take the compiled path at this size
    rng = np.random.default_rng(5)
    A = sp.random(300, 250, density=0.05, random_state=6, format="csr").astype(dtypes[0])
    if dtypes[0] is complex:
        A = A + 1j * sp.random(300, 250, density=0.05, random_state=7, format="csr")
    for k, order in ((8, "F"), (40, "C"), (40, "F")):
        X = rng.standard_normal((250, k)).astype(dtypes[1])
        if dtypes[1] is complex:
            X = X + 1j * rng.standard_normal((250, k))
        X = np.asarray(X, order=order)
        Y = linalg.spmm(A, X)
        # Same sums in another order: round-off only.
        np.testing.assert_allclose(Y, A @ X, rtol=1e-13, atol=1e-13 * np.abs(Y).max())
        assert Y.flags.f_contiguous == (order == "F" and k <= 16)


def test_bad_input_before_factorization(disk, monkeypatch):
    mesh, body, masters = disk
    model = _sector(disk, 1)

    def no_factorization(*args, **kwargs):
        raise AssertionError("factorized before validating")

    monkeypatch.setattr(linalg, "factorize", no_factorization)
    n_slave = model.n_free - 3 * len(masters)
    with pytest.raises(ValueError, match="n_modes"):
        craig_bampton.craig_bampton(model, masters, n_slave + 1)
    with pytest.raises(ValueError, match="n_modes"):
        craig_bampton.craig_bampton(model, masters, "many")
    with pytest.raises(ValueError, match="cutoff"):
        craig_bampton.craig_bampton(model, masters, "auto", cutoff=0.5)
    with pytest.raises(ValueError, match="f_max"):
        craig_bampton.craig_bampton(model, masters, "auto", f_max=-1.0)
    with pytest.raises(ValueError, match="eigen_method"):
        craig_bampton.craig_bampton(model, masters, 5, eigen_method="lanczos")
    with pytest.raises(ValueError, match="clamped"):
        craig_bampton.craig_bampton(model, fem.node_set(mesh, "disk/bore")[:2], 5)
    with pytest.raises(ValueError, match="patches"):
        craig_bampton.craig_bampton(model, masters[:2], 5, patches={"p": masters[2:4]})
    with pytest.raises(ValueError, match="backend"):
        craig_bampton.craig_bampton(model, masters, 5, backend="cholmod-magic")
    spec = bodies.BodySpec(body="disk", material=STEEL, master_sets=("disk/nope",))
    with pytest.raises(ValueError, match="node set 'disk/nope' does not exist"):
        bodies.reduce_body(mesh, spec, [0])
    spec = bodies.BodySpec(body="disk", material=STEEL, master_sets=("disk/rim",))
    with pytest.raises(ValueError, match="on the cyclic face that follows the other"):
        bodies.reduce_body(mesh, spec, [0])
    mesh = dataclasses.replace(mesh, node_sets={**mesh.node_sets, "disk/m": masters})
    spec = bodies.BodySpec(body="disk", material=STEEL, master_sets=("disk/m",))
    with pytest.raises(ValueError, match="nodal_diameter"):
        bodies.reduce_body(mesh, spec, [NS // 2 + 1])


@pytest.mark.slow  # a benchmark's smoke run
def test_bench_reduction_prints_its_tables(capsys):
    """`microslip bench reduction` on a coarse sector: both tables, one row per body and ND,
    and the reduced model's f7 matching the unreduced sector's to the CB tolerance."""
    from microslip.bench import reduction_cost as bench_reduction

    assert bench_reduction.main(["--refine", "2", "--nds", "0", "--backends", "superlu"]) == 0
    out = capsys.readouterr().out
    assert "assembly" in out and "cyclic matrices + Craig-Bampton per ND" in out
    rows = [line.split() for line in out.splitlines() if line.startswith("superlu ")]
    # each row once (the progress goes to stderr)
    assert [r[1:3] for r in rows] == [["blisk", "0"], ["damper", "0"]]
    # The damper keeps only modes below 4 x the disk's 10th fixed-interface frequency.
    assert int(rows[1][5]) < 10


@pytest.mark.parametrize("setting, expected", [("1", "True"), ("0", "False")])
def test_retain_freed_memory_in_its_own_process(setting, expected):
    """The allocator setting of the CLI (process-wide, so run in a child process); the
    environment variable turns it off."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "MICROSLIP_RETAIN_MEMORY": setting}
    code = ("import numpy as np; from microslip.fe import linalg; "
            "r = linalg.retain_freed_memory(); a = np.ones(2**24); del a; b = np.ones(2**24); "
            "print(r, b.sum() == 2**24)")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == [expected, "True"]


def test_block_eigensolver_stops_at_an_unreachable_tolerance(disk):
    """A tolerance below the round-off floor ends in a message that says so, after a bounded
    number of restarts, instead of thousands of block steps."""
    model = _sector(disk, 1)
    # The estimated residual ||S x - nu x||_M / nu of converged pairs floors at a few eps
    # (measured 5e-16 to 2e-15 on this sector, ND 0 and 1): 1e-17 cannot be met.
    with pytest.raises(eigen.EigenSolverError,
                       match=r"not converged after \d+ restarts.*raise it"):
        eigen.lowest_modes(model.stiffness, model.mass, 10, tol=1e-17)


# (45: the count that stopped; 42 and 80 repeat it with fewer and more restarts: slow)
@pytest.mark.parametrize("k", [pytest.param(42, marks=pytest.mark.slow), 45,
                               pytest.param(80, marks=pytest.mark.slow)])
def test_block_eigensolver_converges_past_many_restarts(disk, k):
    """Many modes of a small sector take several thick restarts; the residuals must keep
    falling through them (they grew ~3x per restart while M Z was carried by recurrence after
    the second Gram-Schmidt pass: 45 modes stopped after 20 restarts at 2e-3)."""
    K, M = (getattr(_sector(disk, 0), a) for a in ("stiffness", "mass"))
    lam_dense = sla.eigh(K.toarray(), M.toarray(), eigvals_only=True, subset_by_index=[0, k - 1])
    lam, V = eigen.lowest_modes(K, M, k, tol=1e-12)
    # tol 1e-12 on the shift-invert residual: eigenvalues to round-off of the dense solve.
    np.testing.assert_allclose(lam, lam_dense, rtol=1e-9)
    np.testing.assert_allclose(V.T @ (M @ V), np.eye(k), atol=1e-10)
