"""The structured Jacobian of the balance (pipeline/solve/jacobian.py) against the dense one:
its products, its order-diagonal preconditioner, its solves and its determinant's sign, and
continuation with it against continuation with dense LUs."""

import numpy as np
import pytest
from models import friction_grid, three_dof_cyclic_like

from microslip.fourier import Harmonics
from microslip.solve import continuation as cont
from microslip.solve import hbm, jacobian
from microslip.solve.linear import OperatingPoint
from microslip.solve.response import solve_point, sweep

MODELS = {
    "grid, disjoint, cyclic": lambda: friction_grid(6, H=3, cyclic=True),
    "grid, shared nodes, real": lambda: friction_grid(6, H=3, cyclic=False, shared=True),
    "three DOFs, two laws": lambda: three_dof_cyclic_like(Harmonics.up_to(3, 128)),
    # 24 damper-like bodies of 3 DOFs beside one of 72 contact DOFs: the preconditioner
    # eliminates the small bodies first (jacobian.SMALL_BODY)
    "grid, small bodies": lambda: friction_grid(24, H=2, cyclic=True, dampers=True),
}


def _slipping_state(hb, w):
    """A converged state in partial slip (the contact Jacobian is far from the stuck one)
    and the point."""
    p = OperatingPoint(w)
    r = solve_point(hb, p)
    assert r.converged
    return r.x, p


@pytest.fixture(scope="module", params=list(MODELS))
def state(request):
    hb = MODELS[request.param]()
    x, p = _slipping_state(hb, 1.9)
    x = x + 0.01 * np.random.default_rng(0).normal(size=x.size) * np.max(np.abs(x))
    R, J, dR = hb.residual(x, p, "frequency")
    R2, Js, dR2 = hb.residual(x, p, "frequency", structured=True)
    return hb, J, Js, R, dR


def test_products_and_matrix_are_the_dense_jacobian(state):
    hb, J, Js, R, _ = state
    assert Js.shape == J.shape
    # the same floating-point sums in another order: rounding of the entries' size
    assert np.max(np.abs(Js.dense() - J)) <= 1e-13 * np.max(np.abs(J))
    V = np.random.default_rng(1).normal(size=(3, J.shape[0]))
    for v in V:
        assert np.linalg.norm(Js.matvec(v) - J @ v) <= 1e-13 * np.linalg.norm(J) * \
            np.linalg.norm(v)


def test_order_blocks_are_the_complex_part_of_the_order_diagonal(state):
    """Independent of the per-point projection: from the dense matrix's slices."""
    hb, J, Js, _, _ = state
    h = hb.harmonics
    nd, nc = hb.dofs.size, h.n_coeffs
    J4 = J.reshape(nd, nc, nd, nc)
    blocks = Js.order_blocks()
    k0 = int(h.has_static)
    if h.has_static:
        assert np.max(np.abs(blocks[0] - J4[:, 0, :, 0])) <= 1e-13 * np.max(np.abs(J))
    for k, (a, b) in enumerate(zip(h.cos_index, h.sin_index)):
        want = 0.5 * (J4[:, a, :, a] + J4[:, b, :, b]) + 0.5j * (J4[:, a, :, b] - J4[:, b, :, a])
        assert np.max(np.abs(blocks[k0 + k] - want)) <= 1e-13 * np.max(np.abs(J))


