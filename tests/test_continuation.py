"""Continuation: folds, parameters other than frequency, failure reports."""

import itertools

import numpy as np
import pytest
from models import jenkins_oscillator, normal_oscillator

from microslip.solve import arclength, newton
from microslip.solve import continuation as cont
from microslip.solve.linear import OperatingPoint
from microslip.solve.response import solve_point, sweep


def s_curve(x, lam, jac=True):
    """R = x^3 - x - lam: an S-shaped branch with folds at x = +-1/sqrt(3)."""
    return (np.array([x[0] ** 3 - x[0] - lam]), np.array([[3 * x[0] ** 2 - 1]]),
            np.array([-1.0]))


def test_arclength_follows_both_folds_of_an_s_curve():
    b = cont.arclength(s_curve, np.array([-1.5]), -2.0, 2.0, parameter="lam",
                       settings=cont.Settings(tol=1e-12))
    assert b.complete and b.values[-1] == 2.0
    x = b.x[:, 0]
    assert np.max(np.abs(x**3 - x - b.values)) <= 1e-12
    # the folds at lam = -+2 / (3 sqrt 3), located to the local step size
    fold = 2 / (3 * np.sqrt(3))
    assert len(b.turning_points) == 2
    # a turning point is where the parameter reverses between points, and only there
    d = np.sign(np.diff(b.values))
    assert b.turning_points == [j for j in range(1, len(d)) if d[j - 1] * d[j] < 0]
    assert b.values[b.turning_points[0]] == pytest.approx(fold, abs=0.02)
    assert b.values[b.turning_points[1]] == pytest.approx(-fold, abs=0.02)
    # three solutions at lam = 0: -1, 0, +1
    at_zero = []
    for i in np.flatnonzero(np.diff(np.sign(b.values)) != 0):
        t = b.values[i] / (b.values[i] - b.values[i + 1])  # linear interpolation to lam = 0
        at_zero.append(x[i] + t * (x[i + 1] - x[i]))
    assert np.allclose(sorted(at_zero), [-1, 0, 1], atol=0.05)


def test_natural_continuation_jumps_and_misses_the_middle_branch():
    up = cont.natural(s_curve, np.array([-1.5]), -2.0, 2.0,
                      settings=cont.Settings(tol=1e-12, step=0.01))
    assert up.complete
    # past the fold the sweep falls onto the upper branch: x never sits in (-1/sqrt3, 1/sqrt3)
    middle = np.abs(up.x[:, 0]) < 1 / np.sqrt(3) - 0.05
    assert not middle.any()
    assert up.x[-1, 0] == pytest.approx(1.5214, abs=1e-3)
    # one jump, from the fold at lam = 2 / (3 sqrt 3) (located to min_step x the range) to
    # the upper branch one regular step on (x^3 - x = lam there, x > 1)
    fold = 2 / (3 * np.sqrt(3))
    assert len(up.jumps) == 1
    i, j = up.jumps[0]
    assert j == i + 1 and fold - 4 * 1e-6 <= up.values[i] <= fold
    assert up.values[j] == pytest.approx(up.values[i] + 0.04, abs=4e-6)
    assert up.x[j, 0] > 1 and abs(up.x[j, 0] ** 3 - up.x[j, 0] - up.values[j]) <= 1e-12
    assert "jumped at the fold at lambda = 0.38489" in up.message


