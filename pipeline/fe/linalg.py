"""Sparse symmetric factorizations and shift-invert eigen-solves.

Backends (``backend=`` argument, or ``None`` for the best available):

- ``"pardiso"``: Intel MKL PARDISO through ``pypardiso`` (PyPI wheels). Real symmetric
  matrices use its Cholesky (``mtype=2``), complex Hermitian ones its Hermitian Cholesky
  (``mtype=4``; pypardiso's input checks refuse complex data, so a subclass lifts them). The
  real doubled form ``[[B, -C], [C, B]]`` of ``A = B + iC`` (``doubled_real``) also works but
  measured 5x slower to factorize and 2x the memory (default blisk sector, ND 1).
- ``"superlu"``: SciPy's SuperLU with the symmetric-mode ordering (always available, real and
  complex). The fallback.

Eigen-solves (``lowest_modes``): a block shift-invert Lanczos (default; many right-hand sides
per solve, selection of every mode below a bound) or ARPACK; dense LAPACK for small problems.

CHOLMOD (scikit-sparse) has no wheels on PyPI and does not build without the SuiteSparse
headers; python-mumps on PyPI is built against NumPy 1 and fails to import with NumPy 2 (both
measured on this machine), so neither is offered.
"""

from __future__ import annotations

import ctypes
import importlib.util
import os
from dataclasses import dataclass
from typing import Protocol

import numba
import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

BACKENDS = ("pardiso", "superlu")


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


def load_backends() -> None:
    """Load the sparse back-ends' own libraries now (PARDISO's MKL): a BLAS thread limit
    set after this holds for them too, where one set before they load would not (MKL then
    ran PARDISO on every core whatever ``--threads`` said, and two runs' reduced models
    differed at round-off)."""
    if "pardiso" in available_backends():
        import pypardiso  # noqa: F401 (loads MKL)


#: Above this many unknowns PARDISO wins; below it SuperLU's lower fixed costs do (whole CB of
#: a blisk sector, ND 0 / ND 1, SuperLU vs PARDISO: 8.7k DOFs 1.5 / 3.2 s vs 2.1 / 3.0 s;
#: 13k DOFs 2.1 / 4.5 s vs 2.8 / 3.6 s; 20k DOFs 3.7 / 7.7 s vs 3.0 / 5.0 s).
PARDISO_MIN_SIZE = 15_000


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


def retain_freed_memory() -> bool:
    """Make glibc keep freed memory in the process for reuse (large blocks from the heap, not
    from fresh mmap'd pages, and no trimming). Process-wide, so only the command-line entry
    point calls it; MICROSLIP_RETAIN_MEMORY=0 in the environment turns it off.

    Each large NumPy array otherwise gets fresh pages whose first touch faults: ~11 us per 4 KB
    page on this project's VMs (the host takes back freed pages), 49 ms to fill 18 MB. Measured
    on a 150k-DOF Craig-Bampton: ND 0 14.0 -> 11.3 s, complex ND 1 28.9 -> 26.4 s. The cost:
    memory is not given back until the process ends, and the peak can rise where ever larger
    arrays cannot reuse earlier holes (the same run, ND 0 then ND 1: 4.6 -> 4.9 GB). Returns
    False where it is off or mallopt is unavailable (not glibc).
    """
    import ctypes.util

    if os.environ.get("MICROSLIP_RETAIN_MEMORY", "1") == "0":
        return False
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name) if name else None
        mallopt = libc.mallopt if libc is not None else None
    except (OSError, AttributeError):
        return False
    if mallopt is None:
        return False
    m_trim_threshold, m_mmap_max = -1, -4  # glibc's mallopt parameter numbers (malloc.h)
    return bool(mallopt(m_mmap_max, 0)) and bool(mallopt(m_trim_threshold, 2**31 - 1))


def doubled_real(A: sp.spmatrix) -> sp.csr_matrix:
    """Real symmetric (2n, 2n) form [[Re, -Im], [Im, Re]] of a complex Hermitian A (n, n)."""
    B = sp.csr_matrix(A.real)
    C = sp.csr_matrix(A.imag)
    return sp.bmat([[B, -C], [C, B]], format="csr")


