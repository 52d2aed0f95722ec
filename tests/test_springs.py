"""The benchmark nonlinearities (laws.springs) through the law registry: the cubic
spring of the Duffing oscillator against the closed form of its one-harmonic balance, the
unilateral spring against the half-wave's Fourier coefficients, both Jacobians against
central differences, and their case tables (faults, one line each)."""

import copy

import numpy as np
import pytest
from case_helpers import case_faults

from microslip import case as cases
from microslip.fourier import Harmonics
from microslip.laws.registry import LAWS
from microslip.laws.states import OPEN, PARTIAL_LIFTOFF, STICK
from microslip.solve.linear import OperatingPoint
from microslip.solve.response import solve_point, sweep

ZETA, GAMMA, FORCE = 0.05, 0.1, 0.1
DUFFING = {
    "title": "Duffing",
    "model": {"dofs": ["x"], "mass": [1.0], "stiffness": [1.0], "damping": [2 * ZETA]},
    "contacts": [{"name": "cubic", "law": "polynomial", "coefficients": [0.0, 0.0, GAMMA],
                  "u": {"x": 1.0}}],
    "loads": [{"dof": "x", "amplitude": FORCE}],
    "harmonics": {"max": 1, "samples": 16},
    "analysis": [{"name": "frf", "type": "frf", "start": 0.5, "stop": 2.0}],
}


def duffing(H=1, samples=16):
    data = copy.deepcopy(DUFFING)
    data["harmonics"] = {"max": H, "samples": samples}
    return cases.lumped_model(cases.Case(data, "05_duffing.toml"))


def test_the_duffing_balance_of_one_harmonic_is_its_closed_form():
    """x'' + 2 zeta x' + x + gamma x^3 = P cos w t with x = a cos + b sin: the harmonic balance
    ((1 - w^2) A + 3/4 gamma A^3)^2 + (2 zeta w A)^2 = P^2, A = |(a, b)|, exact at 16 samples
    (x^3 holds harmonics up to 3: no aliasing from 7 samples on), on every point of a sweep
    through the hardening peak (its fold included)."""
    hb = duffing()
    r = sweep(hb, "frequency", 0.5, 2.0, OperatingPoint(0.5))
    assert r.branch.status == "complete"
    for x, w in zip(r.branch.x, r.omega, strict=True):
        a = np.hypot(*hb.recover(x, OperatingPoint(w))[0][1:3])
        lhs = ((1 - w * w) * a + 0.75 * GAMMA * a**3) ** 2 + (2 * ZETA * w * a) ** 2
        # Newton stops at 1e-9 of the force scale: the balance to that
        assert lhs == pytest.approx(FORCE**2, rel=1e-7)
    w_peak, a_peak = r.peak(0)
    # the largest A of that balance (d/dw = 0): w^2 = 1 + 3/4 gamma A^2 - 2 zeta^2 and
    # A = P / (2 zeta sqrt(w^2 + zeta^2)); to the peak's resolution along the curve
    assert w_peak**2 == pytest.approx(1 + 0.75 * GAMMA * a_peak**2 - 2 * ZETA**2, rel=2e-3)
    assert a_peak == pytest.approx(FORCE / (2 * ZETA * np.hypot(w_peak, ZETA)), rel=2e-3)


@pytest.mark.parametrize("law, table, motion", [
    ("polynomial", {"coefficients": [2.0, -0.3, 0.5]}, lambda t: 0.1 + 0.8 * np.cos(t)
     - 0.3 * np.sin(2 * t)),
    ("unilateral", {"kn": 3.0, "gap": 0.2}, lambda t: 0.1 + 0.8 * np.cos(t)
     - 0.3 * np.sin(2 * t)),
])
def test_spring_forces_and_jacobians(law, table, motion):
    """The force coefficients are the samples' (AFT), and the Jacobian is the central
    differences' (exact where no sample crosses the kink within +-eps)."""
    h = Harmonics.up_to(3, 64)
    el = LAWS[law].elements(table)
    g = (h.analysis @ motion(h.theta))[None, None, :]
    r = el.evaluate(g, h)
    f, _ = el.force((h.synthesis @ g[0, 0])[None])
    np.testing.assert_allclose(r.forces[0, 0], h.analysis @ f[0], atol=1e-14)
    eps = 1e-7
    fd = np.empty((h.n_coeffs, h.n_coeffs))
    for j in range(h.n_coeffs):
        e = np.zeros_like(g)
        e[0, 0, j] = eps
        fd[:, j] = (el.evaluate(g + e, h, jacobian=False).forces[0, 0]
                    - el.evaluate(g - e, h, jacobian=False).forces[0, 0]) / (2 * eps)
    np.testing.assert_allclose(r.jacobian[0, 0, :, 0, :], fd, atol=1e-7 * np.abs(fd).max())