def test_a_fold_of_one_unknown_among_many_is_located_and_jumped():
    """The S-curve's unknown beside 399 that follow the parameter smoothly (a whole disk's
    fold is one blade's among thousands of unknowns, and a jump there moves the rms over
    all of them little): the sweep locates the fold and records the jump as the S-curve
    alone does, and never lands on the middle branch."""
    n = 400
    slope = np.linspace(0.5, 1.5, n - 1)

    def many(x, lam, jac=True):
        R0, J0, L0 = s_curve(x[:1], lam)
        J = np.eye(n)
        J[0, 0] = J0[0, 0]
        return (np.concatenate([R0, x[1:] - slope * lam]), J,
                np.concatenate([L0, -slope]))

    x0 = np.concatenate([[-1.5], slope * -2.0])
    up = cont.natural(many, x0, -2.0, 2.0, settings=cont.Settings(tol=1e-12, step=0.01))
    assert up.complete and len(up.jumps) == 1
    i, _ = up.jumps[0]
    fold = 2 / (3 * np.sqrt(3))
    assert fold - 4 * 1e-6 <= up.values[i] <= fold  # located to min_step x the range
    assert not np.any(np.abs(up.x[:, 0]) < 1 / np.sqrt(3) - 0.05)  # never the middle


def test_a_natural_sweep_never_steps_past_a_value_where_it_failed(monkeypatch):
    """Towards a fold the step halves; after a shorter step converged, the next one stops at
    the value that failed (before: twice the step, past it, two more failing solves a
    halving). The fold is located as before, with 176 Newton solves instead of 195."""
    tried = []
    plain = cont.newton

    def logged(fun, x0, lam, **kw):
        r = plain(fun, x0, lam, **kw)
        tried.append((lam, r.converged))
        return r

    monkeypatch.setattr(cont, "newton", logged)
    up = cont.natural(s_curve, np.array([-1.5]), -2.0, 2.0,
                      settings=cont.Settings(tol=1e-12, step=0.01))
    i, j = up.jumps[0]
    fold = 2 / (3 * np.sqrt(3))
    assert fold - 4 * 1e-6 <= up.values[i] <= fold  # (as before)
    ahead = np.inf
    before = itertools.takewhile(lambda t: t[0] < up.values[j], tried)  # up to the landing
    for lam, ok in before:
        assert lam <= ahead + 1e-12
        ahead = min(ahead, lam) if not ok else (np.inf if lam >= ahead - 1e-12 else ahead)
    assert up.steps <= 176


def test_natural_sweep_stops_where_the_solution_set_ends():
    """R = x^2 + lam: no solution at all for lam > 0; the sweep up ends at the fold, says so
    and keeps what it computed."""
    def parabola(x, lam, jac=True):
        return np.array([x[0] ** 2 + lam]), np.array([[2 * x[0]]]), np.array([1.0])

    b = cont.natural(parabola, np.array([1.0]), -1.0, 1.0, settings=cont.Settings(tol=1e-12))
    assert b.status == "stopped" and not b.jumps
    assert "the end of the solution set" in b.message
    # the last point sits within min_step (1e-5 x the range) below the fold at lam = 0; at
    # x ~ 1e-8 the residual's tol 1e-12 allows lam to round to just above 0
    assert -1e-5 <= b.values[-1] <= 1e-12


def test_a_stalled_newton_gives_up_early_and_a_slow_steady_one_does_not():
    """``stall``: R = x^2 + 1 has no real root, and Newton wanders with ||R|| >= 1 (its best
    never halves): with stall 6 it stops after 6 of its 25 iterations and says why. R = x^3
    converges only linearly (x shrinks by 2/3 an iterate, ||R|| by 8/27: halved every
    iterate): never cut. A natural sweep uses it (newton.STALL), and so does arclength's landing."""
    def no_root(x, lam, jac=True):
        return np.array([x[0] ** 2 + 1]), np.array([[2 * x[0]]]), np.array([0.0])

    def cubic(x, lam, jac=True):
        return np.array([x[0] ** 3]), np.array([[3 * x[0] ** 2]]), np.array([0.0])

    settings = cont.Settings(tol=1e-12)
    full = cont.newton(no_root, np.array([0.3]), 0.0, settings=settings)
    cut = cont.newton(no_root, np.array([0.3]), 0.0, settings=settings, stall=6)
    assert not full.converged and full.iterations == 25
    assert not cut.converged and cut.iterations == 6 and cut.reason.startswith("stalled")
    slow = cont.newton(cubic, np.array([1.0]), 0.0, settings=settings, stall=6)
    # (2/3)^3k <= 1e-12 from k = 23: within max_iter 25
    assert slow.converged and slow.iterations == 23


