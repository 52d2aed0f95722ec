"""The linear algebra of the balance: its Jacobian as a structured operator, solved by a
Krylov method preconditioned per harmonic order.

The Jacobian of :class:`~microslip.solve.hbm.HarmonicBalance` is

    J = L + sum_p B_p^T J_p B_p

with ``L`` block-diagonal over harmonic orders (the condensed dynamic stiffness, one dense
complex block S_n per order, in the real cos/sin layout) and a contact part block-diagonal
over contact points (point p's coefficients of every order, through its two nodes' DOFs).
Poured into one dense real matrix it costs ``(N_dof x N_coeff)^2`` memory and a dense LU
of that size per Newton iteration. Here it is kept as the two parts:

* :class:`BalanceJacobian` applies J (per order a complex matrix-vector product, per point a
  small dense block) and makes the preconditioner.
* The preconditioner is J's order-diagonal part: per order n the complex block
  ``S_n + sum_p B_pn^H K_pn B_pn``, with ``K_pn`` the part of point p's order-n block that a
  complex stiffness can represent (the mean over the period of its tangent stiffness;
  what is left, the stiffness's harmonics that couple orders, GMRES resolves). One LU per
  order: memory ``N_dof^2`` per order, factorization ``N_dof^3`` per order; the small
  bodies' DOFs (a whole disk's dampers) eliminated first, block by block (``_Split``).
* :class:`Preconditioner` keeps those factors across Newton iterations and continuation
  points (a point's neighbour has nearly the same Jacobian) and is refreshed when GMRES
  needs more than ``REFRESH_ITERATIONS`` iterations.
* :func:`gmres` is right-preconditioned GMRES (the true residual is the one tested).

The sign of det J, which arclength continuation needs to orient its tangent, is
``sign det P x sign det (P^-1 J)``: the first from the order-0 LU (a complex block's real
form has determinant ``|det|^2 > 0``), the second from the Arnoldi matrix of a GMRES run to
convergence from a fixed random start (its Ritz values include every eigenvalue of
``P^-1 J`` away from the cluster near 1, so every negative one).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from microslip.fourier import Harmonics

from .blocks import BlockDiagonal, pattern_components

#: GMRES: relative tolerance of a solve (||J dx - r|| <= RTOL ||r||) unless its caller asks
#: for less (a Newton step, newton.forcing): arclength's correctors and tangents are then
#: those of a direct solve to well below the continuation's tolerance (1e-9 of the force
#: scale).
RTOL = 1e-10
#: Krylov vectors kept before a solve counts as failed (the memory: n x this many floats).
MAX_KRYLOV = 80
#: A solve on old factors that took more iterations than this, and more than
#: REFRESH_GROWTH x the first solve on them, refreshes the preconditioner from the Jacobian
#: at hand (measured on the blisk + damper, 2 x 36 pairs: a fresh order-diagonal
#: preconditioner takes 14-20 iterations to 1e-10 at H 1, ~27 at H 3, and one 3 points
#: old the same: what it lacks is the coupling of the orders, not the newest state).
REFRESH_ITERATIONS = 30
REFRESH_GROWTH = 1.5
#: Relative tolerance of the Arnoldi run that gives the determinant's sign, and its
#: Krylov budget: a sign needs its run converged (the Ritz values the eigenvalues), which
#: on a stiff whole disk can take past the solves' MAX_KRYLOV (the tuned shrouded disk of
#: 24 blades: 1.2e-8 after 80 iterations, where the branch stopped "singular")
SIGN_RTOL = 1e-8
SIGN_KRYLOV = 4 * MAX_KRYLOV
#: Where GMRES fails even on fresh double-precision factors (the order-diagonal
#: preconditioner misses a strong coupling of the orders: a stiff interlock of every sector
#: of a whole shrouded disk), a system of at most this size is solved by a dense LU (8,192:
#: one 0.5 GB matrix factored in place, ~0.4 TFLOP, seconds) rather than the branch stopped;
#: the same Jacobian's later solves go to it directly. A pivot below DENSE_SINGULAR x the
#: largest is singular to working precision: the solve fails, as GMRES's did.
DENSE_FALLBACK = 8192
DENSE_SINGULAR = 1e-13


@dataclass(frozen=True)
class PointBlocks:
    """The real kinematic map of one contact cut into its points: point p's rows touch only
    its DOFs ``dofs[p]`` (all coefficients of each), through the dense block ``B[p]``
    (m, kd x n_coeffs), m = components x coefficients, columns DOF-major. Then
    B^T diag(J_p) B costs P (m k^2 + k^2) instead of a product over every unknown.
    ``disjoint``: no two points share a DOF and none is padded (a point with fewer DOFs
    repeats its first one with zero columns), so the blocks add without collisions."""

    dofs: np.ndarray  # (P, kd) int, indices into the balance's contact DOFs
    B: np.ndarray  # (P, m, kd * n_coeffs)
    n_coeffs: int
    disjoint: bool

    @classmethod
    def of(cls, Br, P: int, n_coeffs: int) -> PointBlocks:
        """From the real map (P m, N_dof n_coeffs), dense or CSR, DOF-major columns."""
        Bc = sp.csr_matrix(Br)
        m = Bc.shape[0] // P
        per = [np.unique(Bc[p * m:(p + 1) * m].indices // n_coeffs) for p in range(P)]
        kd = max((d.size for d in per), default=0)
        dofs = np.zeros((P, max(kd, 1)), dtype=np.int64)
        B = np.zeros((P, m, max(kd, 1) * n_coeffs))
        coeffs = np.arange(n_coeffs)
        for p, d in enumerate(per):
            if d.size:
                dofs[p, : d.size], dofs[p, d.size:] = d, d[0]
                cols = (d[:, None] * n_coeffs + coeffs).ravel()
                B[p, :, : cols.size] = Bc[p * m:(p + 1) * m][:, cols].toarray()
        used = np.concatenate(per) if per else np.zeros(0, dtype=np.int64)
        padded = any(d.size < kd for d in per)
        return cls(dofs, B, n_coeffs,
                   bool(np.unique(used).size == used.size) and not padded)

    @property
    def cols(self) -> np.ndarray:
        """(P, kd n_coeffs) the unknowns of each point, DOF-major."""
        nc = self.n_coeffs
        return (self.dofs[:, :, None] * nc + np.arange(nc)).reshape(self.dofs.shape[0], -1)

    def sandwich(self, blocks: np.ndarray) -> np.ndarray:
        """(P, k, k) B_p^T J_p B_p of per-point blocks (P, c, nc, c, nc) or (P, m, m)."""
        P, m, _ = self.B.shape
        return np.swapaxes(self.B, 1, 2) @ (blocks.reshape(P, m, m) @ self.B)

    def add_sandwich(self, J: np.ndarray, blocks: np.ndarray) -> None:
        """J += B^T diag(blocks) B for per-point blocks (P, c, nc, c, nc)."""
        self.scatter(J, self.sandwich(blocks))

    def scatter(self, J: np.ndarray, C: np.ndarray) -> None:
        """J[cols_p, cols_p] += C_p for (P, k, k) blocks."""
        cols = self.cols
        rows, cc = cols[:, :, None], cols[:, None, :]
        if self.disjoint:
            J[rows, cc] += C
        else:  # shared or padded columns: accumulate every contribution
            np.add.at(J, (rows, cc), C)


class _Solves:
    """The solves of a structured Jacobian A, its ``_system()`` as GMRES sees it, on the
    preconditioner of its balance's Jacobian: A^-1 rhs, and A bordered by one more row and
    column (arclength's corrector and tangent) solved and its determinant's sign."""

    def _system(self) -> _Bordered:
        raise NotImplementedError

    def solve(self, rhs: np.ndarray, rtol: float = RTOL) -> np.ndarray:
        """A^-1 rhs by preconditioned GMRES to ``rtol``; np.linalg.LinAlgError where it
        fails even with a preconditioner made from this Jacobian."""
        system = self._system()
        return system.J.store.solve(system.J, system, rhs, rtol)

    def bordered_solve(self, col: np.ndarray, row: np.ndarray, corner: float,
                       rhs: np.ndarray) -> np.ndarray:
        """The solution z of [[A, col], [row, corner]] z = rhs (one size more than A)."""
        system = self._system().extended(col, row, corner)
        return system.J.store.solve(system.J, system, rhs)

    def bordered_sign(self, col: np.ndarray, row: np.ndarray, corner: float) -> float:
        """sign det [[A, col], [row, corner]] (see the module)."""
        system = self._system().extended(col, row, corner)
        return system.J.store.sign(system.J, system)


@dataclass(frozen=True, eq=False)
class BalanceJacobian(_Solves):
    """J = L + sum_p B_p^T J_p B_p of the balance at one state, as an operator on the real
    DOF-major unknowns (n = N_dof x n_coeffs).

    linear: the condensed linear part (:class:`~microslip.solve.hbm.Condensed`:
        ``S_product`` per order, ``S`` (n_orders, N_dof, N_dof) complex when asked);
    contacts: per contact its :class:`PointBlocks` and its (P, k, k) sandwiched blocks;
    store: the model's :class:`Preconditioner` (shared by every Jacobian of the model)."""

    harmonics: Harmonics
    linear: Any
    contacts: tuple[tuple[PointBlocks, np.ndarray], ...]
    store: Preconditioner = field(repr=False)

    @property
    def n_dof(self) -> int:
        return self.linear.n_contact

    @property
    def shape(self) -> tuple[int, int]:
        n = self.n_dof * self.harmonics.n_coeffs
        return n, n

    def matvec(self, v: np.ndarray) -> np.ndarray:
        """J v, (n,): per order S_n X_n (X_n = a_n - i b_n), then the contact part."""
        h = self.harmonics
        X = h.to_complex(v.reshape(self.n_dof, h.n_coeffs))
        y = h.real_vector(self.linear.S_product(np.array([X[o] for o in h.orders])))
        out = y.ravel()
        if self._contact is not None:
            out += self._contact @ v
        return out

    @cached_property
    def _contact(self):
        """The contact part as one sparse matrix (P k^2 entries: one product per GMRES
        iteration instead of one small one per point)."""
        if not self.contacts:
            return None
        rows, cols, vals = [], [], []
        for pb, C in self.contacts:
            c = pb.cols
            rows.append(np.broadcast_to(c[:, :, None], C.shape).ravel())
            cols.append(np.broadcast_to(c[:, None, :], C.shape).ravel())
            vals.append(C.ravel())
        n = self.shape[0]
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows),
                                                      np.concatenate(cols))), shape=(n, n))

    def dense(self) -> np.ndarray:
        """The (n, n) real matrix (small models, checks)."""
        J = self.harmonics.real_matrix(self.linear.S)
        for pb, C in self.contacts:
            pb.scatter(J, C)
        return J

    def order_blocks(self) -> np.ndarray:
        """(n_orders, N_dof, N_dof) complex: J's order-diagonal part, each order's block
        projected on the complex-linear maps (real form [[A, B], [-B, A]] of A + iB)."""
        h = self.harmonics
        out = np.array(self.linear.S, dtype=complex)
        nc, k0 = h.n_coeffs, int(h.has_static)
        pairs = ([(0, 0)] if h.has_static else []) + list(zip(h.cos_index, h.sin_index))
        for pb, C in self.contacts:
            P, kd = pb.dofs.shape
            C5 = C.reshape(P, kd, nc, kd, nc)
            rows, cols = pb.dofs[:, :, None], pb.dofs[:, None, :]
            for k, (a, b) in enumerate(pairs):
                if k < k0:
                    blk = C5[:, :, a, :, a].astype(complex)
                else:
                    blk = 0.5 * (C5[:, :, a, :, a] + C5[:, :, b, :, b]) \
                        + 0.5j * (C5[:, :, a, :, b] - C5[:, :, b, :, a])
                if pb.disjoint:
                    out[k][rows, cols] += blk
                else:
                    np.add.at(out[k], (rows, cols), blk)
        return out

    # ------------------------------------------------------------------ solves
    def _system(self) -> _Bordered:
        n = self.shape[0]
        return _Bordered(self, np.zeros((n, 0)), np.zeros((0, n)), np.zeros((0, 0)))


