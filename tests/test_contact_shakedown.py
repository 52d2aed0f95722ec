"""Shakedown: contacts that slip in their first periods and then stick for ever (issue 11, 2).

A cycle that sticks all period is periodic from any start state near it: the period map
has Phi = I and the periodicity (I - Phi) dT = b leaves its derivative free (that solve
used to return NaN). Its tangential state is the history's choice, the predictor/corrector
of Firrone & Zucca eqs. 26-28: the march from T = kt u(t0), static part included, slipping where it
must. The Jacobian has to be the derivative of that same choice, i.e. of the forces the
code returns: checked against central differences of them.

Cases (a ``how`` in the ids): ``plain``, the march sticks after a few periods and is
replayed with derivatives; ``corner``, the march closes in on a corner of the stuck set
(slipping at the same two samples period after period, too slowly to wait for) and the
cycle is the stuck one touching the limit at both, differentiated implicitly;
(a third path, ``remarched``: a Newton jump on the periodicity landed in the stuck set
elsewhere and the march is repeated without jumps, is now rare: the 2D plain march is watched
for its own corner before any jump, and its two former cases close on corners). The 1D
laws shake down in two periods (a 1D slip erases the memory); there the failure was the
sample touching the limit flipping between stick and slip with the last bits of the forces,
and with it the sub-sample kink term.
"""

from dataclasses import replace

import numpy as np
import pytest
from derivatives import fd_contact_jacobian

from microslip.fourier import Harmonics
from microslip.laws.coulomb import ContactElements
from microslip.laws.states import (
    GROSS_SLIP,
    PARTIAL_LIFTOFF,
    SAMPLE_OPEN,
    SAMPLE_SLIP,
    SAMPLE_STICK,
    STICK,
    STICK_SLIP,
)

H = Harmonics.up_to(2, 64)  # coefficients [a0, a1, b1, a2, b2] per component

# law, coupled, how, relative motion [u1, (u2), (v)]; kt = kn = 1, mu = 0.5, N0 = 1
CASES = {
    "D-coupled-plain": ("D", True, "plain",
                        [[0.5, 0.3, 0, 0, 0], [0, 0, 0.3, 0, 0], [0, 0.3, 0, 0.2, 0]]),
    "D-coupled-corner": ("D", True, "corner",
                         [[0.5, 0.3, 0, 0, 0], [0, 0, 0.3, 0, -0.1], [0, 0.3, 0, 0.2, 0]]),
    # (was "remarched": a Newton jump landed near another corner and the march was repeated;
    # the plain march is now watched for its own corner first)
    "D-coupled-corner-2": ("D", True, "corner",
                           [[0.3, 0.2, 0, 0, 0], [0, 0, 0.3, 0, -0.1], [0, 0.3, 0, 0.2, 0]]),
    "D-uncoupled-corner": ("D", False, "corner",
                           [[0, 0.4, 0, 0.1, 0], [0, 0, 0.3, 0, -0.1], [0, 0.3, 0, 0, 0]]),
    # (was "remarched" while a slip onset after a stuck sample took radial return and the
    # flow only continued slips: the march now closes on a corner of the stuck set)
    "D-uncoupled-corner-2": ("D", False, "corner",
                             [[0, 0.4, 0, 0, 0], [0, 0, 0.3, 0, -0.1], [0, 0.3, 0, 0.2, 0]]),
    "C-coupled-plain": ("C", True, "plain",
                        [[0.4, -0.2, -0.2, 0, 0.3], [0.4, 0.2, 0.1, -0.1, 0.2]]),
    "C-coupled-corner": ("C", True, "corner",
                         [[0.3, 0.4, 0, 0.1, 0], [0.2, 0, 0.3, 0, -0.1]]),
    "C-uncoupled-plain": ("C", False, "plain",
                          [[0, 0.1, 0.3, -0.2, -0.1], [0, 0.1, 0.2, 0.3, 0.1]]),
    "C-uncoupled-corner": ("C", False, "corner",
                           [[0, 0.1, 0.2, -0.3, 0], [0, -0.3, 0.3, 0, -0.1]]),
    "B-coupled": ("B", True, "plain", [[0.7, 0.2, 0.1, 0.05, 0], [0, 0.3, 0, 0.1, 0.1]]),
    "B-uncoupled": ("B", False, "plain", [[0, 0.4, 0, 0.2, 0], [0, 0.05, 0, 0, 0.02]]),
    "A-coupled": ("A", True, "plain", [[0.7, 0.2, 0.1, 0.05, 0]]),
    "A-uncoupled": ("A", False, "plain", [[0, 0.4, 0, 0.2, 0]]),
}