@pytest.mark.slow  # (Fig. 24's folds stay fast: test_fig24_natural_sweeps_jump_at_both_folds)
def test_softening_fold_of_the_variable_normal_load_oscillator():
    """Firrone & Zucca Fig. 8 / 24: a preload that lets the contact open softens the peak
    into a fold; arclength follows it, natural continuation cannot."""
    hb = normal_oscillator(0.3, H=5, ns=256)
    arc = sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(0.5))
    assert arc.branch.complete, arc.branch.message
    assert len(arc.branch.turning_points) == 2
    lo, hi = sorted(arc.values[arc.branch.turning_points])
    w = 0.5 * (lo + hi)
    # three solutions at a frequency inside the fold; each solves the balance
    i = np.flatnonzero(np.diff(np.sign(arc.values - w)) != 0)
    assert i.size == 3
    amps = []
    for j in i:
        sol = solve_point(hb, OperatingPoint(w), x0=arc.branch.x[j])
        assert sol.converged
        amps.append(np.hypot(sol.x[1], sol.x[2]))
    assert np.ptp(amps) > 0.1 and len(set(np.round(amps, 4))) == 3
    up, down = _natural_sweeps_jump_at_the_folds(hb, arc, 0.5, 2.5)
    a_down = down.amplitude([0])[:, 0]
    inside = (down.omega > lo + 0.005) & (down.omega < hi - 0.005)
    a_arc = arc.amplitude([0])[:, 0]
    mid = a_arc[arc.branch.turning_points[0]:arc.branch.turning_points[1] + 1]
    assert not np.any((a_down[inside] > mid.min() + 0.01) & (a_down[inside] < mid.max() - 0.01))


def test_fig24_natural_sweeps_jump_at_both_folds():
    """Firrone & Zucca Fig. 24 (law B, a gap of 0.5 N / kn that closes during the motion:
    hardening): the ascending and the descending natural sweeps each jump at their fold, onto the
    branch that arclength continuation computes there."""
    hb = normal_oscillator(-0.5, mu=0.1)
    arc = sweep(hb, "frequency", 0.9, 1.6, OperatingPoint(0.9))
    assert arc.branch.complete and len(arc.branch.turning_points) == 2
    up, down = _natural_sweeps_jump_at_the_folds(hb, arc, 0.9, 1.6)
    # the hardening peak leans right: the upward sweep stays on the resonant branch
    # to the upper fold, then falls onto the lower one
    i, j = up.branch.jumps[0]
    assert up.amplitude([0])[j, 0] < 0.5 * up.amplitude([0])[i, 0]
    # the middle branch, between the turning points, is the unstable one (Hill's method;
    # points next to a fold may go either way: its exponent is nearly zero there)
    from microslip.solve.stability import hill_stability

    stable = np.array([hill_stability(hb, x, arc.point(k)).stable
                       for k, x in enumerate(arc.branch.x)])
    a, b = arc.branch.turning_points
    assert stable[:a].all() and not stable[a + 1:b].any() and stable[b + 1:].all()


def _natural_sweeps_jump_at_the_folds(hb, arc, start, stop):
    """The upward and the downward natural sweeps over [start, stop]: each complete with one
    jump, up at the arclength curve's upper fold and down at its lower one, landing on the
    branch arclength computed at the next value. Returns (up, down)."""
    lo, hi = sorted(arc.values[arc.branch.turning_points])
    up = sweep(hb, "frequency", start, stop, OperatingPoint(start), method="natural")
    down = sweep(hb, "frequency", stop, start, OperatingPoint(stop), method="natural")
    for r, fold in ((up, hi), (down, lo)):
        assert r.branch.complete, r.branch.message
        assert len(r.branch.jumps) == 1 and "jumped at the fold" in r.branch.message
        i, j = r.branch.jumps[0]
        assert r.values[i] == pytest.approx(fold, abs=_arc_spacing(arc, fold))
        _assert_on_arclength_branch(hb, arc, r, j)
    return up, down