#: Below this much work (non-zeros x columns) SciPy's single-threaded sparse product is as fast
#: as the compiled parallel one (and needs no compilation).
_SPMM_MIN_WORK = 4_000_000


def spmm(A: sp.spmatrix, X: NDArray) -> NDArray:
    """A @ X for a sparse A (n, m) and a dense X (m,) or (m, k), real or complex.

    Large products run compiled and parallel over the rows (SciPy's is single-threaded): a
    complex mass matrix with 3.8M non-zeros times 8 vectors, 97 ms -> 40 ms on 2 cores; times
    222 vectors, 2.7 s -> 0.5 s. A thin column-major X (k <= 16, a Krylov block) is read in
    place and the result is column-major too; a wide one is made row-major first (3.6x faster
    at k = 222).
    """
    X = np.asarray(X)
    if X.ndim == 1 or not sp.issparse(A) or A.nnz * X.shape[1] < _SPMM_MIN_WORK:
        return A @ X
    if A.shape[1] != X.shape[0]:  # the compiled kernel does not check bounds
        raise ValueError(f"spmm: A is {A.shape}, X is {X.shape}: inner dimensions differ")
    A = A.tocsr()
    dtype = np.result_type(A.dtype, X.dtype)
    order = "F" if X.flags.f_contiguous and X.shape[1] <= 16 else "C"
    X = np.asarray(X, dtype=dtype, order=order)
    out = np.empty((A.shape[0], X.shape[1]), dtype=dtype, order=order)
    _csr_matmat(A.indptr, A.indices, A.data.astype(dtype, copy=False), X, out)
    return out


def fmul(A: NDArray, B: NDArray) -> NDArray:
    """A @ B as a column-major array, computed as (B^T A^T)^T so that BLAS writes it in place
    (no transposing copy) for a column-major tall A (n, m) and a small B (m, k)."""
    return (B.T @ A.T).T


@numba.njit(parallel=True, cache=True)
def _csr_matmat(indptr, indices, data, X, out):  # pragma: no cover - compiled
    k = out.shape[1]
    for i in numba.prange(out.shape[0]):
        acc = np.zeros(k, dtype=out.dtype)
        for p in range(indptr[i], indptr[i + 1]):
            a = data[p]
            row = indices[p]
            for c in range(k):
                acc[c] += a * X[row, c]
        out[i, :] = acc


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