@dataclass(frozen=True, eq=False)
class BorderedJacobian(_Solves):
    """A :class:`BalanceJacobian` scaled and bordered by k rows and columns,

        A = [[diag(row_scale) J diag(col_scale), cols], [rows, corner]]   (n + k, n + k),

    the Jacobian of a balance with k more unknowns and conditions (a nonlinear mode's
    frequency and self-excitation, its amplitude and phase). Solved as J is: flexible
    GMRES preconditioned by the per-order factors, bordered by block elimination; the
    same interface (``solve``, ``bordered_solve``, ``bordered_sign``) for Newton and
    continuation. The scalings must be positive (they are a problem's units)."""

    J: BalanceJacobian
    row_scale: np.ndarray  # (n,) > 0
    col_scale: np.ndarray  # (n,) > 0
    cols: np.ndarray  # (n, k)
    rows: np.ndarray  # (k, n)
    corner: np.ndarray  # (k, k)

    @property
    def shape(self) -> tuple[int, int]:
        n = self.J.shape[0] + self.corner.shape[0]
        return n, n

    def _system(self) -> _Bordered:
        return _Bordered(self.J, self.cols, self.rows, self.corner, self.row_scale,
                         self.col_scale)

    def matvec(self, v: np.ndarray) -> np.ndarray:
        return self._system().apply(v)

    def dense(self) -> np.ndarray:
        """The (n + k, n + k) real matrix (small models, checks)."""
        n = self.J.shape[0]
        A = np.zeros(self.shape)
        A[:n, :n] = self.row_scale[:, None] * self.J.dense() * self.col_scale[None, :]
        A[:n, n:], A[n:, :n], A[n:, n:] = self.cols, self.rows, self.corner
        return A


