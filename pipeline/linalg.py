"""Sparse symmetric factorizations and shift-invert eigen-solves.

Backends (``backend=`` argument, or ``None`` for the best available):

- ``"pardiso"``: Intel MKL PARDISO through ``pypardiso`` (PyPI wheels, real matrices only).
  Symmetric positive-definite matrices use its Cholesky (``mtype=2``); a complex Hermitian
  matrix ``A = B + iC`` is factorized as the real symmetric matrix of twice the size
  ``[[B, -C], [C, B]]`` (positive definite when A is), which it solves exactly.
- ``"superlu"``: SciPy's SuperLU with the symmetric-mode ordering (always available, real and
  complex). The fallback.

CHOLMOD (scikit-sparse) has no wheels on PyPI and does not build without the SuiteSparse
headers; python-mumps on PyPI is built against NumPy 1 and fails to import with NumPy 2 (both
measured on this machine), so neither is offered.
"""

from __future__ import annotations

import importlib.util
import os
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

BACKENDS = ("pardiso", "superlu")
#: Below this size eigen-problems are solved densely (LAPACK), faster than ARPACK there.
_DENSE_LIMIT = 500


class Factor(Protocol):
    """A factorization of a square sparse matrix A (n, n)."""

    n: int
    backend: str

    def solve(self, b: NDArray) -> NDArray:
        """x = A^-1 b for b (n,) or (n, k); complex b allowed for a complex or real A."""
        ...

    def free(self) -> None:
        """Release the factor's memory (no further solves)."""
        ...


def available_backends() -> tuple[str, ...]:
    """Backends importable here, best first."""
    found = []
    if importlib.util.find_spec("pypardiso") is not None:
        found.append("pardiso")
    found.append("superlu")
    return tuple(found)


#: Above this many unknowns PARDISO's faster factorization wins; below it SuperLU's lower
#: per-solve overhead does (blisk sector, 20k DOFs: SuperLU 0.7 s factor + 10 ms/solve,
#: PARDISO 1.8 s + 27 ms; 112k DOFs cantilever: SuperLU ~150 s, PARDISO 6 s to factorize).
PARDISO_MIN_SIZE = 50_000


def default_backend(n: int | None = None) -> str:
    """The best available backend for an n x n matrix (PARDISO for large ones if installed)."""
    if n is not None and n < PARDISO_MIN_SIZE:
        return "superlu"
    return available_backends()[0]


def check_backend(backend: str | None, n: int | None = None) -> str:
    """Resolve ``None`` to the default for size n; ValueError for an unknown or unavailable
    backend."""
    if backend is None:
        return default_backend(n)
    if backend not in BACKENDS:
        raise ValueError(f"backend={backend!r}: allowed are {BACKENDS} or None (best available)")
    if backend not in available_backends():
        raise ValueError(
            f"backend={backend!r} is not installed here; available: {available_backends()}"
        )
    return backend


def doubled_real(A: sp.spmatrix) -> sp.csr_matrix:
    """Real symmetric (2n, 2n) form [[Re, -Im], [Im, Re]] of a complex Hermitian A (n, n)."""
    B = sp.csr_matrix(A.real)
    C = sp.csr_matrix(A.imag)
    return sp.bmat([[B, -C], [C, B]], format="csr")


@dataclass
class _SuperLUFactor:
    lu: spla.SuperLU
    n: int
    complex_matrix: bool
    backend: str = "superlu"

    def solve(self, b: NDArray) -> NDArray:
        b = np.asarray(b)
        if np.iscomplexobj(b) and not self.complex_matrix:
            return self.lu.solve(np.ascontiguousarray(b.real)) + 1j * self.lu.solve(
                np.ascontiguousarray(b.imag)
            )
        dtype = np.complex128 if self.complex_matrix else np.float64
        return self.lu.solve(np.asarray(b, dtype=dtype))

    def free(self) -> None:
        self.lu = None  # type: ignore[assignment]