def test_the_unilateral_spring_is_a_half_wave_and_says_when_it_opens():
    """u = U cos: with no gap the force is kn U max(cos, 0), first harmonic kn U / 2 and mean
    kn U / pi (to the sampling's error, the kink between samples); closed all period: stick
    (state), never: open, else partial lift-off."""
    h = Harmonics.up_to(1, 1024)
    el = LAWS["unilateral"].elements({"kn": 2.0, "gap": 0.0})
    r = el.evaluate(np.array([[[0.0, 0.5, 0.0]]]), h)
    assert r.forces[0, 0, 1] == pytest.approx(2.0 * 0.5 / 2, rel=1e-5)
    assert r.forces[0, 0, 0] == pytest.approx(2.0 * 0.5 / np.pi, rel=1e-5)
    assert r.state[0] == PARTIAL_LIFTOFF
    closed = LAWS["unilateral"].elements({"kn": 2.0, "gap": -1.0})
    assert closed.evaluate(np.array([[[0.0, 0.5, 0.0]]]), h).state[0] == STICK
    far = LAWS["unilateral"].elements({"kn": 2.0, "gap": 1.0})
    assert far.evaluate(np.array([[[0.0, 0.5, 0.0]]]), h).state[0] == OPEN


@pytest.mark.parametrize("mutate, expected", [
    (lambda d: d["contacts"][0].update(coefficients="cubic"),
     "contacts.cubic.coefficients = 'cubic': expected [c_1, c_2, ...]"),
    (lambda d: d["contacts"][0].update(kn=1.0), "contacts.cubic.kn: unknown key"),
    (lambda d: d["contacts"][0].update(law="unilateral", kn=-1.0, gap=0.0,
                                       coefficients=None) or d["contacts"][0].pop(
                                           "coefficients"),
     "contacts.cubic.kn = -1.0: expected a stiffness > 0"),
    (lambda d: d["analysis"].append({"name": "t", "type": "dti", "frequencies": [1.0]}),
     "time integration takes the friction laws A-D only"),
])
def test_spring_faults_are_one_line_each(mutate, expected):
    found = case_faults(DUFFING, mutate)
    assert any(expected in f for f in found), found


def test_the_duffing_balance_of_seven_harmonics_is_the_time_integration():
    """At a force where the third harmonic matters (P = 0.6, the peak near 1.5 rad/s), the
    harmonic balance with harmonics 0-7 against SciPy's integrator run to the steady state:
    the harmonics' coefficients of x(t) agree to 1e-6 of the largest (the truncation at 7
    and the integrator's tolerance)."""
    from scipy.integrate import solve_ivp

    force, w = 0.6, 1.2
    data = copy.deepcopy(DUFFING)
    data["harmonics"] = {"max": 7, "samples": 128}
    data["loads"][0]["amplitude"] = force
    hb = cases.lumped_model(cases.Case(data, "05_duffing.toml"))
    r = sweep(hb, "frequency", 0.5, w, OperatingPoint(0.5))  # the lower branch's end
    assert r.branch.status == "complete"
    coef = hb.recover(r.branch.x[-1], OperatingPoint(w))[0]

    def rhs(t, y):
        x, v = y
        return [v, force * np.cos(w * t) - 2 * ZETA * v - x - GAMMA * x**3]

    period = 2 * np.pi / w
    x0 = [hb.harmonics.synthesis[0] @ coef, w * (hb.harmonics.synthesis[0] @ (
        hb.harmonics.derivative @ coef))]  # start on the HB orbit: the transient is short
    sol = solve_ivp(rhs, (0, 60 * period), x0, rtol=1e-11, atol=1e-13, dense_output=True)
    t = 59 * period + hb.harmonics.theta / w
    measured = hb.harmonics.analysis @ sol.sol(t)[0]
    np.testing.assert_allclose(measured, coef, atol=1e-6 * np.abs(coef).max())


def test_a_spring_beside_a_friction_contact():
    """A unilateral stop beside law A in one lumped case: far away (gap 10 m) it changes
    nothing (the friction case's points to round-off); touching (gap 0.1 m, inside the
    motion) it stiffens the peak up in frequency and down in amplitude."""
    base = {"title": "t", "model": {"dofs": ["x"], "mass": [1.0], "stiffness": [1.0],
                                    "damping": [0.02]},
            "contacts": [{"name": "wall", "law": "A", "kt": 3.0, "mu": 1.0, "n0": 0.05,
                          "u": {"x": 1.0}}],
            "loads": [{"dof": "x", "amplitude": 0.1}], "harmonics": {"max": 3},
            "analysis": [{"name": "frf", "type": "frf", "start": 0.5, "stop": 2.5}]}
    peaks, solutions = {}, {}
    for gap in (None, 10.0, 0.1):
        data = copy.deepcopy(base)
        if gap is not None:
            data["contacts"].append({"name": "stop", "law": "unilateral", "kn": 5.0,
                                     "gap": gap, "u": {"x": 1.0}})
        hb = cases.lumped_model(cases.Case(data, "t.toml"))
        points = [solve_point(hb, OperatingPoint(w)) for w in (0.9, 1.0, 1.1)]
        assert all(p.converged for p in points)
        peaks[gap] = sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(0.5)).peak(0)
        solutions[gap] = np.array([p.x for p in points])
    # (the same DOF, x, is the one unknown of both cases)
    np.testing.assert_allclose(solutions[10.0], solutions[None], atol=1e-12)
    assert peaks[10.0] == pytest.approx(peaks[None], rel=1e-12)
    assert peaks[0.1][0] > 1.05 * peaks[None][0] and peaks[0.1][1] < peaks[None][1]