#: The Jacobians Newton and continuation solve by their own methods (not an LU).
STRUCTURED = (BalanceJacobian, BorderedJacobian)


class _Bordered:
    """[[diag(r) J diag(c), C], [R, D]] (k >= 0 borders) and its preconditioner, J's
    per-order factors bordered the same way (block elimination: k solves with the factors
    and a k x k Schur complement)."""

    def __init__(self, J: BalanceJacobian, C: np.ndarray, R: np.ndarray, D: np.ndarray,
                 r: np.ndarray | None = None, c: np.ndarray | None = None):
        self.J, self.C, self.R, self.D = J, C, R, np.atleast_2d(D)
        self.r, self.c = r, c
        self.n = J.shape[0]
        self.size = self.n + self.D.shape[0]

    def extended(self, col: np.ndarray, row: np.ndarray, corner: float) -> _Bordered:
        """This system bordered by one more column ``col`` and row ``row`` (size + 1)."""
        n = self.n
        D = np.block([[self.D, col[n:, None]], [row[None, n:], np.array([[corner]])]])
        return _Bordered(self.J, np.column_stack([self.C, col[:n]]),
                         np.vstack([self.R, row[:n]]), D, self.r, self.c)

    def apply(self, v: np.ndarray) -> np.ndarray:
        n = self.n
        u = v[:n] if self.c is None else self.c * v[:n]
        top = self.J.matvec(u)
        if self.r is not None:
            top *= self.r
        if not self.D.size:  # J alone (GMRES's every iteration of a forced balance)
            return top
        return np.concatenate([top + self.C @ v[n:], self.R @ v[:n] + self.D @ v[n:]])

    def _scaled(self, factors: _Factors):
        """v -> (diag(r) P diag(c))^-1 v with P's factors."""
        r, c = self.r, self.c
        if r is None:
            return factors.solve
        return lambda v: factors.solve(v / r) / c

    def _schur(self, factors: _Factors) -> tuple[np.ndarray, np.ndarray]:
        """(Z = P^-1 C, S = D - R Z)."""
        solve = self._scaled(factors)
        Z = np.column_stack([solve(col) for col in self.C.T]) if self.C.shape[1] \
            else np.zeros((self.n, 0))
        S = self.D - self.R @ Z
        scale = np.abs(self.D).max(initial=0.0) + np.linalg.norm(self.R) * np.linalg.norm(Z)
        if S.size and not abs(np.linalg.det(S / scale)) > 1e-14 ** S.shape[0]:
            raise np.linalg.LinAlgError("bordered preconditioner singular")
        return Z, S

    def inverse(self, factors: _Factors):
        solve = self._scaled(factors)
        if not self.D.size:
            return solve
        Z, S = self._schur(factors)
        lu = sla.lu_factor(S, check_finite=False)
        n = self.n

        def inverse(v):
            z1 = solve(v[:n])
            mu = sla.lu_solve(lu, v[n:] - self.R @ z1, check_finite=False)
            return np.concatenate([z1 - Z @ mu, mu])

        return inverse

    def dense(self) -> np.ndarray:
        """The (size, size) real matrix (the dense fallback), written in one array."""
        n = self.n
        A = np.empty((self.size, self.size))
        A[:n, :n] = self.J.dense()
        if self.r is not None:
            A[:n, :n] *= self.r[:, None]
        if self.c is not None:
            A[:n, :n] *= self.c[None, :]
        A[:n, n:], A[n:, :n], A[n:, n:] = self.C, self.R, self.D
        return A

    def same(self, other: _Bordered | None) -> bool:
        """Whether ``other`` is this system (the same Jacobian, borders and scalings)."""
        return other is not None and other.J is self.J and all(
            (a is None and b is None) or (a is not None and b is not None
                                          and np.array_equal(a, b))
            for a, b in ((self.C, other.C), (self.R, other.R), (self.D, other.D),
                         (self.r, other.r), (self.c, other.c)))

    def sign(self, factors: _Factors) -> float:
        s = factors.sign
        for d in (self.r, self.c):
            if d is not None:
                s *= float(np.prod(np.sign(d)))
        if self.D.size:
            s *= float(np.sign(np.linalg.det(self._schur(factors)[1])))
        return s