def test_the_preconditioner_eliminates_the_small_bodies_first_exactly(monkeypatch):
    """Its per-order factors by the split (the dampers' blocks inverted, the Schur
    complement on the large body factored) against those of the whole order blocks, in
    double precision: both are the order-diagonal part's inverse, so they agree to the
    blocks' condition number (below 100) times rounding (measured 1.5e-15: 1e-10 leaves
    room), and so do the signs of the determinant."""
    hb = MODELS["grid, small bodies"]()
    x, p = _slipping_state(hb, 1.9)
    Js = hb.residual(x, p, "frequency", structured=True)[1]
    split = jacobian._Factors.of(Js, single=False)
    for f in split.factors:  # the 24 dampers' 3 DOFs apart; the large body's 72 left
        assert f.split is not None and f.split.b.size == 72
        assert sorted(p.size for p in f.split.parts) == [3] * 24
    monkeypatch.setattr(jacobian._Split, "of", classmethod(lambda cls, *a: None))
    whole = jacobian._Factors.of(Js, single=False)
    assert whole.factors[0].split is None
    V = np.random.default_rng(3).normal(size=(3, Js.shape[0]))
    for v in V:
        ref = whole.solve(v)
        assert np.linalg.norm(split.solve(v) - ref) <= 1e-10 * np.linalg.norm(ref)
    assert split.sign == whole.sign == np.sign(np.linalg.det(Js.order_blocks()[0].real))


def test_solves_match_dense_solves(state):
    hb, J, Js, R, dR = state
    hb.preconditioner.__init__()  # fresh counters and no factors
    x = Js.solve(R)
    ref = np.linalg.solve(J, R)
    # GMRES to RTOL = 1e-10 of the right side; the error is at most cond(J) times that
    cond = np.linalg.cond(J)
    assert np.linalg.norm(x - ref) <= 10 * jacobian.RTOL * cond * np.linalg.norm(ref)
    assert np.linalg.norm(J @ x - R) <= 2 * jacobian.RTOL * np.linalg.norm(R)
    rng = np.random.default_rng(2)
    row, corner = rng.normal(size=R.size), 0.7
    A = np.block([[J, dR[:, None]], [np.append(row, corner)[None, :]]])
    rhs = rng.normal(size=R.size + 1)
    z = Js.bordered_solve(dR, row, corner, rhs)
    assert np.linalg.norm(A @ z - rhs) <= 2 * jacobian.RTOL * np.linalg.norm(rhs)
    assert hb.preconditioner.refreshes == 1 and hb.preconditioner.solves == 2


def test_determinant_sign_is_the_dense_one(state):
    """Both signs occur: the corner's sign flips that of the Schur complement when it
    dominates; a row along -J^-T ... makes it small."""
    hb, J, Js, R, dR = state
    rng = np.random.default_rng(3)
    signs = set()
    for corner in (-50.0, -0.3, 0.0, 0.3, 50.0):
        row = rng.normal(size=R.size)
        A = np.block([[J, dR[:, None]], [np.append(row, corner)[None, :]]])
        want = np.linalg.slogdet(A)[0]
        assert Js.bordered_sign(dR, row, corner) == want
        signs.add(want)
    assert signs == {-1.0, 1.0}


def _bordered(Js, J, k: int, seed: int):
    """A random positive scaling of J bordered by k rows and columns: structured and dense."""
    rng = np.random.default_rng(seed)
    n = J.shape[0]
    r, c = rng.uniform(0.5, 2.0, n), rng.uniform(0.5, 2.0, n)
    cols, rows, corner = rng.normal(size=(n, k)), rng.normal(size=(k, n)), \
        rng.normal(size=(k, k))
    Bs = jacobian.BorderedJacobian(Js, r, c, cols, rows, corner)
    B = np.block([[r[:, None] * J * c[None, :], cols], [rows, corner]])
    return Bs, B


