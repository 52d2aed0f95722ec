"""The linear part of the balance condensed on the contact DOFs, per harmonic order
(Firrone & Zucca eq. 9): ``S_n = D_cc - D_ci D_ii^-1 D_ic`` kept as its factors, the loads
condensed with it, their parameter derivatives, and the recovery of the condensed DOFs."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
import scipy.linalg as sla


@dataclass(frozen=True, eq=False)
class Condensed:
    """Linear part condensed on the contact DOFs at one operating point:
    S_k = D_cc - D_ci Y_k per order, Y_k = D_ii^-1 D_ic, kept as its factors. A product
    ``S_k X`` costs nc^2 + 2 nc ni (:meth:`S_product`); the matrices ``S`` (nc^2 ni per
    order) are made only when asked (a dense Jacobian, a new preconditioner, a linear
    guess), not at every Newton iterate of a continuation.

    Per order k: q_i = z_k - Y_k q_c recovers the other DOFs (the shared ones no contact
    touches, then the order's own)."""

    D: tuple[np.ndarray, ...]  # per order (n_k, n_k), contact DOFs first; real at order 0
    n_contact: int
    F: np.ndarray  # (n_orders, nc) complex
    Y: tuple[np.ndarray, ...]  # per order (ni_k, nc), real where D is (order 0)
    z: tuple[np.ndarray, ...]  # per order (ni_k,)
    dS: tuple[_SchurDerivative | None, ...] | None  # per order; None where dS_k = 0
    dF: np.ndarray | None
    # per order the LU of D_ii (None: nothing condensed), kept when asked (``condense``)
    lus: tuple[tuple | None, ...] = ()

    @cached_property
    def S(self) -> np.ndarray:
        """(n_orders, nc, nc) complex."""
        nc = self.n_contact
        out = np.empty((len(self.D), nc, nc), dtype=complex)
        for k, (D, Y) in enumerate(zip(self.D, self.Y)):
            np.subtract(D[:nc, :nc], D[:nc, nc:] @ Y, out=out[k])
        return out

    def S_product(self, X: np.ndarray) -> np.ndarray:
        """S_k X_k per order: X (n_orders, nc, ...) complex, the same shape back."""
        made, nc = self.__dict__.get("S"), self.n_contact
        out = np.empty(X.shape, dtype=complex)
        for k, (D, Y, x) in enumerate(zip(self.D, self.Y, X)):
            if made is not None:  # one product
                out[k] = made[k] @ x
            else:
                out[k] = real_product(D[:nc, :nc], x) \
                    - real_product(D[:nc, nc:], real_product(Y, x))
        return out

    def recover(self, k: int, x: np.ndarray) -> np.ndarray:
        """The condensed DOFs' amplitudes of order k, z_k - Y_k x, from the contact DOFs'
        x (nc,)."""
        return self.z[k] - self.Y[k] @ x

    def dS_product(self, X: np.ndarray) -> np.ndarray:
        """dS_k X_k per order: X (n_orders, nc, ...) complex, the same shape back."""
        out = np.zeros(X.shape, dtype=complex)
        for k, d in enumerate(self.dS):
            if d is not None:
                out[k] = d.apply(X[k])
        return out

    def derivative_product(self, dD: Sequence[np.ndarray | None], X: np.ndarray) -> np.ndarray:
        """dS_k X_k per order for another derivative dD of D (per order (n_k, n_k) in the
        condensation's order, None where zero) than the one condensed with, from the same
        factors: X (n_orders, nc) complex, the same shape back."""
        out = np.zeros(X.shape, dtype=complex)
        nc = self.n_contact
        for k, d in enumerate(dD):
            if d is not None:
                out[k] = _SchurDerivative(d, self.D[k][:nc, nc:], self.Y[k],
                                          self.lus[k]).apply(X[k])
        return out

    @property
    def nbytes(self) -> int:
        arrays = [self.F, *self.D, *self.Y, *self.z, self.dF, self.__dict__.get("S")]
        derivatives = sum(d.nbytes for d in self.dS or () if d is not None)
        held = {id(d.lu) for d in self.dS or () if d is not None}  # (counted there)
        derivatives += sum(lu[0].nbytes for lu in self.lus
                           if lu is not None and id(lu) not in held)
        return sum(a.nbytes for a in arrays if a is not None) + derivatives


@dataclass(frozen=True, eq=False)
class _SchurDerivative:
    """One order's dS = dD_cc - dD_ci Y - L (dD_ic - dD_ii Y), L = D_ci D_ii^-1, kept as
    its factors: dS X costs products with the blocks (nc^2 + 4 nc ni per column), not the
    matrix (nc^2 ni); the residual needs dS x only."""

    dD: np.ndarray  # (n, n) the order's dD, contact DOFs first
    Dci: np.ndarray  # (nc, ni)
    Y: np.ndarray  # (ni, nc)
    lu: tuple | None  # LU of D_ii, None where nothing is condensed

    @property
    def nbytes(self) -> int:
        return self.dD.nbytes + self.Dci.nbytes + self.Y.nbytes + \
            (self.lu[0].nbytes if self.lu else 0)

    def apply(self, X: np.ndarray) -> np.ndarray:
        """dS X for X (nc,) or (nc, m)."""
        nc = self.Dci.shape[0]
        dD = self.dD
        out = dD[:nc, :nc] @ X
        if self.lu is None:
            return out
        W = self.Y @ X
        out = out - dD[:nc, nc:] @ W
        V = dD[nc:, :nc] @ X - dD[nc:, nc:] @ W
        return out - self.Dci @ sla.lu_solve(self.lu, V, check_finite=False)


def condensed_dofs(shared_others: np.ndarray, n_shared: int, n: int) -> np.ndarray:
    """Indices condensed in an order of size n: shared DOFs no contact touches, then the
    order's own DOFs n_shared..n-1."""
    return np.concatenate([shared_others, np.arange(n_shared, n)])


@dataclass(frozen=True, eq=False)
class Reordered:
    """The linear part with rows and columns reordered per order: the contact DOFs, then the
    condensed ones (``condensed_dofs``). The blocks D_cc, D_ci, D_ic, D_ii of any point are then
    basic slices of D, not gathers from the full matrices: a continuation puts every Newton
    iterate at a new frequency, so this is what gets reused. Matrices are stored real where
    their imaginary part is exactly zero (half the memory, real products at order 0)."""

    index: tuple[np.ndarray, ...]  # per order (n_k,): the original DOF of each row
    linear: Any  # linear.LinearDynamics, reordered, read-only (this module is hbm's)

    @classmethod
    def of(cls, linear: Any, dofs: np.ndarray, others: np.ndarray) -> Reordered:
        """linear: an linear.LinearDynamics; its reordered copy is of the same type."""
        index = tuple(np.concatenate([dofs, condensed_dofs(others, linear.n_dof, n)])
                      for n in linear.sizes)

        def take(mats):
            out, made = [], {}
            for A, p in zip(mats, index):
                key = (id(A), p.size)
                if key in made and np.array_equal(made[key][1], p):
                    out.append(made[key][0])  # an order with the same matrix: held once
                    continue
                B = A[np.ix_(p, p)]
                B = B if np.any(B.imag) else np.ascontiguousarray(B.real)
                B.flags.writeable = False
                out.append(B)
                made[key] = (B, p)
            return tuple(out)

        return cls(index, type(linear)(take(linear.K), take(linear.M), take(linear.C),
                                       take(linear.M_part), linear.orders, linear.n_dof))

    @property
    def nbytes(self) -> int:
        lin = self.linear  # (a matrix orders share counted once)
        held = {id(a): a.nbytes for a in (*self.index, *lin.K, *lin.M, *lin.C, *lin.M_part)}
        return sum(held.values())

    def take(self, vectors: Sequence[np.ndarray]) -> list[np.ndarray]:
        """Per order (n_k,) vectors reordered like the matrices."""
        return [v[p] for v, p in zip(vectors, self.index)]


def condense(D, F, nc: int, dD=None, dF=None, keep_factors: bool = False) -> Condensed:
    """Exact per-order condensation of D q = F onto its first nc DOFs (the rest condensed):
    S = D_cc - D_ci D_ii^-1 D_ic.

    D: per order (n_k, n_k), real or complex, rows and columns ordered contact DOFs first
    (:class:`Reordered`); F: per order (n_k,) in that order; dD, dF: their derivatives per
    order (an entry None where zero) or None. ``keep_factors``: keep the LU factors of
    every D_ii (``Condensed.derivative_product``: more derivatives than one; they take as
    much memory as the D_ii)."""
    n, deriv = len(D), dD is not None or dF is not None
    Fe = np.empty((n, nc), dtype=complex)
    dFe = np.zeros_like(Fe) if deriv else None
    dS = [None] * n
    Ys, zs, lus = [], [], []
    for k, (Dk, Fk) in enumerate(zip(D, F)):
        dFk = None if dF is None else dF[k]
        Y, z, lu = _schur(Dk, Fk, nc, Fe[k], dFk, None if dFk is None else dFe[k])
        if dD is not None and dD[k] is not None:
            dS[k] = _schur_derivative(Dk, dD[k], nc, Y, z, lu, dFe[k])
        Ys.append(Y)
        zs.append(z)
        lus.append(lu)
    return Condensed(tuple(D), nc, Fe, tuple(Ys), tuple(zs), tuple(dS) if deriv else None,
                     dFe, tuple(lus) if keep_factors else ())


def _schur(D, F, nc, Fe, dF=None, dFe=None):
    """One order's condensation of the loads, written into Fe (nc,): Fe = F_c - D_ci z with
    Y = D_ii^-1 D_ic (ni, nc), z = D_ii^-1 F_i (ni,); given dF (n,), also
    dFe = dF_c - L dF_i with L = D_ci D_ii^-1 (the part that does not depend on dD).
    Returns (Y, z, the LU factors of D_ii or None where nothing is condensed)."""
    Dci, Dic, Dii = D[:nc, nc:], D[nc:, :nc], D[nc:, nc:]
    vecs = F[:, None] if dF is None else np.stack([F, dF], axis=1)  # (n, 1 or 2)
    lu = None
    if Dii.shape[0] == 0:
        g = np.zeros((nc, vecs.shape[1]), dtype=complex)
        Y, z = np.zeros((0, nc), dtype=complex), np.zeros(0, dtype=complex)
    else:
        # one solve for every right-hand side, D_ii^-1 [D_ic, F_i, dF_i]
        lu = sla.lu_factor(Dii, check_finite=False)
        sol = sla.lu_solve(lu, _join(Dic, vecs[nc:]), check_finite=False)
        Y, t = sol[:, :nc], _tail(sol, nc)
        g = Dci @ t
        z = t[:, 0].copy()
    Fe[...] = F[:nc] - g[:, 0]
    if dF is not None:
        dFe[...] = dF[:nc] - g[:, 1]
    return Y, z, lu


def _schur_derivative(D, dD, nc, Y, z, lu, dFe) -> _SchurDerivative:
    """The dependence of one order's D in the derivatives of its condensation: dS as a
    :class:`_SchurDerivative`, and -(dD_ci - L dD_ii) z added to dFe (nc,), with
    L = D_ci D_ii^-1 and Y, z, lu from :func:`_schur`."""
    out = _SchurDerivative(dD, D[:nc, nc:], Y, lu)
    if lu is not None:
        dFe -= dD[:nc, nc:] @ z - D[:nc, nc:] @ sla.lu_solve(lu, dD[nc:, nc:] @ z,
                                                           check_finite=False)
    return out


def real_product(A: np.ndarray, x: np.ndarray) -> np.ndarray:
    """A x, a real A applied to a complex x as two real products (numpy would copy A to
    complex first: order 0's matrices, whose vectors are real)."""
    if np.iscomplexobj(A) or not np.iscomplexobj(x):
        return A @ x
    if not np.any(x.imag):
        return A @ x.real
    return A @ x.real + 1j * (A @ x.imag)


def _join(A: np.ndarray, v: np.ndarray) -> np.ndarray:
    """[A, v] as one operand. Complex columns v (m, k) join a real A as their float view
    (m, 2k: real and imaginary parts interleaved), so products with real matrices stay real
    (order 0: a quarter of the work); :func:`_tail` undoes it."""
    if np.iscomplexobj(A):
        return np.concatenate([A, v], axis=1)
    return np.concatenate([A, np.ascontiguousarray(v, dtype=complex).view(float)], axis=1)


def _tail(G: np.ndarray, n: int) -> np.ndarray:
    """The complex columns past the first n of a product with :func:`_join`'s operand."""
    t = G[:, n:]
    return t if np.iscomplexobj(G) else np.ascontiguousarray(t).view(complex)


def solve_orders(S: np.ndarray, F: np.ndarray, rcond_min: float = 1e-12
                  ) -> np.ndarray | None:
    """X_k = S_k^-1 F_k per order, or None if any S_k is singular to rcond_min (LAPACK's
    1-norm estimate, O(n^2) beside the O(n^3) factorization)."""
    X = np.empty_like(F)
    for k, (A, b) in enumerate(zip(S, F)):
        lu, piv, info = sla.lapack.zgetrf(A)
        if info != 0:
            return None
        rcond, _ = sla.lapack.zgecon(lu, np.abs(A).sum(axis=0).max(), norm="1")
        if not rcond >= rcond_min:
            return None
        X[k] = sla.lu_solve((lu, piv), b, check_finite=False)
    return X
