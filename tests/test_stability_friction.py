"""Stability by Hill's method (solve.stability) on friction contacts, against the event-driven
direct time integrator (solve.dti): the Floquet multipliers from the Hill exponents against
the eigenvalues of the monodromy matrix, the DTI's one-period map differentiated by central
differences about the balance's orbit, and trajectories started on the balance's solutions
(the unstable one leaves, the stable ones stay).

The case: cases/03_normal_load.toml's Fig. 24 configuration (a mass at 45 deg to a wall, law B,
kt = kn = 3 N/m, mu = 0.1, a gap of 0.5 N / kn that closes during the motion: hardening,
three solutions between the folds), in the coupled form (``interference = -0.5 N / kn``, the
same gap as ``n0 = -0.5``). The case file's uncoupled form ignores the static harmonic in
the contact and drops the contact's mean force (the static state "solved before"): its
forces depend on the mean of the motion over the period, so it has no time-domain twin and
the integrator's orbit is not the balance's (measured: one period from the balance's state
misses it by 0.5 m/s). Coupled, the balance's orbit returns onto itself within 1e-4.

Why the Hill multipliers agree to ~2e-3 with friction, not 1e-3 (measured at w = 1.19,
multipliers' largest distance to the integrator's, the integrator converged to 1e-5 in its
step):

    branch   H=5/512  H=7/512  H=9/1024  H=13/4096  H=19/4096   (H / samples)
    upper    5.7e-4   5.9e-4   6.7e-4    3.3e-4     3.4e-4
    middle   1.2e-3   6.9e-4   1.8e-3    1.7e-3     1.6e-3
    lower    2.1e-3   5.2e-4   2.9e-4    3.7e-4     3.6e-4

The difference does not shrink with H or the samples, and it vanishes without friction
(mu = 0, the same gap: 7e-5 at H = 5, 4e-7 at H = 13 and 4096 samples; it grows with mu: up
to 3e-3 at mu = 0.3). Hill's method uses the balance's contact Jacobian, that of the periodic
return map: under stick the linearised force kt (du(t) - du(t_stick)) holds the perturbation
at the stick onset, which for a perturbation exp(lambda t) p(t) carries the factor
exp(-lambda (t - t_stick)) that a lambda-independent Jacobian cannot (it is exact as
lambda -> 0: at the folds, where stability changes). The friction tolerance is set from
that measured floor; the frictionless sibling holds the issue's 1e-3 with a wide margin.
"""

import copy
from pathlib import Path

import numpy as np
import pytest

from microslip import case as cases
from microslip.laws.states import SAMPLE_OPEN, SAMPLE_SLIP
from microslip.solve import dti
from microslip.solve.linear import OperatingPoint
from microslip.solve.response import solve_point, sweep
from microslip.solve.stability import floquet_multipliers, hill_stability

CASES = Path(__file__).resolve().parents[1] / "cases"
BRANCHES = ("upper", "middle", "lower")  # by decreasing amplitude
W_FRICTION = 1.19  # rad/s, inside the folds at 1.1859 and 1.2148 (mu = 0.1, H = 5)
W_SMOOTH = 1.20  # rad/s, inside the folds at 1.1853 and 1.2159 (mu = 0)
#: DTI steps per period for the monodromy: its multipliers move by < 1.5e-5 from 4096 to
#: 16384 steps (second order), far below the tolerances below.
STEPS = 4096
#: Central-difference step on the state (m, m/s): forward and backward quotients agree to
#: 3e-6 at 1e-6 (the one-period map is differentiable: every transition is transversal).
EPS = 1e-6
#: Hill against the monodromy with friction: the measured floor of the module docstring
#: (largest 2.1e-3) with 20 % margin; without friction: the issue's 1e-3 (measured 7e-5).
TOL_FRICTION, TOL_SMOOTH = 2.5e-3, 1e-3


