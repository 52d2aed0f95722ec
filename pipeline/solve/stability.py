"""Stability of a periodic solution by Hill's method (issue 25, section 1; first part:
models whose every DOF is an unknown of the balance, the lumped oscillators).

A perturbation ``y(t) = exp(lambda t) p(t)`` of the periodic solution, ``p`` periodic and in
the balance's harmonics, satisfies the linearised equations when

    [J + lambda (C + 2 M w D) + lambda^2 M] p = 0,

with J the balance's Jacobian at the solution (``K + C w D + M (w D)^2`` plus the contact
forces' Jacobian: the one Newton uses), D the derivative d/dtheta in coefficient space and
M, C on every coefficient (Kronecker products in the DOF-major real layout). The quadratic
eigenvalue problem has 2 n nc exponents for n DOFs and nc coefficients; each Floquet
exponent appears in copies shifted by i k w. The 2 n exponents with the smallest imaginary
parts (|Im lambda| <= w / 2, the fundamental strip) are the meaningful ones (the sorting
criterion of Moore 2005 and Peletan et al. 2013; it needs harmonics enough for the copies at
the strip's edge to be resolved). The solution is stable when every selected exponent has a
negative real part; the Floquet multipliers are exp(lambda T), T = 2 pi / w.

At stick/slip transitions the friction force's Jacobian is that of the sampled return map
(Newton's): Hill's method then describes the sampled, piecewise-smooth law, approximately.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from .hbm import HarmonicBalance, OperatingPoint


@dataclass(frozen=True)
class Stability:
    """exponents: (2 n,) the selected Floquet exponents [1/s], by decreasing real part;
    stable: every real part below -tol (tol: round-off relative to w)."""

    exponents: np.ndarray
    stable: bool


def floquet_multipliers(stability: Stability, omega: float) -> np.ndarray:
    """exp(lambda T) of the selected exponents, T = 2 pi / omega."""
    return np.exp(stability.exponents * 2.0 * np.pi / omega)


def hill_stability(hb: HarmonicBalance, x: np.ndarray, point: OperatingPoint) -> Stability:
    """The Floquet exponents of the solution ``x`` at ``point`` (see the module).

    ValueError for a model whose balance condenses DOFs away (their dynamics is not in
    the unknowns: not yet supported)."""
    lin, h = hb.linear, hb.harmonics
    n = lin.n_dof
    if hb.dofs.size != n or any(k.shape[0] != n for k in lin.K):
        raise ValueError("hill_stability: the balance condenses DOFs away (a DOF no contact "
                         "touches, or modal coordinates); only models whose every DOF is an "
                         "unknown are supported yet")
    w = point.omega
    _, J, _ = hb.residual(x, point)
    nc = h.n_coeffs
    # a lumped model's matrices are the same at every order (real)
    M = np.real(lin.M[0] + (point.mass_multiplier - 1.0) * lin.M_part[0])
    C = np.real(lin.C[0])
    eye = np.eye(nc)
    D1 = np.kron(C, eye) + 2.0 * w * np.kron(M, h.derivative)
    D2 = np.kron(M, eye)
    size = n * nc
    A = np.block([[np.zeros((size, size)), np.eye(size)], [-J, -D1]])
    B = np.block([[np.eye(size), np.zeros((size, size))], [np.zeros((size, size)), D2]])
    lam = sla.eig(A, B, right=False)
    lam = lam[np.isfinite(lam)]
    chosen = lam[np.argsort(np.abs(lam.imag), kind="stable")[: 2 * n]]
    chosen = chosen[np.argsort(-chosen.real, kind="stable")]
    return Stability(chosen, bool(np.all(chosen.real < -1e-9 * w)))