def contact(law, coupled, n_points=None):
    kw = dict(kt=1.0, mu=0.5, n_points=n_points)
    if law in "BD":
        kw.update(kn=1.0, **({"interference": 1.0} if coupled else {"n0": 1.0}))
    else:
        kw["n0"] = 1.0
    return ContactElements.create(law, coupled=coupled, **kw)


def case(name):
    law, coupled, how, g = CASES[name]
    return contact(law, coupled), np.array([g], dtype=float), how


def fd_jacobian(el, g, h, eps=1e-6):
    return fd_contact_jacobian(el, g, h, eps)


def fd_n0(el, g, h, eps=1e-6):
    fp = el.with_n0(el.n0 + eps).evaluate(g, h, jacobian=False).forces
    fm = el.with_n0(el.n0 - eps).evaluate(g, h, jacobian=False).forces
    return (fp - fm) / (2 * eps)


# Central differences at eps = 1e-6: truncation O(eps^2) ~ 1e-12 on these smooth stuck
# cycles; rounding of the forces (sums over 64 samples, periodicity to rtol 1e-13 of the
# force scale) over eps, ~1e-7 relative at most. The analytic Jacobians agree to ~1e-9;
# 1e-6 is ten times the rounding bound and far below the errors of a Jacobian with the
# wrong start-state derivative (0.1 to 1 here) or with a kink term flipping (>= 1e-4).
FD_RTOL = 1e-6


@pytest.mark.parametrize("name", CASES)
def test_the_state_is_a_shakedown(name):
    """Each case slips in its first period and ends stuck all period (reported as stick),
    after more than two periods in 2D (where (I - Phi) dT = b was solved); the stuck cycle
    is T = kt u + const within the limit and touches it (where it last slipped)."""
    el, g, how = case(name)
    first = el.evaluate(g, H, jacobian=False, histories=True, rtol=0.0, max_periods=1)
    assert np.any(first.flags == SAMPLE_SLIP)
    r = el.evaluate(g, H, jacobian=False, histories=True)
    assert np.all(r.flags == SAMPLE_STICK) and r.state[0] == STICK
    assert r.periods[0] >= (3 if el.dim == 2 else 2)
    T, u, N = r.T[0], r.u[0], r.N[0]
    scale = np.abs(T).max()
    # the stuck increments are kt du summed over a period: rounding, ~1e-15 of the scale
    assert np.ptp(T - el.kt[0][:, None] * u, axis=1).max() <= 1e-12 * scale
    ratio = np.sqrt((T**2).sum(axis=0)) / (0.5 * N)
    # within the limit up to the stick slack (1e-11 relative), and touching it
    assert ratio.max() <= 1 + 1e-10 and ratio.max() >= 1 - 1e-10
    if how == "corner":
        # a corner: the limit is touched at two samples, at an angle
        assert np.sum(np.abs(ratio - 1) <= 1e-10) == 2
    assert r.dissipation[0] == pytest.approx(0, abs=1e-12)


@pytest.mark.parametrize("name", CASES)
def test_shakedown_jacobian_matches_central_differences(name):
    el, g, _ = case(name)
    r = el.evaluate(g, H)
    assert np.all(np.isfinite(r.jacobian)) and np.all(np.isfinite(r.d_n0))
    # the Jacobian path returns the very forces the force-only path does
    assert np.array_equal(r.forces, el.evaluate(g, H, jacobian=False).forces)
    J = r.jacobian.reshape(1, g[0].size, g[0].size)
    assert np.max(np.abs(J - fd_jacobian(el, g, H))) <= FD_RTOL * np.max(np.abs(J))
    assert np.max(np.abs(r.d_n0 - fd_n0(el, g, H))) <= FD_RTOL * max(np.abs(r.d_n0).max(), 1)


