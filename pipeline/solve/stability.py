"""Stability of a periodic solution by Hill's method (Firrone & Zucca's balance, issue 25).

A perturbation ``y(t) = exp(lambda t) p(t)`` of the periodic solution, ``p`` periodic and in
the balance's harmonics, satisfies the linearised equations when

    H(lambda) p = [J + lambda Delta_1 + lambda^2 Delta_2] p = 0,

on every DOF of every order (the contact DOFs and the ones the balance condenses away: the
masters no contact touches, the reduced bodies' modal coordinates), with, per harmonic order
n (complex blocks, ``s = lambda + i n w``):

    J        the balance's Jacobian: K_n + i n w C_n - (n w)^2 M_n, plus the contact forces'
             Jacobian on the contact DOFs (the one Newton uses);
    Delta_1  C_n + 2 i n w M_n;     Delta_2  M_n      (M at the point's mass multiplier).

Why the full coordinates and not the condensed ones: condensed, the problem would be
non-linear in lambda (the Schur complement of K + s C + s^2 M); in full coordinates it is
quadratic, linearised to [[0, I], [-J, -Delta_1]] = lambda [[I, 0], [0, Delta_2]]. The
condensation is still what makes it cheap: the exponents nearest zero come from
shift-and-invert at lambda = 0, whose every solve with J is Newton's condensed Jacobian (one
LU, or for a large model its structured solve, see ``jacobian``) plus one LU of each order's
condensed block D_ii. A stability check at full scale thus
costs about one Newton iteration of the point (small problems go to a dense eigensolver
instead, the inverted operator formed on the identity).

Which exponents: each Floquet exponent appears in copies shifted by i k w. Kept are the
eigenvalues in the fundamental strip |Im lambda| <= w / 2 (Moore 2005; Peletan et al.
2013) nearest to zero: all of them when the Hill problem is small enough for a dense
eigensolver (``DENSE``), else those within the disc |lambda| <= w / 2 (ARPACK, its count
doubled until the disc is covered, at most ``MOST``). The disc holds every exponent that
can change the stability along a branch: an exponent crosses the imaginary axis inside the
strip, so within the disc. The solution is unstable when an exponent has a real part above
``NEUTRAL`` w (exponents within that band are neutral: the free static slip of a fully
slipping contact); the Floquet multipliers are exp(lambda T), T = 2 pi / w.

At stick/slip and contact/separation transitions the contact forces' Jacobian is that of
the sampled return map (Newton's): Hill's method then describes the sampled,
piecewise-smooth law, approximately (see the README, "Stability").
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse.linalg as spla

from .hbm import HarmonicBalance
from .jacobian import BalanceJacobian
from .linear import OperatingPoint

#: Hill problems of at most this many real unknowns (2 x the full DOFs x coefficients, the
#: linearised size) go to the dense eigensolver: every eigenvalue, ~0.1 s at the limit.
DENSE = 600
#: Newton's Jacobians up to this many unknowns are factored densely for Hill's method
#: (one LU: 0.1 s at 1,296, 1.6 s at 3,024 here), larger ones solved by GMRES.
HILL_LU = 3500
#: GMRES tolerance of a structured Jacobian's solves in Hill's method: ARPACK converges its
#: eigenvalues to 1e-10, which needs solves a little more accurate than Newton's.
HILL_RTOL = 1e-12
#: ARPACK's first count of exponents, and its most after doubling.
FIRST, MOST = 6, 96
#: Exponents with real parts within NEUTRAL x w of zero are neutral, not unstable: the free
#: static slip of a grossly slipping contact is an exponent zero in exact arithmetic,
#: computed as +-1e-7 w (round-off) to 3e-6 w (the sampled law's kinks); any structural
#: damping (zeta >= 1e-4) puts a real part below -1e-4 w.
NEUTRAL = 1e-5


@dataclass(frozen=True)
class Stability:
    """exponents: (k,) the selected Floquet exponents [1/s], by decreasing real part;
    stable: no exponent's real part above NEUTRAL w; complete: every exponent of the strip
    (dense), else those of the disc |lambda| <= w / 2 (False: the count reached MOST first)."""

    exponents: np.ndarray
    stable: bool
    complete: bool = True


def floquet_multipliers(stability: Stability, omega: float) -> np.ndarray:
    """exp(lambda T) of the selected exponents, T = 2 pi / omega."""
    return np.exp(stability.exponents * 2.0 * np.pi / omega)


def undefined(hb: HarmonicBalance) -> str:
    """Why Hill's method does not apply to ``hb`` ("" where it does): a lumped contact whose
    motion lags (``lag``: a time delay, whose perturbation carries exp(-lambda lag) that
    the balance's Jacobian cannot), or orders that are not consecutive on a cyclic model."""
    lagged = [c.name for c in hb.contacts if isinstance(c.kinematics, Mapping)]
    if hb.lumped and lagged:
        return (f"contact {lagged[0]!r} moves with a time lag: a delay, which Hill's method "
                "does not cover")
    try:
        hb.consecutive()
    except ValueError as err:
        return str(err)
    return ""


def hill_stability(hb: HarmonicBalance, x: np.ndarray, point: OperatingPoint) -> Stability:
    """The Floquet exponents of the solution ``x`` (the balance's unknowns) at ``point``
    (see the module). A lumped model kept on some orders only (e.g. the odd ones) is
    analysed on every order up to its highest (:meth:`HarmonicBalance.consecutive`);
    ValueError where the method does not apply (:func:`undefined`)."""
    why = undefined(hb)
    if why:
        raise ValueError(f"hill_stability: {why}")
    full = hb.consecutive()
    if full is not hb:
        hb, x = full, hb.embed(x, full)
    hill = _Hill(hb, x, point)
    w = point.omega
    if 2 * hill.size <= DENSE:
        lam, complete = hill.all_exponents(), True
    else:
        lam, complete = hill.exponents_near_zero(w)
    # the strip -w/2 < Im <= w/2, with a margin for the truncation at its edge; there a
    # multiplier on the negative axis shows as a conjugate pair, a +- i w/2: one is kept
    edge = np.abs(lam.imag) >= (1.0 - 1e-2) * 0.5 * w
    lam = lam[(np.abs(lam.imag) <= 0.5 * w * (1.0 + 1e-2)) & ~(edge & (lam.imag < 0))]
    lam = lam[_leading_first(lam, w)]
    return Stability(lam, bool(lam.size == 0 or lam[0].real <= NEUTRAL * w), complete)


def _leading_first(lam: np.ndarray, w: float) -> np.ndarray:
    """The order of exponents ``lam`` by real part, largest first, a conjugate pair's
    positive imaginary part first: the same order on every run (real parts equal to
    round-off, a pair's, are compared to 1e-9 of w, not by their last bits)."""
    grid = 1e-9 * max(w, float(np.abs(lam).max(initial=0.0)))
    return np.lexsort((-lam.imag, -np.round(lam.real / grid)))


class _Hill:
    """The shifted-and-inverted linearised Hill problem at lambda = 0 on the full real
    coordinates ``[contact unknowns (the balance's layout); per order its condensed DOFs
    (order 0: real; others: real and imaginary parts)]``."""

    def __init__(self, hb: HarmonicBalance, x: np.ndarray, point: OperatingPoint):
        self.h, w = hb.harmonics, point.omega
        self.nc = hb.dofs.size
        _, J, _ = hb.residual(x, point, structured=hb.structured)
        # Newton's Jacobian: its dense LU up to HILL_LU unknowns, else the structured
        # one's preconditioned GMRES (to HILL_RTOL, one solve per column). ARPACK applies
        # the inverse some 20-60 times: one LU costs less than that many GMRES solves up
        # to a few thousand unknowns. The dense eigensolver takes every exponent, those far
        # from zero from 1 / mu with mu small: they need a solve exact to rounding.
        small = 2 * (J.shape[0] + self._condensed_size(hb)) <= DENSE
        if isinstance(J, BalanceJacobian) and (small or J.shape[0] <= HILL_LU):
            J = J.dense()
        self.newton = J if isinstance(J, BalanceJacobian) else \
            sla.lu_factor(J, check_finite=False)
        lin = hb.reordered().linear  # contact DOFs first in every order
        nc = self.nc
        self.Dci, self.Dic, self.Dii, self.delta = [], [], [], []
        for o, D, M, C in zip(lin.orders, lin.dynamic_stiffness(point), lin.mass(point), lin.C):
            self.Dci.append(np.ascontiguousarray(D[:nc, nc:]))
            self.Dic.append(np.ascontiguousarray(D[nc:, :nc]))
            self.Dii.append(sla.lu_factor(D[nc:, nc:], check_finite=False)
                            if D.shape[0] > nc else None)
            # [Delta_1, Delta_2] side by side: one product per order and operator application
            delta = np.concatenate([C + 2j * o * w * M, M], axis=1)
            self.delta.append(delta if np.any(delta.imag) else np.ascontiguousarray(delta.real))
        self.internal = [B.shape[1] for B in self.Dci]
        self.widths = [n if o == 0 else 2 * n for o, n in zip(lin.orders, self.internal)]
        self.n_contact = J.shape[0]
        self.size = self.n_contact + sum(self.widths)

    # ---------------------------------------------------------------- layout
    def _split(self, v: np.ndarray) -> list[np.ndarray]:
        """Real vectors (size, m) -> per order the complex full vectors (n_k, m)."""
        h, m = self.h, v.shape[1]
        c = v[: self.n_contact].reshape(self.nc, h.n_coeffs, m)
        out, at, k0 = [], self.n_contact, int(h.has_static)
        for k, (n, width) in enumerate(zip(self.internal, self.widths)):
            part = v[at: at + width]
            at += width
            if k < k0:
                xc, zi = c[:, 0], part
            else:
                ia, ib = h.cos_index[k - k0], h.sin_index[k - k0]
                xc, zi = c[:, ia] - 1j * c[:, ib], part[:n] + 1j * part[n:]
            out.append(np.concatenate([xc, zi]))
        return out

    def _join(self, V: list[np.ndarray]) -> np.ndarray:
        """Per order complex full vectors (n_k, m) -> the real vectors (size, m), the
        inverse of :meth:`_split`."""
        h, nc, m = self.h, self.nc, V[0].shape[1]
        c = np.empty((nc, h.n_coeffs, m))
        parts, k0 = [c.reshape(-1, m)], int(h.has_static)
        for k, Vk in enumerate(V):
            zi = Vk[nc:]
            if k < k0:
                c[:, 0] = Vk[:nc].real
                parts.append(zi.real)
            else:
                c[:, h.cos_index[k - k0]] = Vk[:nc].real
                c[:, h.sin_index[k - k0]] = -Vk[:nc].imag
                parts.append(np.concatenate([zi.real, zi.imag]))
        return np.concatenate(parts)

    # ------------------------------------------------------------- operators
    def _solve_j(self, r: np.ndarray) -> np.ndarray:
        """H(0)^-1 r (size, m) by the condensation: per order the internal DOFs from D_ii,
        the contact unknowns from Newton's Jacobian."""
        nc = self.nc
        R = self._split(r)
        t = [sla.lu_solve(lu, Rk[nc:], check_finite=False) if lu else Rk[nc:]
             for lu, Rk in zip(self.Dii, R)]
        g = self._join([np.concatenate([B @ tk, np.zeros_like(tk)]) for B, tk in
                        zip(self.Dci, t)])[: self.n_contact]
        zc = self._solve_newton(r[: self.n_contact] - g)
        Xc = self._split(np.concatenate([zc, np.zeros((self.size - self.n_contact,
                                                       zc.shape[1]))]))
        out = []
        for lu, B, tk, X in zip(self.Dii, self.Dic, t, Xc):
            zi = tk - (sla.lu_solve(lu, B @ X[:nc], check_finite=False) if lu else 0.0)
            out.append(np.concatenate([X[:nc], zi]))
        return self._join(out)

    @staticmethod
    def _condensed_size(hb: HarmonicBalance) -> int:
        """The real unknowns of every order's condensed DOFs (order 0: one per DOF)."""
        nc = hb.dofs.size
        return sum((n - nc) * (1 if o == 0 else 2)
                   for o, n in zip(hb.harmonics.orders, hb.linear.sizes))

    def _solve_newton(self, b: np.ndarray) -> np.ndarray:
        """Newton's Jacobian solved for the columns of b (n_contact, m)."""
        if isinstance(self.newton, BalanceJacobian):
            try:
                return np.column_stack([self.newton.solve(c, rtol=HILL_RTOL) for c in b.T])
            except np.linalg.LinAlgError:
                # GMRES fails where J is nearly singular (a fold, where bifurcations are
                # located): the dense LU, as below HILL_LU, warns there but solves
                self.newton = sla.lu_factor(self.newton.dense(), check_finite=False)
        return sla.lu_solve(self.newton, b, check_finite=False)

    def inverted(self, v: np.ndarray) -> np.ndarray:
        """The linearised problem shifted and inverted at 0: [p; q] -> [u; p] with
        u = -H(0)^-1 (Delta_1 p + Delta_2 q), on vectors (2 size,) or (2 size, m); its
        eigenvalues are 1 / lambda."""
        v2 = v.reshape(2 * self.size, -1)
        p = v2[: self.size]
        pq = [np.concatenate([a, b]) for a, b in zip(self._split(p), self._split(v2[self.size:]))]
        u = -self._solve_j(self._join([A @ x for A, x in zip(self.delta, pq)]))
        return np.concatenate([u, p]).reshape(v.shape)

    # ------------------------------------------------------------ exponents
    def all_exponents(self) -> np.ndarray:
        """Every eigenvalue (dense: the inverted operator applied to the identity)."""
        mu = sla.eigvals(self.inverted(np.eye(2 * self.size)), check_finite=False)
        return 1.0 / mu[mu != 0]

    def exponents_near_zero(self, w: float) -> tuple[np.ndarray, bool]:
        """(the eigenvalues nearest zero covering the disc |lambda| <= w / 2, whether it
        is covered) by ARPACK on the inverted operator."""
        n = 2 * self.size
        op = spla.LinearOperator((n, n), matvec=self.inverted, dtype=float)
        k = min(FIRST, n - 2)
        # a seeded start vector (ARPACK's own is random): the same exponents on every run
        start = np.random.default_rng(0).standard_normal(n)
        while True:
            converged = True
            try:
                mu = spla.eigs(op, k=k, which="LM", return_eigenvectors=False,
                               ncv=min(n, max(2 * k + 1, 20)), tol=1e-10, v0=start)
            except spla.ArpackNoConvergence as err:  # the converged ones: not surely the
                mu, converged = err.eigenvalues, False  # nearest zero, so not complete
            lam = 1.0 / mu[mu != 0]
            covered = converged and lam.size and np.abs(lam).max() > 0.5 * w
            if not converged:
                return lam, False
            if covered or k >= min(MOST, n - 2):
                return lam, bool(covered)
            k = min(2 * k, MOST, n - 2)