#: The preconditioner eliminates first the DOFs of the linear part's small bodies (at most
#: SMALL_BODY contact DOFs each: a whole disk's dampers), block by block, and factors only
#: the Schur complement on the others: a 48-blade disk's order block of 2,304 DOFs becomes
#: a 1,152 LU (8 x less to factor, 4 x less to apply) and 48 inverses of 24 x 24.
SMALL_BODY = 64


@dataclass(frozen=True, eq=False)
class _Split:
    """The order blocks' DOFs split into the large bodies' ``b`` and the small ones' ``d``,
    with ``parts``: the diagonal blocks of A_dd (positions in ``d``; the small bodies, or
    several of them where contacts join them)."""

    b: np.ndarray
    d: np.ndarray
    parts: list[np.ndarray]

    @classmethod
    def of(cls, linear: np.ndarray, blocks: np.ndarray) -> _Split | None:
        """From the condensed linear part ``linear`` and the order blocks ``blocks`` (both
        (n_orders, N, N)): the small bodies of the order where they are most apart (at
        order 0 a static condensation may tie them weakly to the others: A_bd holds it);
        None where none is apart, or where A_dd's blocks (the contacts, the static ties
        among them) join more than half the DOFs (the whole block's LU then)."""
        d = max((np.concatenate([c for c in pattern_components(L != 0)
                                 if c.size <= SMALL_BODY] or [np.zeros(0, int)])
                 for L in linear), key=len)  # (the order whose small bodies are most apart)
        if not d.size:
            return None
        d = np.sort(d)
        b = np.setdiff1d(np.arange(linear.shape[1]), d)
        parts = pattern_components(np.any(blocks[:, d[:, None], d[None, :]] != 0, axis=0))
        if max(p.size for p in parts) > linear.shape[1] // 2:
            return None
        return cls(b, d, parts)