# ------------------------------------------------------------------ models
def gap_oscillator(H, samples, mu=None):
    """03_normal_load.toml's Fig. 24 oscillator, coupled form (see the module)."""
    data = copy.deepcopy(cases.load(CASES / "03_normal_load.toml").data)
    contact = data["contacts"][0]
    del contact["n0"]
    contact["form"] = "coupled"
    contact["interference"] = -0.5 / contact["kn"]  # the gap of n0 = -0.5 N
    if mu is not None:
        contact["mu"] = mu
    data["harmonics"] = {"max": H, "samples": samples}
    return cases.lumped_model(cases.Case(data, "03_normal_load.toml"))


def three_solutions(w, mu=None):
    """{branch: its recovered coefficients (1, ncoeff)} at ``w`` from an arclength sweep at
    H = 5 (the Fig. 24 sweep)."""
    hb = gap_oscillator(5, 256, mu)
    r = sweep(hb, "frequency", 0.9, 1.6, OperatingPoint(0.9))
    assert r.branch.status == "complete" and len(r.branch.turning_points) == 2
    crossings = [k for k in range(len(r) - 1) if (r.omega[k] - w) * (r.omega[k + 1] - w) <= 0]
    assert len(crossings) == 3, crossings
    coefs = [hb.recover(r.branch.x[k], OperatingPoint(w)) for k in crossings]
    coefs.sort(key=lambda c: -hb.harmonics.peak(c)[0])
    return dict(zip(BRANCHES, coefs, strict=True))


def solve_at(hb, w, guess):
    """The balance's solution at ``w`` from the coefficients of another H (padded or cut)."""
    x0 = np.zeros(hb.n_unknowns)
    n = min(x0.size, guess.shape[1])
    x0[:n] = guess[0, :n]
    r = solve_point(hb, OperatingPoint(w), x0=x0)
    assert r.converged
    return r.x


def state_at(hb, coef, w, theta):
    """(q, v) of the orbit ``coef`` (n_dof, ncoeff) at phase ``theta``."""
    h = hb.harmonics
    E = h.synthesis_at(np.array([theta]))[0]
    n = np.array(h.dynamic_orders, dtype=float)
    dE = np.zeros_like(E)
    dE[h.cos_index] = -n * np.sin(n * theta)
    dE[h.sin_index] = n * np.cos(n * theta)
    return coef @ E, w * (coef @ dE)


class OnePeriod:
    """The DTI's one-period map of the state (q, v) from the instant t0 = theta / w, where
    the contact's internal state is fixed by (q, v): open (T = N = 0), or, with
    ``slipping``, slipping at the force ``slipping`` (T = +-mu N whatever the perturbation)."""

    def __init__(self, hb, w, theta, steps=STEPS, slipping=None):
        self.hb = hb
        self.tm = dti.TimeModel.from_harmonic_balance(hb)
        self.F1 = hb.excitation.forces[1]
        self.w, self.t0, self.steps = w, theta / w, steps
        self.slipping = slipping

    def start(self, z):
        n = self.tm.n_dof
        s = dti.initial_state(self.tm, z[:n], z[n:], t0=self.t0)
        if self.slipping is None:
            assert np.all(s.flag == SAMPLE_OPEN), "the contact must be open at t0"
            return s
        T = np.zeros_like(s.T)
        T[:, 0] = self.slipping
        return dti.State(s.t, s.q, s.v, T, s.N, s.N_raw, s.g,
                         np.full_like(s.flag, SAMPLE_SLIP))

    def march(self, z, periods=1, steps=None):
        steps = steps or self.steps
        period = 2 * np.pi / self.w
        t = self.t0 + period / steps * np.arange(periods * steps + 1)
        F = np.real(self.F1[None, :] * np.exp(1j * self.w * t)[:, None])
        return dti.integrate(self.tm, F, t[-1], period / steps, initial=self.start(z))

    def __call__(self, z):
        end = self.march(z).end
        return np.concatenate([end.q, end.v])

    def monodromy(self, z):
        M = np.empty((z.size, z.size))
        for j in range(z.size):
            dz = np.zeros(z.size)
            dz[j] = EPS
            M[:, j] = (self(z + dz) - self(z - dz)) / (2 * EPS)
        return M


