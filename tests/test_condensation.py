"""Condensation of the linear part on the contact DOFs, and the real layout of its operators,
against plain dense references built here."""

import numpy as np
import pytest

from microslip.fourier import Harmonics
from microslip.laws.coulomb import ContactElements
from microslip.solve import hbm
from microslip.solve.hbm import Contact, HarmonicBalance
from microslip.solve.linear import Excitation, LinearDynamics, OperatingPoint

POINTS = [OperatingPoint(w, mass_multiplier=s) for w in (0.7, 1.6) for s in (1.0, 1.8)]


def _model(kind: str = "cyclic") -> HarmonicBalance:
    """Orders 0 and 1 of different sizes (7 shared DOFs + 2 and + 5 own ones), contacts on
    4 shared DOFs, a mass part and a rotating load tied to the frequency (so the condensed
    force depends on w and s).

    kind: "cyclic" complex Hermitian at order 1 and damped; "undamped" real and C = 0 (D is
    real at every order); "lumped" every DOF a contact DOF (nothing condensed)."""
    rng = np.random.default_rng(5)
    h = Harmonics([0, 1])
    n_shared, own, touched = 7, {0: 2, 1: 5}, [0, 2, 3, 5]
    if kind == "lumped":
        n_shared, own, touched = 4, {0: 0, 1: 0}, [0, 1, 2, 3]
    sizes = {o: n_shared + own[o] for o in h.orders}

    def hermitian(n, cplx, shift):
        A = rng.normal(size=(n, n)) + (1j * rng.normal(size=(n, n)) if cplx else 0)
        return A @ A.conj().T / n + shift * np.eye(n)

    cplx = kind == "cyclic"
    K = {o: 10 * hermitian(n, cplx and o > 0, 1.0) for o, n in sizes.items()}
    M = {o: hermitian(n, False, 0.5) for o, n in sizes.items()}
    C = None if kind == "undamped" else {o: 0.05 * hermitian(n, cplx and o > 0, 0.1)
                                          for o, n in sizes.items()}
    Mp = {o: 0.3 * hermitian(n, False, 0.0) for o, n in sizes.items()}
    lin = LinearDynamics.create(K, M, C, harmonics=h, mass_part=Mp, n_shared=n_shared)
    B = np.zeros((len(touched), n_shared))
    B[np.arange(len(touched)), touched] = 1.0
    B[1, touched[2]] = -0.4  # a relative displacement
    el = ContactElements.create("B", kt=2.0, kn=3.0, mu=0.3, n0=0.5, n_points=len(touched) // 2)
    forces = {o: rng.normal(size=n) + 1j * rng.normal(size=n) * (o > 0) for o, n in sizes.items()}
    exc = Excitation(forces, rotating=rng.normal(size=n_shared), engine_order=2,
                     rotating_part=rng.normal(size=n_shared))
    model = HarmonicBalance(lin, [Contact("c", el, B)], exc, h)
    assert model.dofs.tolist() == touched
    return model


def _reference(model: HarmonicBalance, point: OperatingPoint):
    """Per order (S, F, Y, z): the full D at the point, the Schur complement on the contact
    DOFs by np.linalg.solve (condensed: the other shared DOFs, then the order's own)."""
    lin, w, s = model.linear, point.omega, point.mass_multiplier
    F, _ = model.forces(point)
    c = model.dofs
    out = []
    for k, o in enumerate(lin.orders):
        M = lin.M[k] + (s - 1.0) * lin.M_part[k]
        D = lin.K[k] - (o * w) ** 2 * M + 1j * o * w * lin.C[k]
        i = np.setdiff1d(np.arange(D.shape[0]), c)
        Y = np.linalg.solve(D[np.ix_(i, i)], D[np.ix_(i, c)])
        z = np.linalg.solve(D[np.ix_(i, i)], F[k][i])
        out.append((D[np.ix_(c, c)] - D[np.ix_(c, i)] @ Y, F[k][c] - D[np.ix_(c, i)] @ z, Y, z))
    return out


def _close(a, b, rtol):
    """Max-norm agreement relative to the reference's largest entry."""
    scale = max(float(np.abs(b).max(initial=0.0)), 1e-300)
    assert np.abs(np.asarray(a) - b).max(initial=0.0) <= rtol * scale


@pytest.mark.parametrize("kind", ["cyclic", "undamped", "lumped"])
@pytest.mark.parametrize("point", POINTS)
def test_condensation_matches_dense_schur_complement(kind, point):
    model = _model(kind)
    assert list(model.linear.sizes) == ([4, 4] if kind == "lumped" else [9, 12])
    for parameter in (None, "frequency"):
        got = model.condensed(point, parameter)
        for k, (S, F, Y, z) in enumerate(_reference(model, point)):
            # both are direct solves of the same well-conditioned blocks (cond(D_ii) ~ 1e2):
            # they differ by rounding only, ~1e-15 of the entries
            _close(got.S[k], S, 1e-12)
            _close(got.F[k], F, 1e-12)
            _close(got.Y[k], Y, 1e-12)
            _close(got.z[k], z, 1e-12)


@pytest.mark.parametrize("kind", ["cyclic", "undamped", "lumped"])
@pytest.mark.parametrize("parameter", ["frequency", "mass"])
@pytest.mark.parametrize("point", POINTS)
def test_condensation_derivative_matches_central_difference(kind, parameter, point):
    model = _model(kind)
    got = model.condensed(point, parameter)
    value = point.get(parameter)
    step = 1e-5 * value
    plus = model.condensed(point.set(parameter, value + step))
    minus = model.condensed(point.set(parameter, value - step))
    # central difference: truncation step^2 |S'''| / 6 ~ 1e-10 (no resonance near the
    # points), rounding eps |S| / step ~ 1e-10 of dS (|S| ~ 10 |dS|); seen up to 1e-9. 1e-7
    # leaves a margin while a wrong term (e.g. a missing L (dD_ic - dD_ii Y)) is O(1)
    eye = np.broadcast_to(np.eye(got.S.shape[1]), got.S.shape)
    _close(got.dS_product(eye), (plus.S - minus.S) / (2 * step), 1e-7)
    _close(got.dF, (plus.F - minus.F) / (2 * step), 1e-7)
    assert np.abs(got.dF[0]).max() > 0  # the rotating load: order 0 is exercised too


def test_reordered_linear_part_is_built_once_and_counted(monkeypatch):
    monkeypatch.setattr(hbm._Cache, "LIMIT", 1)  # every new point evicts the previous one
    model = _model()
    first = model.reordered()
    for w in (0.5, 0.6, 0.7):
        model.condensed(OperatingPoint(w), "frequency")
    assert model.reordered() is first  # pinned: never evicted
    last = model.condensed(OperatingPoint(0.7), "frequency")
    assert model._cache._bytes == first.nbytes + last.nbytes


@pytest.mark.parametrize("orders", [(0, 1), (0, 1, 3), (1, 2)])
def test_real_matrix_matches_its_formula(orders):
    """``X_n = a_n - i b_n``: y_a = Re S a + Im S b, y_b = -Im S a + Re S b; order 0 Re S."""
    h = Harmonics(orders)
    n, nc = 5, h.n_coeffs
    rng = np.random.default_rng(2)
    S = rng.normal(size=(len(orders), n, n)) + 1j * rng.normal(size=(len(orders), n, n))
    ref = np.zeros((n * nc, n * nc))
    for k, o in enumerate(orders):
        for i in range(n):
            for j in range(n):
                re, im = S[k, i, j].real, S[k, i, j].imag
                if o == 0:
                    ref[i * nc, j * nc] = re
                    continue
                a = int(h.has_static) + 2 * h.dynamic_orders.index(o)  # a_n, then b_n
                ref[i * nc + a, j * nc + a] = re
                ref[i * nc + a, j * nc + a + 1] = im
                ref[i * nc + a + 1, j * nc + a] = -im
                ref[i * nc + a + 1, j * nc + a + 1] = re
    assert np.array_equal(h.real_matrix(S), ref)  # pure copies: bit for bit
    x = rng.normal(size=n * nc)
    np.testing.assert_allclose(h.real_apply(S, x), ref @ x, rtol=0, atol=1e-13)


def test_a_block_diagonal_matrix_held_by_its_blocks_is_the_dense_one():
    """Three bodies of 2, 2 and 3 DOFs interleaved (a permutation away from block-diagonal):
    the blocks found from the pattern, their products (real and complex vectors, one and
    several), inverse and determinant's sign against numpy's on the dense matrix (both
    exact to rounding: 1e-12 of the norms)."""
    from microslip.solve.blocks import BlockDiagonal

    rng = np.random.default_rng(4)
    body = np.array([0, 1, 2, 0, 2, 1, 2])
    A = np.where(body[:, None] == body[None, :], rng.normal(size=(7, 7)), 0.0) + 3 * np.eye(7)
    blocks = BlockDiagonal.of(A)
    assert sorted(i.shape[1] * i.shape[0] for i in blocks.index) == [3, 4]  # 2 x 2, 1 x 3
    assert blocks.largest == 3
    np.testing.assert_array_equal(blocks.dense(), A)
    for x in (rng.normal(size=7), rng.normal(size=(7, 2)) + 1j * rng.normal(size=(7, 2))):
        np.testing.assert_allclose(blocks.product(x), A @ x, rtol=0, atol=1e-12 * np.abs(x).max())
    np.testing.assert_allclose(blocks.inverse().dense(), np.linalg.inv(A), atol=1e-12)
    assert blocks.sign() == np.sign(np.linalg.det(A))
    A[6, 6] = -50.0  # a negative determinant
    assert BlockDiagonal.of(A).sign() == np.sign(np.linalg.det(A)) == -1.0


def test_the_static_condensation_is_held_per_body():
    """Two bodies, each with contact and other DOFs: S_0 (the Schur complement on the
    contact DOFs) by its blocks against the dense Schur complement, one block a body."""
    from microslip.solve.modal_condensation import StaticPart

    rng = np.random.default_rng(5)
    body = np.array([0, 1, 0, 1, 0, 0, 1, 1])  # contact DOFs: the first 4
    R = rng.normal(size=(8, 8))
    D = np.where(body[:, None] == body[None, :], R + R.T, 0.0) + 8 * np.eye(8)
    s = StaticPart.of(D, 4)
    want = D[:4, :4] - D[:4, 4:] @ np.linalg.solve(D[4:, 4:], D[4:, :4])
    np.testing.assert_allclose(s.S, want, atol=1e-13 * np.abs(want).max())
    assert [i.shape for i in s.blocks.index] == [(2, 2)]  # two bodies of 2 contact DOFs
    x = rng.normal(size=(4, 3)) + 1j * rng.normal(size=(4, 3))
    np.testing.assert_allclose(s.product(x), want @ x, atol=1e-12 * np.abs(want @ x).max())
    # a weak tie between the bodies (as a static condensation's between a damper and its
    # platforms): the bodies' blocks as given, the tie held apart, the same S_0 and products
    D[0, 1] = D[1, 0] = 0.1
    s = StaticPart.of(D, 4, [np.array([0, 2]), np.array([1, 3])])
    want = D[:4, :4] - D[:4, 4:] @ np.linalg.solve(D[4:, 4:], D[4:, :4])
    np.testing.assert_allclose(s.S, want, atol=1e-13 * np.abs(want).max())
    assert [i.shape for i in s.blocks.index] == [(2, 2)] and s.blocks.rest.nnz > 0
    np.testing.assert_allclose(s.product(x), want @ x, atol=1e-12 * np.abs(want @ x).max())