@dataclass(frozen=True, eq=False)
class _OrderFactor:
    """One order block A's inverse: whole (``split`` None), or by the split: A_dd^-1 block
    by block, the couplings A_bd and A_db (sparse) and the inverse of the Schur complement
    A_bb - A_bd A_dd^-1 A_db."""

    inverse: np.ndarray  # (N, N) A^-1, or (nb, nb) the Schur complement's
    sign: float  # sign det A (meaningful where A is real)
    split: _Split | None = None
    dd: BlockDiagonal | None = None  # A_dd^-1
    bd: Any = None
    db: Any = None

    @classmethod
    def of(cls, A: np.ndarray, split: _Split | None) -> _OrderFactor:
        """LinAlgError where A, A_dd or the Schur complement is singular."""
        if split is None:
            return cls(*_inverse(A))
        b, d = split.b, split.d
        dd = BlockDiagonal.of(A[d[:, None], d[None, :]], split.parts).inverse()
        bd, db = sp.csr_matrix(A[b[:, None], d[None, :]]), sp.csr_matrix(A[d[:, None], b])
        schur = A[b[:, None], b[None, :]] - bd @ dd.product(db.toarray())
        inverse, sign = _inverse(schur) if b.size else (schur, 1.0)
        if not np.iscomplexobj(A):
            sign *= dd.sign()
        return cls(inverse, sign, split, dd, bd, db)

    def solve(self, v: np.ndarray) -> np.ndarray:
        """A^-1 v, v (N,)."""
        if self.split is None:
            return self.inverse @ v
        b, d = self.split.b, self.split.d
        y_d = self.dd.product(v[d])
        out = np.empty_like(v)
        out[b] = self.inverse @ (v[b] - self.bd @ y_d)
        out[d] = y_d - self.dd.product(self.db @ out[b])
        return out