def open_phase(hb, coef):
    """The phase of the orbit's smallest displacement (the gap widest open)."""
    theta = np.linspace(0.0, 2 * np.pi, 4096, endpoint=False)
    return float(theta[np.argmin(hb.harmonics.synthesis_at(theta) @ coef[0])])


def distance(a, b):
    """max |a - b| over the multipliers of a, each to its nearest in b."""
    return max(float(np.abs(b - m).min()) for m in a)


def leading(m):
    return float(np.abs(m).max())


# ---------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def friction_solutions():
    return three_solutions(W_FRICTION)


@pytest.fixture(scope="module")
def monodromies(friction_solutions):
    """Per branch: the DTI's monodromy multipliers about the H = 9 balance's orbit, the state
    it starts from and the one-period map. Asserts that the orbit is the DTI's: one period
    returns within 1e-4 of the amplitude (measured <= 5e-5: the truncation at H = 9 and
    the step error)."""
    out = {}
    hb = gap_oscillator(9, 1024)
    for name, guess in friction_solutions.items():
        x = solve_at(hb, W_FRICTION, guess)
        coef = hb.recover(x, OperatingPoint(W_FRICTION))
        theta = open_phase(hb, coef)
        z = np.concatenate(state_at(hb, coef, W_FRICTION, theta))
        f = OnePeriod(hb, W_FRICTION, theta)
        amplitude = hb.harmonics.peak(coef)[0]
        back = f(z) - z
        assert np.hypot(back[0], back[1] / W_FRICTION) < 1e-4 * amplitude, (name, back)
        out[name] = dict(mono=np.linalg.eigvals(f.monodromy(z)), z=z, map=f,
                         amplitude=amplitude)
    return out


# ------------------------------------------------ (1) multipliers, friction
@pytest.mark.parametrize("H, samples", [(5, 512), (7, 512), (9, 1024)])
@pytest.mark.parametrize("where", BRANCHES)
def test_friction_multipliers_are_the_dti_monodromy(where, H, samples, friction_solutions,
                                                    monodromies):
    """Gap closing with friction (mu = 0.1), w = 1.19: every Hill multiplier within
    TOL_FRICTION of the integrator's (the floor of the module docstring), and the stability
    the same by both: the middle branch unstable (a real multiplier ~1.26), the outer two
    stable."""
    hb = gap_oscillator(H, samples)
    point = OperatingPoint(W_FRICTION)
    s = hill_stability(hb, solve_at(hb, W_FRICTION, friction_solutions[where]), point)
    hill = floquet_multipliers(s, W_FRICTION)
    mono = monodromies[where]["mono"]
    assert len(hill) == 2  # one DOF: one pair of exponents in the strip (dense, complete)
    assert distance(mono, hill) < TOL_FRICTION, (hill, mono)
    assert abs(leading(hill) - leading(mono)) < TOL_FRICTION
    assert s.stable == (where != "middle")
    assert (leading(mono) < 1.0) == (where != "middle")
    if where == "middle":  # a saddle: a real multiplier above one, by both
        assert leading(mono) > 1.2 and leading(hill) > 1.2
        assert abs(hill[np.argmax(np.abs(hill))].imag) < 1e-9


@pytest.fixture(scope="module")
def frictionless_solutions():
    return three_solutions(W_SMOOTH, mu=0.0)


@pytest.mark.parametrize("where", BRANCHES)
def test_without_friction_the_multipliers_agree_to_the_issues_bound(where,
                                                                    frictionless_solutions):
    """The same gap with mu = 0 (memoryless, piecewise linear): Hill within 1e-3 of the
    monodromy (measured <= 2.3e-6 at H = 9, 1024 samples): the agreement the friction case
    lacks is not the integrator's nor the contact/separation events'."""
    hb = gap_oscillator(9, 1024, mu=0.0)
    point = OperatingPoint(W_SMOOTH)
    x = solve_at(hb, W_SMOOTH, frictionless_solutions[where])
    hill = floquet_multipliers(hill_stability(hb, x, point), W_SMOOTH)
    coef = hb.recover(x, point)
    theta = open_phase(hb, coef)
    mono = np.linalg.eigvals(OnePeriod(hb, W_SMOOTH, theta).monodromy(
        np.concatenate(state_at(hb, coef, W_SMOOTH, theta))))
    assert distance(mono, hill) < TOL_SMOOTH * max(1.0, leading(mono)), (hill, mono)
    assert (leading(hill) > 1.0) == (leading(mono) > 1.0) == (where == "middle")


