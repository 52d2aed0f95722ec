"""Lumped models for the direct-time-integration tests (built through the public API)."""

from __future__ import annotations

import numpy as np

from microslip.laws.coulomb import ContactElements
from microslip.solve.dti import LoadSteps, TimeModel


def blade_damper_blade(
    *,
    m1: float = 0.05,
    m2: float = 0.1,
    kx1: float = 1.0e6,
    f_blade: float = 61.8,
    ky: float = 1.0e6,
    md: float = 0.03,
    Id: float = 5.0e-7,
    kd: float = 1.0e3,
    ktheta: float = 1.0,
    alpha_deg: float = 45.0,
    a: float = 4.0e-3,
    b: float = 2.0e-3,
    kt: float = 2.0e5,
    kn: float = 2.0e5,
    mu: float = 0.5,
    CF: float = 30.0,
    F: float = 5.0,
    beta: float = 2.5e-5,
    ramp_time: float = 0.05,
    settle_time: float = 0.1,
    ramp_periods: int = 10,
) -> tuple[TimeModel, LoadSteps]:
    """The 9-DOF blade-damper-blade model of Firrone & Zucca's Fig. 12 (eqs. 20-23).

    DOFs [x1_l, y_l, x2_l, x1_r, y_r, x2_r, x_d, y_d, theta_d] (m, rad): each
    blade a platform m1 (x1, y) and an airfoil m2 (x2) joined by kx2, chosen so
    that the blade's first mode (platform on kx1) is at ``f_blade`` Hz; the
    damper a rigid wedge (md, Id) on weak ground springs kd, ktheta, touching
    each platform at (a_i, b_i) from its centre through a law-B point
    (kt, kn, mu, no preload, no gap) inclined alpha from the vertical.
    Rayleigh damping C = beta K. CF (N) acts on y_d; the excitation is
    ``F cos(w t)`` on x1_l and ``-F cos(w t)`` on x1_r (mirror-symmetric).
    Illustrative parameters (the text gives none): with them load step 1 ends
    with N ~ 14 N and T ~ -mu N, as the text reports."""
    # kx2 from the blade's first eigenvalue: det(K - w^2 M) = 0 solved for kx2
    w2 = (2 * np.pi * f_blade) ** 2
    kx2 = w2 * m2 * (kx1 - w2 * m1) / (kx1 - w2 * m1 - w2 * m2)
    n = 9
    K = np.zeros((n, n))
    for x1, y, x2 in ((0, 1, 2), (3, 4, 5)):
        K[x1, x1] += kx1 + kx2
        K[x1, x2] -= kx2
        K[x2, x1] -= kx2
        K[x2, x2] += kx2
        K[y, y] += ky
    K[6, 6] = K[7, 7] = kd
    K[8, 8] = ktheta
    M = np.diag([m1, m1, m2, m1, m1, m2, md, md, Id])
    al = np.radians(alpha_deg)
    sa, ca = np.sin(al), np.cos(al)
    # damper point displacement (eq. 23): [x_d - b theta, y_d + a_i theta]
    left = np.zeros((2, n))
    left[0, [0, 1]] = sa, ca  # u_L (eq. 22)
    left[0, [6, 7, 8]] = -sa, -ca, sa * b - ca * (-a)
    left[1, [0, 1]] = ca, -sa  # v_L
    left[1, [6, 7, 8]] = -ca, sa, ca * b + sa * (-a)
    right = np.zeros((2, n))
    right[0, [3, 4]] = -sa, ca  # u_R
    right[0, [6, 7, 8]] = sa, -ca, -sa * b - ca * a
    right[1, [3, 4]] = -ca, -sa  # v_R
    right[1, [6, 7, 8]] = ca, sa, -ca * b + sa * a
    el = ContactElements.create("B", kt=kt, kn=kn, mu=mu, n0=0.0)
    model = TimeModel.create(M, K, beta * K, [(el, left), (el, right)])
    static = np.zeros(n)
    static[7] = CF
    harmonic = np.zeros(n, dtype=complex)
    harmonic[0], harmonic[3] = F, -F
    loads = LoadSteps.create(n, static=static, harmonic=harmonic, ramp_time=ramp_time,
                             settle_time=settle_time, ramp_periods=ramp_periods)
    return model, loads