def _inverse(A: np.ndarray) -> tuple[np.ndarray, float]:
    """(A^-1, sign det A) by LU; LinAlgError where A is singular."""
    lu, piv = sla.lu_factor(A, check_finite=False, overwrite_a=True)
    d = np.diag(lu)
    if not np.all(np.isfinite(d)) or np.any(d == 0):
        raise np.linalg.LinAlgError("singular")
    swaps = np.count_nonzero(piv != np.arange(piv.size))
    sign = float(np.prod(np.sign(d.real))) * (-1.0) ** swaps
    # the explicit inverse: a matrix-vector product per solve, 4x faster than the two
    # triangular solves (LAPACK's are not blocked for one right side); made by the blocked
    # triangular solves on the identity, not getri: 0.93 s against 3.38 s at 2,304
    # complex64 DOFs (0.29 against 1.26 s real float32; OpenBLAS, one thread), where the LU
    # takes 0.35 s
    inv = sla.lu_solve((lu, piv), np.eye(lu.shape[0], dtype=lu.dtype), check_finite=False)
    if not np.all(np.isfinite(inv)):
        raise np.linalg.LinAlgError("singular")
    return inv, sign


@dataclass(frozen=True)
class _Factors:
    """Per-order factors of the order-diagonal preconditioner (:class:`_OrderFactor`),
    single precision: order 0 real."""

    harmonics: Harmonics
    factors: tuple  # per order an _OrderFactor, float32 (order 0) or complex64
    sign: float  # sign det of the real form (order 0's; complex blocks give |det|^2)

    @classmethod
    def of(cls, J: BalanceJacobian, single: bool = True) -> _Factors:
        """``single``: in single precision (half the memory and time of every solve; GMRES
        is flexible, so the factors' rounding is the preconditioner's only), else double
        (where an order block is too ill-conditioned for single precision: a lightly damped
        resonance, a fold)."""
        h = J.harmonics
        real, cplx = (np.float32, np.complex64) if single else (np.float64, np.complex128)
        blocks = J.order_blocks()
        split = _Split.of(J.linear.S, blocks)
        out = []
        for k, A in enumerate(blocks):
            static = h.has_static and k == 0
            A = A.real.astype(real) if static else A.astype(cplx)
            try:
                out.append(_OrderFactor.of(A, split))
            except np.linalg.LinAlgError:
                raise np.linalg.LinAlgError(
                    f"preconditioner of order {h.orders[k]} singular") from None
        return cls(h, tuple(out), out[0].sign if h.has_static else 1.0)

    def solve(self, v: np.ndarray) -> np.ndarray:
        h = self.harmonics
        n = v.size // h.n_coeffs
        c = v.reshape(n, h.n_coeffs)
        k0 = int(h.has_static)
        out = np.empty_like(c)
        if h.has_static:
            f = self.factors[0]
            out[:, 0] = f.solve(c[:, 0].astype(f.inverse.dtype))
        if h.dynamic_orders:
            X = (c[:, k0::2] - 1j * c[:, k0 + 1::2]).astype(self.factors[-1].inverse.dtype)
            for k, f in enumerate(self.factors[k0:]):
                Y = f.solve(np.ascontiguousarray(X[:, k]))
                out[:, k0 + 2 * k], out[:, k0 + 2 * k + 1] = Y.real, -Y.imag
        return out.ravel()