@pytest.mark.parametrize("name", CASES)
def test_stuck_cycle_is_where_the_march_settles(name):
    """The cycle returned is the predictor/corrector's: the plain march from T = kt u(t0)
    (rtol = 0: no periodicity test, so no Newton jump on it)."""
    el, g, how = case(name)
    r = el.evaluate(g, H, jacobian=False)
    if how == "corner":
        plain = el.evaluate(g, H, jacobian=False, histories=True, rtol=0.0, max_periods=100)
        assert np.all(plain.flags == SAMPLE_STICK)  # it has settled (in 10 to 30 periods)
        # it closes in on the corner geometrically and stops once its slip falls within the
        # stick slack (1e-11 relative): 2e-11 away at most here; 1e-9 leaves room for the
        # rounding of the stuck periods after it and is far below the 1e-6 to 1e-5 a
        # Newton jump into the stuck set lands away
        assert np.max(np.abs(r.forces - plain.forces)) <= 1e-9 * np.abs(r.forces).max()
    else:
        # the same march, period for period: the same forces to the bit
        plain = el.evaluate(g, H, jacobian=False, histories=True, rtol=0.0,
                            max_periods=int(r.periods[0]))
        assert np.all(plain.flags == SAMPLE_STICK)
        assert np.array_equal(r.forces, plain.forces)


def mixed_d(rng):
    """Law D, coupled: the three shakedown cases next to points that mix stick, slip,
    lift-off and re-contact in one period, a gross-slip point and a point stuck from the
    start, each with its own parameters."""
    shake = [np.array(CASES[n][3], dtype=float) for n in CASES
             if CASES[n][:2] == ("D", True)]
    P = len(shake) + 5
    kt = np.ones((P, 2))
    kn, mu, inter = np.ones(P), np.full(P, 0.5), np.ones(P)
    g = np.zeros((P, 3, H.n_coeffs))
    g[:len(shake)] = shake
    rich = slice(len(shake), len(shake) + 3)
    kt[rich] = rng.uniform(1.0, 3.0, (3, 1))
    kn[rich] = rng.uniform(1.0, 2.0, 3)
    mu[rich] = rng.uniform(0.2, 0.6, 3)
    inter[rich] = rng.uniform(0.05, 0.3, 3)
    g[rich] = 0.15 * rng.normal(size=(3, 3, H.n_coeffs))
    g[rich, :2, 1] += 0.6
    g[rich, 2, 1] += 0.5 * inter[rich] + 0.3
    g[-2, 0, 1:3] = [2.0, 0.0]  # gross slip on a circle of radius 2 >> mu N / kt = 0.5
    g[-2, 1, 1:3] = [0.0, 2.0]
    # N varying: at constant N, central differences on v make the limit vary over a step
    # by ~eps, where the slip flow's integral of 1/L switches form (1e-8): noise ~3e-5
    g[-2, 2, 3] = 0.1
    g[-1, 0, 0:3] = [0.1, 0.1, 0.0]  # |kt u| <= 0.25 < mu N: stuck from the start
    g[-1, 1, 0:3] = [0.0, 0.0, 0.1]
    el = ContactElements.create("D", kt=kt, kn=kn, mu=mu, interference=inter, coupled=True)
    return el, g