class _PardisoFactor:
    backend = "pardiso"

    def __init__(self, A: sp.spmatrix, positive_definite: bool) -> None:
        # Intel OpenMP threads spin ~200 ms after each call by default, stealing the cores
        # from OpenBLAS between solves (measured: 2.5x slower ARPACK); set before MKL loads.
        os.environ.setdefault("KMP_BLOCKTIME", "0")
        import pypardiso

        self.n = int(A.shape[0])
        self.complex_matrix = np.iscomplexobj(A.data) if sp.issparse(A) else np.iscomplexobj(A)
        real = doubled_real(A) if self.complex_matrix else sp.csr_matrix(A, dtype=np.float64)
        # PARDISO's symmetric types read the upper triangle only.
        self._A = sp.triu(real, format="csr")
        self._A.sort_indices()
        self._solver = pypardiso.PyPardisoSolver(mtype=2 if positive_definite else -2)
        # Hash the matrix once at factorization, and recognise it by identity afterwards
        # (pypardiso would otherwise compare or hash the whole matrix on every solve).
        self._solver.size_limit_storage = 0
        self._solver._is_already_factorized = lambda M: M is self._A
        self._solver.factorize(self._A)

    def _solve_real(self, b: NDArray) -> NDArray:
        # One thread for single-vector triangular solves: they are memory-bound, and with
        # the cores shared, OpenMP barriers made each ARPACK solve ~20x slower (measured).
        if b.shape[1] > 2:  # block solves (static modes) keep MKL's threads
            return self._solver.solve(self._A, np.asfortranarray(b, dtype=np.float64))
        mkl = self._solver.libmkl
        previous = mkl.MKL_Set_Num_Threads_Local(1)
        try:
            return self._solver.solve(self._A, np.asfortranarray(b, dtype=np.float64))
        finally:
            mkl.MKL_Set_Num_Threads_Local(previous)

    def solve(self, b: NDArray) -> NDArray:
        b = np.asarray(b)
        vector = b.ndim == 1
        b2 = b.reshape(self.n, -1)
        if self.complex_matrix:
            x = self._solve_real(np.concatenate([b2.real, b2.imag]))
            out = x[: self.n] + 1j * x[self.n :]
        elif np.iscomplexobj(b2):
            k = b2.shape[1]
            x = self._solve_real(np.concatenate([b2.real, b2.imag], axis=1))
            out = x[:, :k] + 1j * x[:, k:]
        else:
            out = self._solve_real(b2)
        return out.ravel() if vector else out

    def free(self) -> None:
        self._solver.free_memory(everything=True)


def factorize(
    A: sp.spmatrix, backend: str | None = None, positive_definite: bool = True
) -> Factor:
    """Factorize a real symmetric or complex Hermitian sparse matrix A (n, n).

    positive_definite: lets PARDISO use Cholesky; set False for an indefinite shifted matrix.
    """
    backend = check_backend(backend, A.shape[0])
    if A.shape[0] != A.shape[1]:
        raise ValueError(f"A.shape={A.shape}: must be square")
    A = sp.csr_matrix(A)
    if backend == "pardiso":
        return _PardisoFactor(A, positive_definite)
    complex_matrix = np.iscomplexobj(A.data)
    lu = spla.splu(
        A.tocsc(), permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True}
    )
    return _SuperLUFactor(lu=lu, n=int(A.shape[0]), complex_matrix=complex_matrix)


def rayleigh_ritz(K: sp.spmatrix, M: sp.spmatrix, V: NDArray) -> tuple[NDArray, NDArray]:
    """Eigenpairs of (K, M) projected on span(V): ascending eigenvalues, M-orthonormal vectors.

    Cleans up ARPACK output (degenerate pairs, complex round-off) so that Phi^H M Phi = I and
    Phi^H K Phi = diag(lambda) hold to round-off.
    """
    KV = K @ V
    MV = M @ V
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
    tol: float = 0.0,
) -> tuple[NDArray[np.float64], NDArray]:
    """The k eigenpairs of K phi = lambda M phi nearest ``sigma`` (shift-invert Lanczos/Arnoldi).

    K, M: (n, n) real symmetric or complex Hermitian; M positive definite.
    factor: a factorization of K - sigma M to reuse (else one is made).
    Returns lambda (k,) ascending [rad^2/s^2] and Phi (n, k) with Phi^H M Phi = I.
    """
    n = K.shape[0]
    if not (isinstance(k, int | np.integer) and 0 < k <= n):
        raise ValueError(f"k={k!r}: number of modes must satisfy 0 < k <= n = {n}")
    if n <= _DENSE_LIMIT or k >= n // 2:
        # Small or nearly complete spectra: dense LAPACK is faster and always complete.
        lam, V = sla.eigh(K.toarray(), M.toarray(), subset_by_index=[0, k - 1])
        return lam, V
    if factor is None:
        shifted = K - sigma * M if sigma != 0.0 else K
        factor = factorize(shifted, backend=backend, positive_definite=sigma <= 0.0)
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