class Preconditioner:
    """The per-order factors a model's Newton solves share, with how they fared: reused
    while GMRES converges in at most REFRESH_ITERATIONS, made again from the Jacobian at
    hand otherwise. Counters for benchmarks: ``solves``, ``iterations`` (GMRES, summed),
    ``refreshes``, ``dense_solves`` (dense LUs of the fallback)."""

    def __init__(self):
        self._factors: _Factors | None = None
        self._first = 0  # GMRES iterations of the first solve on the current factors
        self.solves = self.iterations = self.refreshes = self.dense_solves = 0
        self._dense: tuple[_Bordered, tuple[np.ndarray, np.ndarray]] | None = None

    def __getstate__(self) -> dict:
        """Pickled without its factors (N_dof^2 per order: a model sent to a worker makes
        its own at its first solve)."""
        return {**self.__dict__, "_factors": None, "_first": 0, "_dense": None}

    def _fresh(self, J: BalanceJacobian, single: bool = True) -> _Factors:
        self._factors, self._first = _Factors.of(J, single), 0
        self.refreshes += 1
        return self._factors

    def _run(self, J: BalanceJacobian, system: _Bordered, rhs: np.ndarray, rtol: float,
             budget: int = MAX_KRYLOV):
        """GMRES (at most ``budget`` iterations) on the current factors; where it fails, on
        fresh ones, then on fresh ones in double precision: (x, Arnoldi matrix, the factors
        it ran on); LinAlgError where even the last fails."""
        stages = ([] if self._factors is None else [None]) + [True, False]
        failure: Exception | None = None
        for single in stages:
            try:  # a singular single-precision block: double precision next
                factors = self._factors if single is None else self._fresh(J, single)
                x, its, H = gmres(system.apply, system.inverse(factors), rhs, rtol, budget)
            except np.linalg.LinAlgError as err:
                self.solves += 1
                self.iterations += budget
                failure = err
                continue
            self.solves += 1
            self.iterations += its
            if single is None and self._slow(its):
                try:  # converged slowly on old factors: new ones for the next
                    self._fresh(J)
                except np.linalg.LinAlgError:
                    self._factors = None  # the next solve tries again
            elif single is not None:
                self._slow(its)  # the first solve on the new factors
            return x, H, factors
        raise np.linalg.LinAlgError(
            f"GMRES did not converge in {budget} iterations even with a fresh "
            f"preconditioner in double precision (Jacobian singular or nearly: {failure})")

    def _slow(self, its: int) -> bool:
        """Whether a solve on the current factors took long enough to make them again."""
        if not self._first:
            self._first = its
            return False
        return its > max(REFRESH_ITERATIONS, REFRESH_GROWTH * self._first)

    def solve(self, J: BalanceJacobian, system: _Bordered, rhs: np.ndarray,
              rtol: float = RTOL) -> np.ndarray:
        if not np.all(np.isfinite(rhs)):
            raise ValueError("right-hand side has NaN or Inf")
        if not self._fell_back(system):
            try:
                x = self._run(J, system, rhs, rtol)[0]
                self._dense = None  # (a kept LU is of an older Jacobian)
                return x
            except np.linalg.LinAlgError:
                if system.size > DENSE_FALLBACK:
                    raise
        return sla.lu_solve(self._dense_factors(system), rhs, check_finite=False)

    def sign(self, J: BalanceJacobian, system: _Bordered) -> float:
        """sign det of the system: the factors' sign times that of the Arnoldi matrix of
        GMRES from a fixed random start, run to SIGN_RTOL."""
        n = system.size
        start = np.random.default_rng(n).standard_normal(n)
        # converged, or the Ritz values are not yet the eigenvalues and the sign is a
        # guess: then on fresh factors (old ones: the slow run makes them new), then in
        # double precision, else LinAlgError
        if not self._fell_back(system):
            try:
                _, H, factors = self._run(J, system, start, SIGN_RTOL, SIGN_KRYLOV)
                s, _ = np.linalg.slogdet(H)
                return system.sign(factors) * float(s)
            except np.linalg.LinAlgError:
                if system.size > DENSE_FALLBACK:
                    raise
        return lu_sign(*self._dense_factors(system))

    def _fell_back(self, system: _Bordered) -> bool:
        """Whether the system's Jacobian already needed the dense fallback (its GMRES
        failed): then its other solves go there directly."""
        return self._dense is not None and self._dense[0].J is system.J \
            and system.size <= DENSE_FALLBACK

    def _dense_factors(self, system: _Bordered) -> tuple[np.ndarray, np.ndarray]:
        """LU factors of the system's dense matrix, kept for the same system (a tangent's
        solve, then its sign); LinAlgError where it holds NaN or Inf or is singular to
        working precision (DENSE_SINGULAR)."""
        if self._dense is not None and system.same(self._dense[0]):
            return self._dense[1]
        self._dense = None  # its memory before the new matrix's
        A = system.dense()
        if not np.all(np.isfinite(A)):
            raise np.linalg.LinAlgError("the Jacobian holds NaN or Inf")
        with warnings.catch_warnings():  # an exactly zero pivot is judged below
            warnings.simplefilter("ignore", sla.LinAlgWarning)
            lu, piv = sla.lu_factor(A, overwrite_a=True, check_finite=False)
        pivots = np.abs(np.diag(lu))
        if not pivots.min() > DENSE_SINGULAR * pivots.max():
            raise np.linalg.LinAlgError("the Jacobian is singular to working precision (its "
                                        "dense LU's pivots)")
        self.dense_solves += 1
        self._dense = (system, (lu, piv))
        return lu, piv