def test_a_bordered_jacobian_is_its_dense_matrix_and_solves_like_it(state):
    """Two borders (a nonlinear mode's frequency and self-excitation, amplitude and phase)
    and one more (the arclength's): products, solves and the determinant's sign against the
    dense bordered matrix."""
    hb, J, Js, R, dR = state
    Bs, B = _bordered(Js, J, 2, 4)
    assert np.max(np.abs(Bs.dense() - B)) <= 1e-13 * np.max(np.abs(B))
    v = np.random.default_rng(5).normal(size=B.shape[0])
    assert np.linalg.norm(Bs.matvec(v) - B @ v) <= 1e-13 * np.linalg.norm(B) * np.linalg.norm(v)
    rhs = np.random.default_rng(6).normal(size=B.shape[0])
    # GMRES to RTOL of the right side (the true residual is the one tested)
    assert np.linalg.norm(B @ Bs.solve(rhs) - rhs) <= 2 * jacobian.RTOL * np.linalg.norm(rhs)
    rng = np.random.default_rng(7)
    signs = set()
    for corner in (-50.0, 0.0, 50.0):
        col, row = rng.normal(size=B.shape[0]), rng.normal(size=B.shape[0])
        A = np.block([[B, col[:, None]], [np.append(row, corner)[None, :]]])
        z = Bs.bordered_solve(col, row, corner, np.append(rhs, 1.0))
        assert np.linalg.norm(A @ z - np.append(rhs, 1.0)) <= \
            2 * jacobian.RTOL * np.linalg.norm(np.append(rhs, 1.0))
        want = np.linalg.slogdet(A)[0]
        assert Bs.bordered_sign(col, row, corner) == want
        signs.add(want)
    assert signs == {-1.0, 1.0}


def test_gmres_solves_a_nonsymmetric_system_and_reports_failure():
    rng = np.random.default_rng(4)
    A = np.eye(60) + 0.3 * rng.normal(size=(60, 60)) / np.sqrt(60)
    b = rng.normal(size=60)
    x, its, H = jacobian.gmres(lambda v: A @ v, lambda v: v, b, rtol=1e-12)
    assert np.linalg.norm(A @ x - b) <= 1e-11 * np.linalg.norm(b)
    assert H.shape == (its, its) and np.linalg.slogdet(H)[0] == np.linalg.slogdet(A)[0]
    # a preconditioner that is the inverse: one iteration
    inv = np.linalg.inv(A)
    assert jacobian.gmres(lambda v: A @ v, lambda v: inv @ v, b)[1] == 1
    with pytest.raises(np.linalg.LinAlgError):
        jacobian.gmres(lambda v: A @ v, lambda v: v, b, rtol=1e-14, max_iter=5)


def test_old_factors_are_reused_until_slow_then_refreshed():
    hb = friction_grid(6, H=3)
    x, p = _slipping_state(hb, 1.9)
    pc = hb.preconditioner
    pc.__init__()
    _, J1, _ = hb.residual(x, p, structured=True)
    J1.solve(np.ones(x.size))
    assert pc.refreshes == 1
    _, J2, _ = hb.residual(x * 1.001, p.set("frequency", 1.901), structured=True)
    J2.solve(np.ones(x.size))  # a neighbour: the old factors serve
    assert pc.refreshes == 1
    # far away (stuck, another frequency): converged slowly or not at all on the old
    # factors, so they are made again from the Jacobian at hand
    _, J3, _ = hb.residual(np.zeros(x.size), p.set("frequency", 0.5), structured=True)
    before = pc.iterations
    J3.solve(np.ones(x.size))
    assert pc.refreshes == 2 or pc.iterations - before <= jacobian.REFRESH_ITERATIONS


def test_inexact_newton_converges_to_the_same_point_with_fewer_krylov_iterations(monkeypatch):
    """Newton's steps solved only as far as each iteration needs (newton.forcing) against
    every step to GMRES's default 1e-10: the same converged point (both to tol = 1e-9 of
    the force scale: their difference is what that leaves, held to 1e-8 of the solution;
    measured 1.2e-12), no more Newton iterations (7 both), fewer Krylov iterations (147
    against 275)."""
    from microslip.solve import newton as newton_module

    monkeypatch.setattr(hbm, "STRUCTURED_FROM", 0)
    hb = friction_grid(6, H=3)
    assert hb.structured
    p = OperatingPoint(1.9)
    runs = {}
    for inexact in (True, False):
        if not inexact:
            monkeypatch.setattr(newton_module, "forcing", lambda *a: jacobian.RTOL)
        hb.preconditioner.__init__()
        r = solve_point(hb, p)
        assert r.converged
        runs[inexact] = (r, hb.preconditioner.iterations)
    (loose, k_loose), (tight, k_tight) = runs[True], runs[False]
    assert loose.iterations <= tight.iterations and k_loose < 0.8 * k_tight
    assert np.max(np.abs(loose.x - tight.x)) <= 1e-8 * np.max(np.abs(tight.x))