def test_jacobian_of_mixed_points_in_one_call():
    rng = np.random.default_rng(11)
    el, g = mixed_d(rng)
    r = el.evaluate(g, H, histories=True)
    # the states really mix: shakedowns, stick-slip with lift-off, gross slip, stuck
    assert list(r.state[:3]) == [STICK] * 3 and r.state[-1] == STICK
    assert np.all(r.state[3:6] == PARTIAL_LIFTOFF) and r.state[-2] == GROSS_SLIP
    assert np.any(r.flags == SAMPLE_OPEN) and np.any(r.flags == SAMPLE_SLIP)
    J = r.jacobian.reshape(el.size, g[0].size, g[0].size)
    Jfd = fd_jacobian(el, g, H)
    # per point, as above (FD_RTOL)
    for p in range(el.size):
        assert np.max(np.abs(J[p] - Jfd[p])) <= FD_RTOL * np.max(np.abs(J[p])), p
    assert np.max(np.abs(r.d_n0 - fd_n0(el, g, H))) <= FD_RTOL * max(np.abs(r.d_n0).max(), 1)


def test_jacobian_of_mixed_1d_points_in_one_call():
    """Law B coupled: shakedown, stick-slip with lift-off and plain stick side by side."""
    P = 4
    g = np.zeros((P, 2, H.n_coeffs))
    g[0] = CASES["B-coupled"][3]
    g[1] = [[0.2, 0.9, 0.1, 0, 0.05], [0.0, 1.3, 0.2, 0, 0]]  # opens, recloses, slips
    g[2] = [[0.0, 0.9, 0.0, 0, 0], [0.0, 0.1, 0.0, 0, 0]]  # stick-slip, closed throughout
    g[3] = [[0.1, 0.1, 0.1, 0, 0], [0.0, 0.1, 0.0, 0, 0]]  # stuck from the start
    el = contact("B", True, n_points=P)
    r = el.evaluate(g, H, histories=True)
    assert list(r.state) == [STICK, PARTIAL_LIFTOFF, STICK_SLIP, STICK]
    J = r.jacobian.reshape(P, g[0].size, g[0].size)
    Jfd = fd_jacobian(el, g, H)
    for p in range(P):  # FD_RTOL, as above
        assert np.max(np.abs(J[p] - Jfd[p])) <= FD_RTOL * np.max(np.abs(J[p])), p


@pytest.mark.parametrize("name", ["D-coupled-plain", "D-coupled-corner", "B-coupled",
                                  "C-coupled-plain"])
def test_a_start_phase_is_the_march_from_that_point_of_the_period(name):
    """``start_phase`` p marches from time p of the period: the same as the march from 0 of
    the motion advanced by p, x(t + p), whose samples are taken here directly at t_k + p
    (not through the coefficient rotation the elements use). Its forces are those, read
    back at t - p; the mean force is where a shakedown's start shows (it differs from the
    start at 0), and the Jacobian is the derivative of the same forces."""
    el, g, _ = case(name)
    p = 2.0 * np.pi * 0.37  # not a whole number of samples
    shifted = replace(el, start_phase=p)
    E_p = H.synthesis_at(H.theta + p)
    advanced = np.einsum("kc,pjc->pjk", E_p, g) @ H.analysis.T  # x(t + p), exact to H
    r0 = el.evaluate(advanced, H, jacobian=False, histories=True)
    r = shifted.evaluate(g, H, histories=True)
    # histories: rounding of the coefficients turned and summed, ~1e-15
    assert np.allclose(r.u, r0.u, rtol=0, atol=1e-13)
    assert np.allclose(r.T, r0.T, rtol=0, atol=1e-12)
    # the forces: at t_k + p the same samples as the advanced march's at t_k
    scale = np.abs(r0.forces).max()
    assert np.allclose(np.einsum("kc,pjc->pjk", E_p, r.forces),
                       np.einsum("kc,pjc->pjk", H.synthesis, r0.forces), rtol=0,
                       atol=1e-12 * scale)
    # the start matters for these cycles: the mean forces move by more than rounding
    moved = np.abs(r.forces[..., 0] - el.evaluate(g, H, jacobian=False).forces[..., 0]).max()
    assert moved > 1e-6 * scale
    J = r.jacobian.reshape(1, g[0].size, g[0].size)
    assert np.max(np.abs(J - fd_jacobian(shifted, g, H))) <= FD_RTOL * np.max(np.abs(J))
    assert np.max(np.abs(r.d_n0 - fd_n0(shifted, g, H))) <= FD_RTOL * max(
        np.abs(r.d_n0).max(), 1)