def _pardiso_solver_class() -> type:
    """pypardiso's solver (it finds and loads MKL), called with our own settings:

    - complex Hermitian matrices: MKL PARDISO takes them (mtype 4 / -4, MKL_Complex16 =
      interleaved float64 pairs, the layout of NumPy's complex128); pypardiso only refuses them
      in its input checks;
    - explicit iparm (iparm[0] = 1). With iparm[0] = 0, as pypardiso leaves it, PARDISO resets
      every setting to its defaults on each call, which include two steps of iterative
      refinement per solve (three solves and two products for one) and the sequential solve;
    - zero-based CSR arrays converted once, not on every call, and the solution returned in the
      Fortran order PARDISO writes (no copy);
    - no hashing or comparing of the matrix on every solve: the caller solves only with the
      matrix it factorized.
    """
    import pypardiso

    class Solver(pypardiso.PyPardisoSolver):
        def __init__(self, mtype: int) -> None:
            super().__init__(mtype=mtype)
            self.iparm[:] = 0
            self.iparm[0] = 1  # the settings below, not the defaults
            self.iparm[1] = 2  # METIS nested dissection
            # Iterative refinement: none on the SPD / HPD Cholesky factors (residuals ~1e-15
            # without), two steps on Bunch-Kaufman ones, whose restricted pivoting loses ~3
            # digits otherwise (measured: 4e-12 vs 4e-15 on a shifted real matrix).
            self.iparm[7] = 2 if mtype < 0 else 0
            self.iparm[9] = 8  # pivot perturbation 1e-8 (indefinite types)
            self.iparm[17] = -1  # report the factor's non-zeros
            self.iparm[20] = 1  # Bunch-Kaufman pivoting (indefinite types)
            # Parallel forward/backward substitution: 222 right-hand sides 4.6x faster than the
            # defaults (150k DOFs, 2 threads; most of it the refinement steps removed).
            self.iparm[24] = 2
            self.iparm[34] = 1  # zero-based indexing
            self._csr: tuple[sp.csr_matrix, NDArray, NDArray] | None = None

        def factorize(self, A: sp.csr_matrix) -> None:
            """Analysis and numerical factorization of A (CSR, sorted, upper triangle)."""
            self.set_phase(12)
            self._call_pardiso(A, np.zeros((A.shape[0], 1), dtype=A.dtype))

        def solve(self, A: sp.csr_matrix, b: NDArray) -> NDArray:
            """Solution of A x = b with the factor of A (the matrix factorize was given)."""
            self.set_phase(33)
            return self._call_pardiso(A, np.asfortranarray(b, dtype=A.dtype))

        def _call_pardiso(self, A: sp.csr_matrix, b: NDArray) -> NDArray:
            if self._csr is None or self._csr[0] is not A:
                if A.nnz >= 2**31:
                    raise ValueError(f"matrix with {A.nnz} non-zeros: beyond PARDISO's 32-bit "
                                     "indices")
                self._csr = (A, A.indptr.astype(np.int32), A.indices.astype(np.int32))
            _, ia, ja = self._csr
            x = np.empty_like(b, order="F")  # PARDISO writes every entry
            error = ctypes.c_int32(0)
            int_p, pt_type = ctypes.POINTER(ctypes.c_int32), ctypes.POINTER(self._pt_type[0])
            one = ctypes.byref(ctypes.c_int32(1))
            self._mkl_pardiso(
                self.pt.ctypes.data_as(pt_type), one, one,
                ctypes.byref(ctypes.c_int32(self.mtype)),
                ctypes.byref(ctypes.c_int32(self.phase)),
                ctypes.byref(ctypes.c_int32(A.shape[0])),
                A.data.ctypes.data_as(ctypes.c_void_p),
                ia.ctypes.data_as(int_p), ja.ctypes.data_as(int_p),
                self.perm.ctypes.data_as(int_p),
                ctypes.byref(ctypes.c_int32(1 if b.ndim == 1 else b.shape[1])),
                self.iparm.ctypes.data_as(int_p),
                ctypes.byref(ctypes.c_int32(0)),
                b.ctypes.data_as(ctypes.c_void_p), x.ctypes.data_as(ctypes.c_void_p),
                ctypes.byref(error),
            )
            if error.value != 0:
                raise RuntimeError(f"PARDISO error {error.value} (phase {self.phase})")
            return x

    return Solver


class _PardisoFactor:
    backend = "pardiso"

    def __init__(self, A: sp.spmatrix, positive_definite: bool) -> None:
        # Intel OpenMP threads spin ~200 ms after each call by default, stealing the cores
        # from OpenBLAS between solves (measured: 2.5x slower ARPACK); set before MKL loads.
        os.environ.setdefault("KMP_BLOCKTIME", "0")
        self.n = int(A.shape[0])
        self.complex_matrix = bool(np.iscomplexobj(A.data))
        dtype = np.complex128 if self.complex_matrix else np.float64
        # PARDISO's symmetric / Hermitian types read the upper triangle only.
        self._A = sp.triu(sp.csr_matrix(A, dtype=dtype), format="csr")
        self._A.sort_indices()
        if np.any(np.diff(self._A.indptr) == 0):
            raise ValueError("matrix has an empty row: singular")
        # Real symmetric: 2 (Cholesky) / -2 (Bunch-Kaufman); complex Hermitian: 4 / -4 (half the
        # memory and a quarter of the time of the doubled real form, measured).
        mtype = (4 if self.complex_matrix else 2) * (1 if positive_definite else -1)
        self._solver = _pardiso_solver_class()(mtype=mtype)
        self._solver.factorize(self._A)

    @property
    def factor_nonzeros(self) -> int:
        """Non-zeros of the factor (PARDISO's iparm(18))."""
        return int(self._solver.get_iparm(18))

    def _solve(self, b: NDArray) -> NDArray:
        # One thread for single-vector triangular solves: they are memory-bound, and with
        # the cores shared, OpenMP barriers made each ARPACK solve ~20x slower (measured).
        if b.shape[1] > 2:  # block solves keep MKL's threads
            return self._solver.solve(self._A, b)
        mkl = self._solver.libmkl
        previous = mkl.MKL_Set_Num_Threads_Local(1)
        try:
            return self._solver.solve(self._A, b)
        finally:
            mkl.MKL_Set_Num_Threads_Local(previous)

    def solve(self, b: NDArray) -> NDArray:
        b = np.asarray(b)
        vector = b.ndim == 1
        b2 = b.reshape(self.n, -1)
        if self.complex_matrix:
            out = self._solve(np.asfortranarray(b2, dtype=np.complex128))
        elif np.iscomplexobj(b2):
            k = b2.shape[1]
            x = self._solve(np.asfortranarray(np.concatenate([b2.real, b2.imag], axis=1)))
            out = x[:, :k] + 1j * x[:, k:]
        else:
            out = self._solve(np.asfortranarray(b2, dtype=np.float64))
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