def _arc_spacing(arc, fold: float) -> float:
    """How far the arclength curve's turning point may sit from the true fold: the parameter
    spacing of its points around the one nearest ``fold`` (near a fold the parameter varies
    quadratically along the arc, so the fold lies within one spacing of the extreme point)."""
    w = arc.values
    k = int(np.argmin(np.abs(w - fold)))
    return float(np.max(np.abs(np.diff(w[max(k - 1, 0): k + 2]))))


def _assert_on_arclength_branch(hb, arc, r, j):
    """Point j of the natural sweep r is the solution of the arclength branch at its
    frequency: one of the arclength's crossings of that value, solved there by Newton,
    equals it to the Newton tolerance."""
    w = r.values[j]
    crossings = np.flatnonzero(np.diff(np.sign(arc.values - w)) != 0)
    dist = []
    for k in crossings:
        t = (w - arc.values[k]) / (arc.values[k + 1] - arc.values[k])
        guess = arc.branch.x[k] + t * (arc.branch.x[k + 1] - arc.branch.x[k])
        sol = solve_point(hb, OperatingPoint(w), x0=guess)
        assert sol.converged
        dist.append(np.max(np.abs(sol.x - r.branch.x[j])))
    # tol 1e-9 x the force scale on the residual: the same solution agrees to ~1e-8 x the
    # amplitude; another branch is 0.1-1 m away
    assert min(dist) <= 1e-6 * np.max(np.abs(r.branch.x[j]))


@pytest.mark.parametrize("parameter,start,stop", [("preload", 0.01, 2.0),
                                                  ("excitation", 0.05, 5.0),
                                                  ("mass", 0.5, 1.5)])
def test_parameter_continuation_matches_pointwise_solutions(parameter, start, stop):
    hb = jenkins_oscillator(H=3, n_samples=128)
    base = OperatingPoint(1.1)
    r = sweep(hb, parameter, start, stop, base)
    assert r.branch.complete, r.branch.message
    for i in np.linspace(0, len(r) - 1, 5).astype(int):
        sol = solve_point(hb, base.set(parameter, r.values[i]))
        assert sol.converged
        # the same solution (unique here), to the Newton tolerance
        assert np.max(np.abs(sol.x - r.branch.x[i])) <= 1e-7 * np.max(np.abs(sol.x))


def test_performance_curve_asymptotes():
    """Amplitude over excitation (Firrone & Zucca Fig. 6, right): stuck receptance at small
    forces, free receptance at large ones."""
    w = 0.7
    hb = jenkins_oscillator(H=3, n_samples=128, P=1.0)
    r = sweep(hb, "excitation", 1e-3, 50.0, OperatingPoint(w))
    assert r.branch.complete
    c = r.coefficients([0])[:, 0]
    amp = np.hypot(c[:, 1], c[:, 2]) / r.values  # first-harmonic receptance
    stuck = 1 / abs(4.0 - w**2 + 0.02j * w)
    free = 1 / abs(1.0 - w**2 + 0.02j * w)
    assert amp[0] == pytest.approx(stuck, rel=1e-9)  # mu N = 0.05 > kt x at P = 1e-3
    assert amp[-1] == pytest.approx(free, rel=0.01)  # friction 0.05 N against 50 N


def test_failure_is_reported_with_the_branch_kept():
    hb = normal_oscillator(0.3, H=5, ns=256)
    # one Newton iteration per attempt: neither the sweep nor its detour round the fold
    # gets far (with two, the detour now passes the fold and the sweep completes)
    tight = cont.Settings(max_iter=1, min_step=1e-3)
    r = sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(0.5), method="natural", settings=tight)
    assert not r.branch.complete
    assert len(r) > 0 and np.all(r.branch.residuals <= tight.tol)
    assert "frequency =" in r.branch.message and "iterations" in r.branch.message
    assert r.branch.failed is not None and np.all(np.isfinite(r.branch.failed[1]))