def test_the_forcing_term_is_as_loose_as_the_iteration_allows():
    """GMRES's tolerance for a step: the tight default far from the solution at the first
    iterate, Eisenstat & Walker's 0.9 (r_k / r_k-1)^2 where Newton converges, what the next
    iterate's convergence needs near the solution, never looser than ETA_MAX."""
    from microslip.solve.newton import ETA_MAX, forcing

    assert forcing(1.0, None, 1e-9) == pytest.approx(jacobian.RTOL)  # far, first: the tight default
    assert forcing(1e-3, 1e-2, 1e-9) == ETA_MAX  # Eisenstat & Walker's 9e-3, capped
    assert forcing(1e-3, 1.0, 1e-9) == pytest.approx(9e-7)  # Eisenstat & Walker's
    assert forcing(1e-5, 1.0, 1e-9) == pytest.approx(1e-5)  # what convergence needs
    assert forcing(0.0, 1.0, 1e-9) == ETA_MAX


@pytest.mark.slow  # (a whole sweep each, 3.7 s: the structured products, solves and signs
# against the dense matrix are fast tests of their own)
@pytest.mark.parametrize("model", ["grid, disjoint, cyclic", "grid, shared nodes, real"])
def test_continuation_with_structured_solves_follows_the_dense_branch(model, monkeypatch):
    """The same arclength sweep through the resonance, every Newton step by GMRES or by a
    dense LU: the same points (the step sizes follow the iteration counts, so one different
    count would shift every later point: they must agree one to one)."""
    out = {}
    for structured in (False, True):
        monkeypatch.setattr(hbm, "STRUCTURED_FROM", 0 if structured else 10**9)
        hb = friction_grid(6, H=1, cyclic="cyclic" in model, shared="shared" in model)
        assert hb.structured == structured
        r = sweep(hb, "frequency", 1.7, 2.3, OperatingPoint(1.7),
                  settings=cont.Settings(max_points=400))
        assert r.branch.complete
        out[structured] = r
    a, b = out[False], out[True]
    assert len(a) == len(b)
    assert list(a.branch.iterations) == list(b.branch.iterations)
    # both converged to tol = 1e-9 of the force scale; the points agree to what that leaves
    # of the step lengths (1e-8 of the range: the comparison script's tolerance)
    assert np.max(np.abs(a.values - b.values)) <= 1e-8 * 0.6
    scale = np.max(np.abs(a.branch.x))
    assert np.max(np.abs(a.branch.x - b.branch.x)) <= 1e-7 * scale


def test_hill_exponents_through_gmres_are_those_through_the_lu(monkeypatch):
    """Hill's shift-and-invert with every solve by GMRES (to HILL_RTOL) finds the exponents
    nearest zero that the dense LU finds (ARPACK on both, to its 1e-10)."""
    from microslip.solve import stability

    hb = friction_grid(6, H=1)
    x, p = _slipping_state(hb, 1.95)
    monkeypatch.setattr(stability, "DENSE", 0)  # ARPACK on both
    ref = stability.hill_stability(hb, x, p)
    monkeypatch.setattr(hbm, "STRUCTURED_FROM", 0)
    monkeypatch.setattr(stability, "HILL_LU", 0)
    assert hb.structured
    got = stability.hill_stability(hb, x, p)
    assert got.stable == ref.stable and got.exponents.size == ref.exponents.size
    # ARPACK's tolerance 1e-10 on 1 / lambda, relative: the exponents to ~1e-8 of |lambda|
    want, have = np.sort_complex(ref.exponents), np.sort_complex(got.exponents)
    assert np.all(np.abs(have - want) <= 1e-7 * np.abs(want) + 1e-9 * p.omega)


