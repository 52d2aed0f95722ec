"""The lowest modes of a sparse symmetric (or Hermitian) pencil K x = lambda M x: dense
below a size, else ARPACK or a block shift-invert Krylov solver (``lowest_modes``, with an
upper bound on the eigenvalues kept), on a factorization of ``linalg``; and the
Rayleigh-Ritz step that makes a basis' projection diagonal."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from . import linalg
from .linalg import Factor, fmul, spmm

#: Below this size eigen-problems are solved densely (LAPACK), faster than ARPACK there.
_DENSE_LIMIT = 500


class EigenSolverError(RuntimeError):
    """The block Krylov eigen-solve did not converge (the message says how far it got)."""


def rayleigh_ritz(K: sp.spmatrix, M: sp.spmatrix, V: NDArray) -> tuple[NDArray, NDArray]:
    """Eigenpairs of (K, M) projected on span(V): ascending eigenvalues, M-orthonormal vectors.

    Cleans up ARPACK output (degenerate pairs, complex round-off) so that Phi^H M Phi = I and
    Phi^H K Phi = diag(lambda) hold to round-off.
    """
    KV = spmm(K, V)
    MV = spmm(M, V)
    Kr = V.conj().T @ KV
    Mr = V.conj().T @ MV
    Kr = 0.5 * (Kr + Kr.conj().T)
    Mr = 0.5 * (Mr + Mr.conj().T)
    lam, Q = sla.eigh(Kr, Mr)
    return lam, V @ Q


def lowest_modes(
    K: sp.spmatrix,
    M: sp.spmatrix,
    k: int,
    factor: Factor | None = None,
    sigma: float = 0.0,
    backend: str | None = None,
    tol: float = 1e-12,
    upper: float | Callable[[NDArray], float] | None = None,
    method: str = "block",
    block: int | None = None,
) -> tuple[NDArray[np.float64], NDArray]:
    """The k lowest eigenpairs of K phi = lambda M phi, by shift-invert about ``sigma``.

    K, M: (n, n) real symmetric or complex Hermitian; M positive definite; ``sigma`` below the
    wanted eigenvalues (0 for a constrained body, negative for a free one).
    factor: a factorization of K - sigma M to reuse (else one is made).
    tol: relative residual ||K x - lambda M x|| / ||K x|| of every returned pair (eigenvalue
        errors are of the order of its square).
    upper: also return every eigenpair below this bound [rad^2/s^2]; a callable gets the k
        lowest eigenvalues and returns the bound (mode selection by cut-off).
    method: "block" (block shift-invert Krylov with thick restarts: many right-hand sides per
        solve) or "arpack" (SciPy's eigsh / eigs, one right-hand side per solve; no ``upper``).
    Returns lambda (k',) ascending [rad^2/s^2], k' >= k, and Phi (n, k') with Phi^H M Phi = I.
    """
    n = K.shape[0]
    if not (isinstance(k, int | np.integer) and 0 < k <= n):
        raise ValueError(f"k={k!r}: number of modes must satisfy 0 < k <= n = {n}")
    if method not in ("block", "arpack"):
        raise ValueError(f"method={method!r}: 'block' or 'arpack'")
    W = getattr(factor, "constraint", None)
    if n <= _DENSE_LIMIT or (k >= n // 2 and upper is None):
        # Small or nearly complete spectra: dense LAPACK is faster and always complete.
        if W is None:
            lam, V = sla.eigh(K.toarray(), M.toarray())
        else:  # on W's null space (the averaged masters held)
            N = sla.null_space(W.toarray())
            KN, MN = (np.asarray(A @ N) for A in (K, M))
            lam, V = sla.eigh(N.conj().T @ KN, N.conj().T @ MN)
            V = N @ V
        count = k if upper is None else max(k, int(np.sum(lam <= _bound(upper, lam[:k]))))
        return lam[:count], V[:, :count]
    if factor is None:
        shifted = K - sigma * M if sigma != 0.0 else K
        factor = linalg.factorize(shifted, backend=backend, positive_definite=sigma <= 0.0)
    if method == "block":
        return _block_krylov(K, M, int(k), factor, sigma, tol, upper, block)
    if upper is not None:
        raise ValueError("upper= needs method='block'")
    dtype = np.result_type(K.dtype, M.dtype)
    op = spla.LinearOperator((n, n), matvec=factor.solve, matmat=factor.solve, dtype=dtype)
    ncv = min(n, max(2 * k + 1, k + 20))
    v0 = np.ones(n, dtype=dtype)  # deterministic start vector
    if np.iscomplexobj(K) or np.iscomplexobj(M):
        _, V = spla.eigs(K, k=k, M=M, sigma=sigma, OPinv=op, which="LM", ncv=ncv, tol=tol,
                         v0=v0)
    else:
        _, V = spla.eigsh(K, k=k, M=M, sigma=sigma, OPinv=op, which="LM", ncv=ncv, tol=tol,
                          v0=v0)
    return rayleigh_ritz(K, M, V)


def _bound(upper: float | Callable[[NDArray], float] | None, lam_k: NDArray) -> float:
    if upper is None:
        return -np.inf
    return float(upper(lam_k)) if callable(upper) else float(upper)


#: Default block size of the block Krylov solver (right-hand sides per solve). The number of
#: block steps hardly falls with the block size (150k-DOF blisk sector, 30 modes: 20 / 18 / 16 /
#: 14 / 12 steps for b = 6 / 8 / 12 / 16 / 24) while each step's solve is memory-bound (reads the
#: whole factor) and its orthogonalization grows with b; eigen time, real ND 0: 7.5 / 6.2 / 7.1 /
#: 7.1 / 7.2 s, complex ND 1 (b = 8 / 12 / 16): 14.1 / 15.1 / 16.0 s. ARPACK (single vectors)
#: needs ~80 solves.
BLOCK = 8


#: Thick restarts after which the block Krylov solver gives up (converging problems need 1-3).
MAX_RESTARTS = 20


#: Basis size before a thick restart: _BASIS x wanted + 3 blocks (3: fewest solves per mode
#: for the blisk sector, measured against 2 and 4).
_BASIS = 3


def _block_krylov(
    K: sp.spmatrix,
    M: sp.spmatrix,
    k: int,
    factor: Factor,
    sigma: float,
    tol: float,
    upper: float | Callable[[NDArray], float] | None,
    block: int | None,
) -> tuple[NDArray[np.float64], NDArray]:
    """Block shift-invert Lanczos with full M-orthogonalization and thick (Krylov-Schur)
    restarts, for the operator S = (K - sigma M)^-1 M (self-adjoint in the M inner product).

    Each step applies S to a whole block of b vectors in ONE multi-right-hand-side solve (the
    factor is read once per block instead of once per vector as in ARPACK). Ritz pairs come from
    H = V^H M S V. Only the last block's images leave span(V), so the residual of a Ritz pair is
    ||S x - nu x||_M = ||Z y_last||_M with Z the new block before normalization; it is tested as
    ARPACK does, <= tol |nu| (lambda = sigma + 1/nu), and checked explicitly at the end. A full
    basis is restarted on the wanted Ritz vectors plus one block (H becomes diagonal there) and
    the Krylov sequence continues from the new block, which holds every residual.
    """
    n = K.shape[0]
    dtype = np.result_type(K.dtype, M.dtype, np.float64)
    b = max(1, min(int(block or BLOCK), n // 4))
    rng = np.random.default_rng(12345)  # deterministic start block
    cap = min(n, _BASIS * k + 3 * b)
    # Column-major: the leading columns V[:, :m] are contiguous, so BLAS reads them in place
    # (a row-major basis made every product copy n x m first: 1/3 of the eigen time).
    V, MV, SV = (np.empty((n, cap), dtype=dtype, order="F") for _ in range(3))
    H = np.zeros((cap, cap), dtype=dtype)
    m = 0
    W, MW = _start_block(rng, (n, b), dtype, factor, M)
    wanted, bound = k, None
    restarts = 0
    for _ in range(max(200, 4 * n // b)):
        j = W.shape[1]
        if m + j > cap:  # a cut-off asked for more modes: grow the basis storage
            cap = min(n, max(m + j, _BASIS * wanted + 3 * b))
            V, MV, SV = (_grown(A, m, cap) for A in (V, MV, SV))
            H = np.pad(H[:m, :m], ((0, cap - m), (0, cap - m)))
        SW = factor.solve(MW).astype(dtype, copy=False)
        V[:, m : m + j], MV[:, m : m + j], SV[:, m : m + j] = W, MW, SW
        m += j
        # H's new columns V^H M S W are the first Gram-Schmidt coefficients of S W.
        Z, MZ, G, C = _m_orthogonalize(SW, V[:, :m], MV[:, :m], M)
        H[:m, m - j : m] = C
        H[m - j : m, : m - j] = C[: m - j].conj().T
        nu, Y, res = _ritz_pairs(H[:m, :m], G, j)
        theta = sigma + 1.0 / nu
        converged = (res <= tol) & (nu > 0)
        if m >= k and (converged[:k].all() or m >= n):
            if bound is None and upper is not None:
                bound = _bound(upper, theta[:k])
            wanted = k if bound is None else max(k, int(np.sum((theta <= bound) & (nu > 0))))
            # Done when the wanted pairs converged and, with a bound, also the first pair
            # above it (Ritz values are upper bounds: no eigenvalue hides below the bound).
            need = wanted + (bound is not None)
            if (need <= m and converged[:need].all()) or m >= n:
                X = V[:, :m] @ Y[:, :wanted]
                _check_residuals(M, X, SV[:, :m] @ Y[:, :wanted], nu[:wanted], tol, m < n)
                return rayleigh_ritz(K, M, X)
        W, MW = _svqb(Z, MZ)
        if W.shape[1] == 0:  # invariant subspace: continue from fresh random directions
            fresh = _in_range(rng.standard_normal((n, b)).astype(dtype), factor, M, dtype)
            W, MW, *_ = _m_orthogonalize(fresh, V[:, :m], MV[:, :m], M)
            W, MW = _svqb(W, MW)
        if m + W.shape[1] > _BASIS * wanted + 3 * b:
            # Thick restart on the wanted Ritz vectors and one block beyond: H is diagonal
            # there, and S maps their span into span(itself, W): the Krylov structure holds.
            restarts += 1
            _check_restarts(restarts, wanted, float(res[:wanted].max()), tol)
            m = _thick_restart((V, MV, SV), H, Y, nu, m, min(m, wanted + b))
    raise EigenSolverError(f"block Krylov: no convergence for k={k} (tol={tol})")


def _start_block(rng: np.random.Generator, shape: tuple[int, int], dtype, factor: Factor,
                 M: sp.spmatrix) -> tuple[NDArray, NDArray]:
    """The M-orthonormal random start block W (n, b) (complex for a complex operator) and
    M W, in the range of S."""
    W = rng.standard_normal(shape)
    if np.issubdtype(dtype, np.complexfloating):
        W = W + 1j * rng.standard_normal(shape)
    W = _in_range(W, factor, M, dtype).astype(dtype)
    empty = np.empty((shape[0], 0), dtype=dtype, order="F")
    W, MW, *_ = _m_orthogonalize(W, empty, empty, M)
    return _svqb(W, MW)


def _check_restarts(restarts: int, wanted: int, worst: float, tol: float) -> None:
    """EigenSolverError past MAX_RESTARTS thick restarts: converging problems need 1-3
    (blisk sectors); a tol below the estimate's round-off floor (a few eps) would otherwise
    spin for thousands of steps."""
    if restarts > MAX_RESTARTS:
        raise EigenSolverError(
            f"block Krylov: {wanted} modes not converged after {MAX_RESTARTS} restarts "
            f"(worst residual {worst:.1e} > tol {tol:.1e}; a tol near the round-off "
            "floor cannot be met: raise it)")


def _in_range(W: NDArray, factor: Factor, M: sp.spmatrix, dtype) -> NDArray:
    """A start block where S maps (W x = 0) when the factor carries a constraint, else W."""
    if getattr(factor, "constraint", None) is not None:
        return factor.solve(spmm(M, W.astype(dtype)))
    return W


def _ritz_pairs(Hm: NDArray, G: NDArray, j: int) -> tuple[NDArray, NDArray, NDArray]:
    """Ritz values nu (m,) of the projected operator Hm (m, m), largest first (nearest above
    sigma), their vectors Y (m, m) and residual estimates ||Z y_last||_M / |nu| (m,) from the
    Gram matrix G (j, j) of the new block Z."""
    nu, Y = sla.eigh(0.5 * (Hm + Hm.conj().T))
    nu, Y = nu[::-1], Y[:, ::-1]
    Yl = Y[-j:]
    res = np.sqrt(np.abs(np.einsum("ij,ik,kj->j", Yl.conj(), G, Yl))) / np.abs(nu)
    return nu, Y, res


def _check_residuals(M: sp.spmatrix, X: NDArray, SX: NDArray, nu: NDArray, tol: float,
                     partial: bool) -> None:
    """EigenSolverError when the explicit residuals ||S x - nu x||_M / nu of the Ritz
    vectors X (n, k) (SX = S X) show a loss of orthogonality (``partial``: the basis is not
    the whole space)."""
    R = SX - X * nu
    err = np.sqrt(np.abs(np.einsum("ij,ij->j", R.conj(), spmm(M, R)))) / nu
    # The explicit residual can sit above tol at the round-off floor of an ill-conditioned K
    # (the computed S is self-adjoint only to ~eps cond(K); a slender P2 beam: 1e-9). Past
    # 10 tol (and 1e-6) something is broken.
    if partial and err.max() > max(10 * tol, 1e-6):
        raise EigenSolverError(f"block Krylov: residual {err.max():.2e} > {tol:.1e} after "
                               "convergence (loss of orthogonality)")


def _thick_restart(bases: tuple[NDArray, ...], H: NDArray, Y: NDArray, nu: NDArray, m: int,
                   keep: int) -> int:
    """Restart the bases (V, M V, S V) in place on their first ``keep`` Ritz vectors (H
    becomes diag(nu) there); the new basis size."""
    for A in bases:
        A[:, :keep] = fmul(A[:, :m], Y[:, :keep])
    H[:keep, :keep] = np.diag(nu[:keep])
    return keep


def _grown(A: NDArray, m: int, cap: int) -> NDArray:
    """A column-major (n, cap) array holding the first m columns of A."""
    out = np.empty((A.shape[0], cap), dtype=A.dtype, order="F")
    out[:, :m] = A[:, :m]
    return out


def _m_orthogonalize(
    Z: NDArray, V: NDArray, MV: NDArray, M: sp.spmatrix
) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Z - V V^H M Z by block classical Gram-Schmidt against the M-orthonormal V, with a second
    pass only where the first cancelled more than half of a column's M-norm squared (the DGKS
    criterion: "twice is enough", and once is when little cancels).

    Returns (Z, M Z, Z^H M Z, C) with C = V^H M Z of the first pass (m, k); Z (n, k)
    column-major, like the basis.
    """
    Z = np.asfortranarray(Z)
    MZ = spmm(M, Z)
    if V.shape[1] == 0:
        G = Z.conj().T @ MZ
        return Z, MZ, 0.5 * (G + G.conj().T), np.zeros((0, Z.shape[1]), dtype=Z.dtype)
    before = np.einsum("ij,ij->j", Z.conj(), MZ).real
    C = (Z.conj().T @ MV).conj().T  # conjugates the thin block only
    Z = Z - fmul(V, C)
    MZ = MZ - fmul(MV, C)
    G = Z.conj().T @ MZ
    if np.any(np.diag(G).real < 0.5 * before):
        C2 = (Z.conj().T @ MV).conj().T
        Z = Z - fmul(V, C2)
        # M Z afresh, not by the recurrence MZ - MV C2: after heavy cancellation (a block
        # nearly inside span(V), as when Ritz vectors converge) the recurrence keeps an
        # absolute error eps ||M Z_before||, which _svqb scales up with the small remainder
        # and each thick restart feeds back into MV: residuals then grow ~3x per restart and
        # never reach tol (42 modes of a 2.3k-DOF sector, numpy 2.4 / scipy 1.17).
        MZ = spmm(M, Z)
        G = Z.conj().T @ MZ
    return Z, MZ, 0.5 * (G + G.conj().T), C


def _svqb(Z: NDArray, MZ: NDArray) -> tuple[NDArray, NDArray]:
    """M-orthonormalize a block (eigen-decomposition of its Gram matrix), dropping numerically
    dependent directions. Returns (Z, M Z)."""
    if Z.shape[1] == 0:
        return Z, MZ
    G = Z.conj().T @ MZ
    s, U = sla.eigh(0.5 * (G + G.conj().T))
    keep = s > 1e-24 * max(float(s.max()), 1e-300)
    T = U[:, keep] / np.sqrt(s[keep])
    return fmul(Z, T), fmul(MZ, T)