@pytest.mark.slow
def test_the_friction_gap_does_not_close_with_harmonics_or_samples(friction_solutions,
                                                                  frictionless_solutions):
    """Convergence in H and samples (fast siblings above): without friction Hill tends to the
    monodromy (<= 1e-5 from H = 9 and 1024 samples, measured 4e-7 at H = 13, 4096), with
    friction it stays ~1e-3 away however fine (measured 3e-4 .. 2e-3): the floor is the
    method's (the module docstring), not the truncation's."""
    cases_ = [(W_FRICTION, 0.1, friction_solutions), (W_SMOOTH, 0.0, frictionless_solutions)]
    gaps = {}
    for w, mu, solutions in cases_:
        hb9 = gap_oscillator(9, 1024, mu)
        for where in BRANCHES:
            coef = hb9.recover(solve_at(hb9, w, solutions[where]), OperatingPoint(w))
            theta = open_phase(hb9, coef)
            mono = np.linalg.eigvals(OnePeriod(hb9, w, theta, steps=8192).monodromy(
                np.concatenate(state_at(hb9, coef, w, theta))))
            for H, samples in [(9, 1024), (13, 2048), (13, 4096), (19, 4096)]:
                hb = gap_oscillator(H, samples, mu)
                s = hill_stability(hb, solve_at(hb, w, coef), OperatingPoint(w))
                gaps[mu, where, H, samples] = distance(mono, floquet_multipliers(s, w))
    smooth = [g for (mu, *_), g in gaps.items() if mu == 0.0]
    friction = [g for (mu, *_), g in gaps.items() if mu > 0.0]
    assert max(smooth) < 1e-5, gaps
    assert max(friction) < TOL_FRICTION, gaps
    middle = [g for (mu, where, *_), g in gaps.items() if mu > 0 and where == "middle"]
    assert min(middle) > 1e-4, gaps  # the floor: 100 x the frictionless agreement


# ---------------------------------------- (2) trajectories from the solutions
def departure(f, z, amplitude, periods, steps):
    """The distance of the state at every period start from z, relative to the amplitude
    (velocities scaled by 1 / w), and the trajectory."""
    tr = f.march(z, periods, steps)
    q, v = tr.q[::steps, 0], tr.v[::steps, 0]
    return np.hypot(q - z[0], (v - z[1]) / f.w) / amplitude, tr


def periodic_state(f, z, steps):
    """The integrator's own periodic state near z (Newton on z = P(z) with the monodromy of
    the map P at ``steps`` per period: shooting, which converges on unstable orbits too)."""
    g = OnePeriod(f.hb, f.w, f.t0 * f.w, steps)
    for _ in range(8):
        dz = np.linalg.solve(np.eye(z.size) - g.monodromy(z), g(z) - z)
        z = z + dz
        if np.abs(dz).max() < 1e-12:
            return z
    raise AssertionError("shooting did not converge")