def test_peak_tracking_matches_full_sweeps():
    """The optimization curve traced by continuation of the peak equals the
    peaks of full FRFs (where the peak is single-humped), with fewer solves."""
    from microslip.solve.peaks import peak_curve

    hb = jenkins_oscillator(H=1, n_samples=128, fs=1.0)  # the preload multiplier is N0
    values = np.linspace(0.0, 1.5, 16)
    pc = peak_curve(hb, "preload", values, 0, (0.5, 2.5))
    assert pc.how.count("tracked") >= 12
    steps = 0
    for v, a_t in list(zip(values, pc.amplitude))[::5]:
        r = sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(0.5).set("preload", v))
        steps += r.branch.steps
        _, a = r.peak(0)
        # same local maximum, refined to 1e-7 of the window: amplitudes agree to 1e-6;
        # a flat two-humped peak may be followed on its other hump (1e-4 measured)
        assert a_t == pytest.approx(a, rel=2e-4)
    assert pc.solves < steps / 4 * len(values)


def v_kink(x, lam, jac=True):
    """R = [x1 - 10 |lam|, x2 - lam]: the branch x(lam) turns sharply in x at lam = 0
    (a stick/slip kink) while lam keeps growing; J = I has no fold anywhere."""
    return (np.array([x[0] - 10 * abs(lam), x[1] - lam]), np.eye(2),
            np.array([-10 * np.sign(lam), -1.0]))


def test_arclength_passes_a_kink_without_retracing():
    # the tangents before and after the kink point opposite ways in x (dot product < 0):
    # orienting each along the previous one would turn the branch back onto itself;
    # the sign of det [J dR; t] (constant away from folds) carries it through
    b = cont.arclength(v_kink, np.array([10.0, -1.0]), -1.0, 1.0, parameter="lam",
                       settings=cont.Settings(tol=1e-12))
    assert b.complete and b.values[-1] == 1.0
    assert np.all(np.diff(b.values) > 0) and b.turning_points == []
    assert np.allclose(b.x[:, 0], 10 * np.abs(b.values), atol=1e-9)


def test_a_stalled_branch_stops_and_says_why():
    # undamped, with a force friction cannot bound (P = 0.1 N > 4 mu N / pi = 0.064 N):
    # the response runs off to infinity at w = 1 rad/s and the branch never gets past it
    hb = jenkins_oscillator(3, 64, c=0.0, kt=1e2)
    r = sweep(hb, "frequency", 0.55, 2.5, OperatingPoint(0.55))
    assert r.branch.status == "stopped" and "stalled at frequency = 1" in r.branch.message
    assert len(r) < 3 * arclength.STALL_POINTS + 400  # stopped, not piled up to max_points
    assert np.ptp(r.values[-arclength.STALL_POINTS:]) < arclength.STALL_SPAN * 1.95
    assert r.amplitude([0])[-1, 0] > 1e3  # it did run off (m, against 0.1 N / 1 N/m)


def wave(x, lam, jac=True):
    """n copies of R_i = x_i - sin(3 lam): the same curved branch in every unknown."""
    n = x.size
    return x - np.sin(3 * lam), np.eye(n), np.full(n, -3 * np.cos(3 * lam))


def test_the_arc_metric_does_not_depend_on_the_number_of_unknowns():
    # the unknowns enter the arc length by their root mean square: 400 copies of one
    # unknown trace the very same points as one (a 2-norm would weight the parameter
    # 1/20 as much and take ~20 times the points)
    one = cont.arclength(wave, np.zeros(1), 0.0, 2.0, parameter="lam")
    many = cont.arclength(wave, np.zeros(400), 0.0, 2.0, parameter="lam")
    assert one.complete and many.complete
    assert len(one) == len(many)
    assert np.allclose(one.values, many.values, rtol=0, atol=1e-9)
    assert np.allclose(many.x, np.sin(3 * many.values)[:, None], atol=1e-9)