def test_a_pickled_model_leaves_its_preconditioner_behind():
    """A model sent to a worker carries no factors: it makes its own, and solves the same."""
    import pickle

    hb = friction_grid(6, H=3)
    x, p = _slipping_state(hb, 1.9)
    _, J, _ = hb.residual(x, p, structured=True)
    b = np.ones(x.size)
    want = J.solve(b)
    assert hb.preconditioner._factors is not None
    copy = pickle.loads(pickle.dumps(hb))
    assert copy.preconditioner._factors is None
    _, J2, _ = copy.residual(x, p, structured=True)
    assert np.linalg.norm(J2.solve(b) - want) <= 1e-8 * np.linalg.norm(want)


def test_the_sign_on_old_factors_is_the_dense_one():
    """Factors made at other states (the continuation keeps them for many points): the
    sign's Arnoldi run either converges on them or goes on with fresh ones, and is right
    (a run cut short would give a random sign: 21 of 40 wrong on the first attempt)."""
    hb = friction_grid(6, H=3)
    x, p = _slipping_state(hb, 1.9)
    R, J, dR = hb.residual(x, p, "frequency")
    rng = np.random.default_rng(7)
    for w_old in (1.5, 1.7, 1.8):
        x_old, p_old = _slipping_state(hb, w_old)
        hb.preconditioner.__init__()
        hb.residual(x_old, p_old, structured=True)[1].solve(np.ones(x.size))  # old factors
        _, Js, _ = hb.residual(x, p, "frequency", structured=True)
        for _ in range(5):
            row, corner = rng.normal(size=R.size), rng.normal()
            A = np.block([[J, dR[:, None]], [np.append(row, corner)[None, :]]])
            assert Js.bordered_sign(dR, row, corner) == np.linalg.slogdet(A)[0]


def test_where_gmres_fails_a_small_system_is_solved_densely(state, monkeypatch):
    """GMRES made to fail at every stage (the order-diagonal preconditioner blind to a
    strong coupling of the orders, as on a whole shrouded disk): the solve, the bordered
    solve and the determinant's sign are the dense ones, each counted; above
    DENSE_FALLBACK the failure is raised as before."""
    hb, J, Js, R, dR = state

    def fails(*args, **kwargs):
        raise np.linalg.LinAlgError("GMRES: no convergence (made to fail)")

    monkeypatch.setattr(jacobian, "gmres", fails)
    hb.preconditioner.__init__()
    # a direct LU of the same matrix: rounding only (cond(J) x machine precision)
    tol = 1e3 * np.finfo(float).eps * np.linalg.cond(J)
    x = Js.solve(R)
    assert np.linalg.norm(x - np.linalg.solve(J, R)) <= tol * np.linalg.norm(x)
    row, corner = np.random.default_rng(4).normal(size=R.size), 0.3
    A = np.block([[J, dR[:, None]], [np.append(row, corner)[None, :]]])
    rhs = np.ones(R.size + 1)
    z = Js.bordered_solve(dR, row, corner, rhs)
    assert np.linalg.norm(z - np.linalg.solve(A, rhs)) <= tol * np.linalg.norm(z)
    assert Js.bordered_sign(dR, row, corner) == np.linalg.slogdet(A)[0]
    assert hb.preconditioner.dense_solves == 2  # the bordered solve and sign share one LU
    for bad in (np.zeros_like(J), np.full_like(J, np.nan)):  # singular, not finite
        monkeypatch.setattr(type(Js), "dense", lambda self, bad=bad: bad.copy())
        with pytest.raises(np.linalg.LinAlgError):
            Js.solve(R + 1.0)  # (another right side: no kept LU is of this matrix)
        hb.preconditioner.__init__()
    monkeypatch.setattr(jacobian, "DENSE_FALLBACK", R.size - 1)
    with pytest.raises(np.linalg.LinAlgError):
        Js.solve(R)