def test_an_integration_started_on_the_middle_branch_leaves_it(monodromies):
    """From the unstable solution's state the integration leaves: its distance from the
    integrator's own periodic orbit grows by the leading multiplier per period while small
    (3e-3 .. 3e-2 of the amplitude: the stable multiplier's part has decayed by 0.68^n and
    the motion is still linear there: 1 %), passes 10 % of the amplitude and the motion
    settles on an outer branch's amplitude (the lower one's at w = 1.19)."""
    m = monodromies["middle"]
    f, z = m["map"], m["z"]
    steps = 2048
    star = periodic_state(f, z, steps)
    assert np.hypot(*(star - z) * [1, 1 / f.w]) < 1e-3 * m["amplitude"]  # the HB orbit's
    tr = f.march(z, 60, steps)
    q, v = tr.q[::steps, 0], tr.v[::steps, 0]
    d = np.hypot(q - star[0], (v - star[1]) / f.w) / m["amplitude"]
    escape = int(np.argmax(d > 0.1))
    assert 10 < escape < 60 and d.max() > 0.1
    window = np.flatnonzero((d[:escape] > 3e-3) & (d[:escape] < 3e-2))
    assert window.size >= 5
    rate = (d[window[-1]] / d[window[0]]) ** (1.0 / (window[-1] - window[0]))
    assert rate == pytest.approx(leading(m["mono"]), rel=0.01)
    # settled after 250 periods: the last period's max |x| is an outer branch's (the
    # 512-step error is 1.5e-4, the transient decays by 0.946 per period over the ~200
    # periods after the escape)
    tr = f.march(z, 250, 512)
    final = np.abs(tr.q[-513:, 0]).max()
    outer = [monodromies[b]["amplitude"] for b in ("upper", "lower")]
    assert min(abs(final - a) / a for a in outer) < 2e-3, (final, outer)


@pytest.mark.parametrize("where", ["upper", "lower"])
def test_an_integration_started_on_a_stable_branch_stays(where, monodromies):
    """From a stable solution's state the integration stays within 2e-3 of the amplitude
    for 40 periods (measured <= 4e-4 at 512 steps per period: the step error (w dt)^2 ~
    1.5e-4 and the offset of the H = 9 orbit from the integrator's, which the stable map
    contracts to; the middle branch passes 10 % in ~30 periods from as close)."""
    m = monodromies[where]
    d, _ = departure(m["map"], m["z"], m["amplitude"], 40, 512)
    assert d.max() < 2e-3, d.max()


# ------------------------------------------------- (3) stick-slip, law A
def test_stick_slip_jenkins_multipliers_are_the_dti_monodromy():
    """cases/01_sdof_wall.toml (law A, constant N0 = 0.05 N, mu = 1) at w = 1, in stick-slip
    (94 % of the period slipping): the monodromy of the (q, v) map from an instant in slip
    (T = -mu N0 held there, whatever the perturbation). The leading multiplier within 1e-4
    (measured 8e-6 at H = 9, 1024 samples), the other within 5e-3 (measured 3e-3, 6e-5 at H
    = 13 and 2048 samples: the sampled stick arc, ~60 samples, and the memory of the module
    docstring)."""
    data = copy.deepcopy(cases.load(CASES / "01_sdof_wall.toml").data)
    data["contacts"][0]["n0"] = 0.05
    data["harmonics"] = {"max": 9, "samples": 1024}
    hb = cases.lumped_model(cases.Case(data, "01_sdof_wall.toml"))
    w = 1.0
    point = OperatingPoint(w)
    r = solve_point(hb, point)
    assert r.converged
    response = hb.contact_response(r.x, point, histories=True)[0]
    flags = response.flags[0]
    assert 0.5 < response.slip_fraction[0] < 1.0  # stick-slip
    # the middle sample of the longest slip run: the perturbed starts slip the same way
    slip = np.flatnonzero(flags == SAMPLE_SLIP)
    runs = np.split(slip, np.flatnonzero(np.diff(slip) > 1) + 1)
    i = (run := max(runs, key=len))[len(run) // 2]
    T = response.T[0, 0, i]
    assert abs(abs(T) - 0.05) < 1e-12
    theta = 2 * np.pi * i / hb.harmonics.n_samples
    coef = hb.recover(r.x, point)
    z = np.concatenate(state_at(hb, coef, w, theta))
    f = OnePeriod(hb, w, theta, slipping=T)
    back = f(z) - z
    assert np.hypot(back[0], back[1] / w) < 1e-4 * hb.harmonics.peak(coef)[0]
    mono = np.linalg.eigvals(f.monodromy(z))
    s = hill_stability(hb, r.x, point)
    hill = floquet_multipliers(s, w)
    assert s.stable and leading(mono) < 1.0
    assert abs(leading(hill) - leading(mono)) < 1e-4, (hill, mono)
    assert distance(mono, hill) < 5e-3, (hill, mono)