def test_the_corrector_gives_up_early_where_newton_makes_no_progress():
    # R = x^2 + 1 has no root: damped Newton stalls at x = 0 with ||R|| = 1; the
    # corrector says so after STAGNATION iterations instead of spending max_iter
    # (each with up to 7 line-search evaluations) before the step is halved
    calls = []

    def no_root(x, lam, jac=True):
        calls.append(lam)
        return np.array([x[0] ** 2 + 1.0]), np.array([[2 * x[0]]]), np.array([0.0])

    settings = cont.Settings(max_iter=25, target_iter=4)
    tangent = np.array([0.0, 1.0])
    ok, _, its, res, why = newton.corrector(no_root, np.array([0.3, 0.0]), tangent,
                                         np.ones(1), 1.0, 1.0, settings)
    assert not ok and "no progress" in why and res >= 1.0
    assert its <= newton.STAGNATION + 2
    assert len(calls) <= 8 * (newton.STAGNATION + 2)  # 7 trials per iteration at most


def test_a_watch_stops_the_branch_where_it_says_so():
    """The watch sees every new point and its answer ends the branch there, as its message;
    an empty answer changes nothing (the same points as without a watch)."""
    seen = []

    def watch(lam, x):
        seen.append(lam)
        return "enough" if lam > 0.0 else ""

    b = cont.arclength(s_curve, np.array([-1.5]), -2.0, 2.0, watch=watch)
    assert b.status == "stopped" and b.message == "enough"
    assert b.values[-1] > 0.0 and np.all(b.values[:-1] <= 0.0)
    assert seen == list(b.values[1:])  # every point after the first, once
    free = cont.arclength(s_curve, np.array([-1.5]), -2.0, 2.0, watch=lambda lam, x: "")
    plain = cont.arclength(s_curve, np.array([-1.5]), -2.0, 2.0)
    assert free.complete and np.array_equal(free.values, plain.values)


def cusp(c):
    """R = x - lam + c sqrt(max(lam - 1, 0)): the branch x = lam - c sqrt(lam - 1) turns
    down at lam = 1 with an infinite slope, the square-root cusp of a 2D contact starting
    to slip. A short arclength step's hyperplane meets it only ~c^2 / 4 past the cusp,
    beyond ON_BRANCH x the step: no short step lands there."""
    def fun(x, lam, jac=True):
        d = max(lam - 1.0, 0.0)
        slope = 0.5 * c / np.sqrt(d) if d > 0 else 0.0
        return (np.array([x[0] - lam + c * np.sqrt(d)]), np.array([[1.0]]),
                np.array([-1.0 + slope]))
    return fun


@pytest.mark.parametrize("c", [0.4, 1.0])
def test_a_square_root_cusp_is_leapt_after_two_misses(c):
    # c = 0.4: the early leap passes it after EARLY_LEAP_MISSES misses, not after the step
    # has been halved down to min_step (a corner tried on the way): measured 44 correctors
    # against 87. c = 1.0: no leap lands (the fixed-parameter crossing passes it, 84
    # correctors); the leaps that missed cost a few correctors more (89), bounded by
    # EARLY_SPACING. Either way the points past it are on the branch.
    def run(early):
        mp = pytest.MonkeyPatch()
        mp.setattr(arclength, "EARLY_LEAPS", early)
        try:
            return cont.arclength(cusp(c), np.array([0.0]), 0.0, 2.0, parameter="lam",
                                  settings=cont.Settings(tol=1e-12))
        finally:
            mp.undo()

    late, early = run(0), run(arclength.EARLY_LEAPS)
    for b in (late, early):
        assert b.complete and b.values[-1] == 2.0
        x, lam = b.x[:, 0], b.values
        assert np.max(np.abs(x - lam + c * np.sqrt(np.maximum(lam - 1, 0)))) <= 1e-10
        assert np.any(lam > 1.0) and np.all(np.diff(lam) > 0)
    if c < 0.5:
        assert early.steps < 0.6 * late.steps
    else:
        assert early.steps <= 1.1 * late.steps