class ConstrainedFactor:
    """Solves of a Hermitian positive semi-definite K (n, n) under linear constraints W
    (c, n), W of full row rank and holding K's null space (averaged masters: the contact
    points that stand for patches of a surface): x of

        K x + W^H lam = b,   W x = g.

    By the augmented Lagrangian: K_a = K + a W^H W is positive definite and has the same
    solution for any a (W x = g makes the added term vanish), so it is factorized once
    (Cholesky), with Z = K_a^-1 W^H (n, c) and the capacitance C = W Z (c, c):
    x = y - Z C^-1 (W y - g), y = K_a^-1 (b + a W^H g). ``a`` is the mean diagonal of K
    over the mean ||w_i||^2 of W's rows: the ties as stiff as the elements they hold, so
    K_a is conditioned as K is. Z is dense (n, c): c = 3 per averaged point.

    ``solve(b)`` (g = 0) is the constrained inverse of K on the null space of W: the
    shift-invert operator of the fixed-interface modes (``constraint`` tells
    ``lowest_modes`` to start its Krylov space there).
    """

    def __init__(self, K: sp.spmatrix, W: sp.spmatrix, backend: str | None = None) -> None:
        W = sp.csr_matrix(W)
        WHW = (W.conj().T @ W).tocsr()
        rows = np.asarray(abs(W).power(2).sum(axis=1)).ravel()  # ||w_i||^2
        if not rows.all():
            raise ValueError(f"averaged masters: constraint {int(np.argmin(rows))} holds no "
                             "free DOF (every node it averages is clamped or a master)")
        self.alpha = float(np.abs(K.diagonal()).mean() / rows.mean())
        self.factor = factorize(K + self.alpha * WHW, backend=backend, positive_definite=True)
        self.n, self.backend, self.constraint = K.shape[0], self.factor.backend, W
        self.Z = np.asarray(self.factor.solve(W.conj().T.toarray()))
        C = np.asarray(W @ self.Z)
        try:
            self._cho = sla.cho_factor(0.5 * (C + C.conj().T))
        except np.linalg.LinAlgError:
            raise ValueError("averaged masters: their weights are linearly dependent (two "
                             "points averaging the same nodes alike)") from None

    def solve(self, b: NDArray, g: NDArray | None = None) -> NDArray:
        """x (n,) or (n, k) for b (n,) or (n, k) and constraint values g (c,) or (c, k)
        (None: 0)."""
        b = np.asarray(b)
        if g is not None:
            b = b + self.alpha * (self.constraint.conj().T @ g)
        y = np.asarray(self.factor.solve(b))
        r = self.constraint @ y if g is None else self.constraint @ y - g
        return y - self.Z @ sla.cho_solve(self._cho, r)

    def free(self) -> None:
        self.factor.free()
        self.Z = np.empty((0, 0))