def lu_sign(lu: np.ndarray, piv: np.ndarray) -> float:
    """Sign of the determinant of the matrix that LAPACK factored into (lu, piv)."""
    swaps = np.count_nonzero(piv != np.arange(piv.size))
    return float(np.prod(np.sign(np.diag(lu)))) * (-1.0) ** swaps


def gmres(apply, precondition, b: np.ndarray, rtol: float = RTOL,
          max_iter: int = MAX_KRYLOV) -> tuple[np.ndarray, int, np.ndarray]:
    """Flexible GMRES (Saad 1993) for A x = b: (x, iterations, the square Arnoldi matrix
    of A M^-1). Flexible: the preconditioned vectors z_j = M^-1 v_j are kept and x is
    their combination, so a preconditioner that is linear only to its rounding (single
    precision factors) costs no accuracy. Classical Gram-Schmidt done twice (as accurate
    as the modified one, in matrix products). LinAlgError without convergence to
    ||b - A x|| <= rtol ||b|| in max_iter iterations."""
    n = b.size
    beta = float(np.linalg.norm(b))
    if beta == 0.0:
        return np.zeros(n), 0, np.eye(0)
    V = np.empty((max_iter + 1, n))
    Z = np.empty((max_iter, n))
    Hs = np.zeros((max_iter + 1, max_iter))
    rot = np.zeros((max_iter, 2))  # Givens rotations (c, s)
    g = np.zeros(max_iter + 1)
    R = np.zeros((max_iter + 1, max_iter))  # the rotated Hessenberg
    V[0], g[0] = b / beta, beta
    for j in range(max_iter):
        Z[j] = precondition(V[j])
        w = apply(Z[j])
        h = V[: j + 1] @ w
        w -= V[: j + 1].T @ h
        h2 = V[: j + 1] @ w
        w -= V[: j + 1].T @ h2
        h += h2
        norm = float(np.linalg.norm(w))
        if not np.isfinite(norm):
            raise np.linalg.LinAlgError("GMRES: NaN or Inf in the operator or preconditioner")
        Hs[: j + 1, j], Hs[j + 1, j] = h, norm
        col = np.append(h, norm)
        for i in range(j):
            c, s = rot[i]
            col[i], col[i + 1] = c * col[i] + s * col[i + 1], -s * col[i] + c * col[i + 1]
        r = float(np.hypot(col[j], col[j + 1]))
        if r == 0.0:
            raise np.linalg.LinAlgError("GMRES breakdown")
        rot[j] = col[j] / r, col[j + 1] / r
        col[j], col[j + 1] = r, 0.0
        R[: j + 2, j] = col
        g[j], g[j + 1] = rot[j, 0] * g[j], -rot[j, 1] * g[j]
        if abs(g[j + 1]) <= rtol * beta or norm == 0.0:
            y = sla.solve_triangular(R[: j + 1, : j + 1], g[: j + 1], check_finite=False)
            return Z[: j + 1].T @ y, j + 1, Hs[: j + 1, : j + 1]
        V[j + 1] = w / norm
    raise np.linalg.LinAlgError(f"GMRES: no convergence in {max_iter} iterations "
                                f"(residual {abs(g[max_iter]) / beta:.2g} of the right side)")
