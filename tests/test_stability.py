"""Stability by Hill's method (solve.stability): the exponents of a linear oscillator are
its own (closed form), the Duffing oscillator's change stability exactly at the folds of its
response curve (the middle branch unstable), and the Floquet multipliers equal the monodromy
matrix's from SciPy's integration of the variational equations (an independent path)."""

import copy

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from microslip import case as cases
from microslip.solve.linear import OperatingPoint
from microslip.solve.response import solve_point, sweep
from microslip.solve.stability import floquet_multipliers, hill_stability

ZETA, GAMMA = 0.05, 0.1


def _duffing_data(force, gamma=GAMMA):
    return {"title": "Duffing", "model": {"dofs": ["x"], "mass": [1.0], "stiffness": [1.0],
                                          "damping": [2 * ZETA]},
            "contacts": [{"name": "cubic", "law": "polynomial",
                          "coefficients": [0.0, 0.0, gamma], "u": {"x": 1.0}}],
            "loads": [{"dof": "x", "amplitude": force}],
            "analysis": [{"name": "frf", "type": "frf", "start": 0.5, "stop": 2.0}]}


def duffing(force, H, gamma=GAMMA):
    data = {**_duffing_data(force, gamma),
            "harmonics": {"max": H, "samples": max(64, 16 * (H + 1))}}
    return cases.lumped_model(cases.Case(copy.deepcopy(data), "05_duffing.toml"))


@pytest.mark.parametrize("w", [0.6, 1.0, 1.7])
def test_a_linear_oscillators_exponents_are_its_eigenvalues(w):
    """gamma = 0: the exponents are -zeta +- i sqrt(1 - zeta^2), shifted by i k w into the
    strip |Im| <= w / 2: real parts -zeta exactly, whatever the forcing frequency."""
    hb = duffing(0.1, 3, gamma=0.0)
    p = OperatingPoint(w)
    s = hill_stability(hb, solve_point(hb, p).x, p)
    assert s.stable and len(s.exponents) == 2
    np.testing.assert_allclose(s.exponents.real, -ZETA, atol=1e-10)
    wd = np.sqrt(1 - ZETA**2)
    shifted = np.abs(np.abs(s.exponents.imag) - np.abs(wd - w * np.round(wd / w)))
    assert shifted.max() < 1e-9


def test_the_duffing_middle_branch_is_unstable_between_the_folds():
    """Along a hardening sweep that folds (P = 0.3): stable up to the first turning point,
    unstable between the two, stable after; the exponent through zero at each fold."""
    hb = duffing(0.3, 3)
    r = sweep(hb, "frequency", 0.5, 2.0, OperatingPoint(0.5))
    assert r.branch.status == "complete"
    folds = sorted(r.branch.turning_points)
    assert len(folds) == 2, folds
    stable = np.array([hill_stability(hb, x, OperatingPoint(w)).stable
                       for x, w in zip(r.branch.x, r.omega, strict=True)])
    i, j = folds
    # the turning points are the last stable and first unstable points, within one step
    assert stable[: i - 1].all() and not stable[i + 1: j - 1].any() and stable[j + 1:].all()


@pytest.mark.parametrize("where", ["lower", "middle", "upper"])
def test_multipliers_are_the_monodromy_matrix(where):
    """At w = 1.2, P = 0.3, H = 7 (three solutions): the Floquet multipliers from the Hill
    exponents against the eigenvalues of the monodromy matrix, the variational equations
    integrated over one period along the balance's orbit; to 1e-3 (the issue's bound; the
    truncation at seven harmonics and the integrator's tolerance)."""
    hb = duffing(0.3, 7)
    w = 1.2
    r = sweep(hb, "frequency", 0.5, 2.0, OperatingPoint(0.5))
    crossings = [k for k in range(len(r) - 1)
                 if (r.omega[k] - w) * (r.omega[k + 1] - w) <= 0]
    assert len(crossings) == 3, crossings
    k = crossings[("lower", "middle", "upper").index(where)]
    x = solve_point(hb, OperatingPoint(w), x0=r.branch.x[k]).x
    s = hill_stability(hb, x, OperatingPoint(w))
    coef = hb.recover(x, OperatingPoint(w))[0]
    h = hb.harmonics

    def rhs(t, y):
        u = h.synthesis_at(np.array([w * t]))[0] @ coef
        Phi = y.reshape(2, 2)
        A = np.array([[0.0, 1.0], [-(1.0 + 3 * GAMMA * u * u), -2 * ZETA]])
        return (A @ Phi).ravel()

    sol = solve_ivp(rhs, (0.0, 2 * np.pi / w), np.eye(2).ravel(), rtol=1e-11, atol=1e-13)
    def ordered(z):  # (a conjugate pair's equal real parts differ in round-off)
        return z[np.lexsort((z.imag, np.round(z.real, 6)))]

    mono = ordered(np.linalg.eigvals(sol.y[:, -1].reshape(2, 2)))
    hill = ordered(floquet_multipliers(s, w))
    np.testing.assert_allclose(hill, mono, atol=1e-3 * max(1.0, np.abs(mono).max()))
    assert s.stable == (where != "middle")
    assert (np.abs(mono).max() < 1.0) == s.stable


def _fold_of_one_harmonic(branch: str) -> float:
    """w at a fold of the one-harmonic Duffing balance (closed form of its amplitude
    equation a^2 [(1 - w^2 + 3/4 gamma a^2)^2 + (2 zeta w)^2] = P^2, P = 0.3): where
    d w / d a = 0, solved by SciPy from either side."""
    from scipy.optimize import fsolve

    def equations(v):
        a, w = v
        q = 1 - w**2 + 0.75 * GAMMA * a**2
        f = q**2 + (2 * ZETA * w) ** 2
        return [a**2 * f - 0.3**2, 2 * a * f + a**2 * 2 * q * 1.5 * GAMMA * a]

    guess = (2.5, 1.21) if branch == "upper" else (1.3, 1.15)
    return float(fsolve(equations, guess, xtol=1e-14)[1])


def test_the_folds_are_located_where_the_closed_form_puts_them(tmp_path):
    """One harmonic (the closed form's own truncation): the run's located folds against
    the amplitude equation's, to 1e-9 (the test function, the real exponent, is within
    1e-9 w of zero or bracketed to 1e-4 of the step, and the branch's w is quadratic in the
    distance to the fold);
    the stability datasets say unstable exactly between them, and the terminal lists them."""
    import h5py

    from microslip.app.run import run_case

    data = cases.load("cases/05_duffing.toml").data
    data["harmonics"] = {"max": 1, "samples": 64}
    data["analysis"][0]["family"]["values"] = [0.3]
    said = []
    run_case(cases.Case(data, "05_duffing.toml"), tmp_path, progress=said.append, cache=False)
    with h5py.File(tmp_path / "results.h5") as f:
        c = f["frf/curve_000"]
        b = c["bifurcations"]
        assert [k.decode() for k in b["kind"][()]] == ["fold", "fold"]
        assert b["located"][()].all()
        np.testing.assert_allclose(sorted(b["omega"][()]),
                                   sorted(_fold_of_one_harmonic(s) for s in ("upper", "lower")),
                                   rtol=1e-9)
        stable, index = c["stable"][()], np.sort(b["index"][()])
        assert stable[: index[0] + 1].all() and stable[index[1] + 1:].all()
        assert not stable[index[0] + 1: index[1] + 1].any()
        assert np.isnan(c["floquet"][:, 2:]).all()  # one DOF: two exponents per point
    assert sum("fold at frequency" in line for line in said) == 2


def quadratic_cubic(H: int, force: float = 0.5, beta: float = 1.0, gamma: float = 1.0):
    """x'' + 2 zeta x' + x + beta x^2 + gamma x^3 = P cos(w t), zeta = 0.01."""
    data = {"title": "quadratic-cubic", "model": {"dofs": ["x"], "mass": [1.0],
                                                  "stiffness": [1.0], "damping": [0.02]},
            "contacts": [{"name": "spring", "law": "polynomial",
                          "coefficients": [0.0, beta, gamma], "u": {"x": 1.0}}],
            "loads": [{"dof": "x", "amplitude": force}],
            "harmonics": {"max": H, "samples": 16 * (H + 1)},
            "analysis": [{"name": "frf", "type": "frf", "start": 1.6, "stop": 2.4}]}
    return cases.lumped_model(cases.Case(copy.deepcopy(data), "qc.toml"))


def test_period_doubling_at_the_half_subharmonic_resonance():
    """Forced near twice its natural frequency, the quadratic spring modulates the
    stiffness at w (2 beta x): a Mathieu first tongue, where the T-periodic response loses
    stability through a multiplier -1. Hill's method finds two period doublings (an
    exponent pair through Im = w / 2), the same to 1e-5 at H = 4 and 6, and at each the
    monodromy matrix of SciPy's integration of the variational equations has a multiplier
    at -1 (to 1e-3: the location to 1e-4 of the step and the truncation)."""
    from microslip.solve.bifurcation import find_bifurcations

    found = {}
    for H in (4, 6):
        hb = quadratic_cubic(H)
        r = sweep(hb, "frequency", 1.6, 2.4, OperatingPoint(1.6))
        points = [hill_stability(hb, x, r.point(i)) for i, x in enumerate(r.branch.x)]
        found[H] = (hb, find_bifurcations(r, points))
        assert [b.kind for b in found[H][1]] == ["period doubling"] * 2
    np.testing.assert_allclose([b.omega for b in found[4][1]],
                               [b.omega for b in found[6][1]], rtol=1e-5)
    hb, bifurcations = found[6]
    h = hb.harmonics
    for b in bifurcations:
        assert b.located and abs(abs(b.exponent.imag) - b.omega / 2) < 1e-6 * b.omega
        w = b.omega
        coef = hb.recover(b.x, OperatingPoint(w))[0]

        def rhs(t, y, w=w, coef=coef):
            u = h.synthesis_at(np.array([w * t]))[0] @ coef
            A = np.array([[0.0, 1.0], [-(1.0 + 2 * u + 3 * u * u), -0.02]])
            return (A @ y.reshape(2, 2)).ravel()

        sol = solve_ivp(rhs, (0.0, 2 * np.pi / w), np.eye(2).ravel(), rtol=1e-11,
                        atol=1e-13)
        mono = np.linalg.eigvals(sol.y[:, -1].reshape(2, 2))
        assert np.min(np.abs(mono + 1.0)) < 1e-3


def test_a_branch_circling_a_kink_makes_no_bifurcation():
    """Stability flipping back and forth at points a hair apart (a branch circling a
    stick/slip kink) is one cluster: none when it ends as it began, its first
    change when it does not; changes far apart, or across a natural sweep's jump, stay."""
    from microslip.solve.bifurcation import _changes

    values = np.array([0.0, 1.0, 2.0, 2.0 + 1e-9, 2.0 - 1e-9, 2.0 + 2e-9, 3.0, 4.0])
    counts = [(k, 0, 0) for k in (0, 0, 0, 1, 0, 1, 1, 0)]
    # 2 -> 5: 0, 1, 0, 1 (net +1: the first change, at 2); 6 -> 7 a change on its own
    assert _changes(values, counts, set()) == [(2, 0), (6, 0)]
    counts[5] = (0, 0, 0)  # the cluster ends as it began: nothing there
    counts[6] = (0, 0, 0)
    assert _changes(values, counts, set()) == []
    assert _changes(values, [(0, 0, 0)] * 7 + [(0, 1, 0)], {6}) == []  # across a jump


def test_odd_harmonics_are_analysed_on_every_order():
    """A balance kept on the odd orders (the Duffing's solution has no even harmonic) gets
    its stability from every order up to its highest: the same exponents as the balance on
    orders 0..7 at the same solution, to 1e-8 (Newton's tolerance on the solution)."""
    full = duffing(0.3, 7)
    data = {"orders": [1, 3, 5, 7], "samples": 128}
    odd = cases.lumped_model(cases.Case({**_duffing_data(0.3), "harmonics": data}, "o.toml"))
    p = OperatingPoint(1.2)
    r = sweep(odd, "frequency", 0.5, 2.0, OperatingPoint(0.5))
    k = [i for i in range(len(r) - 1) if (r.omega[i] - 1.2) * (r.omega[i + 1] - 1.2) <= 0][1]
    x = solve_point(odd, p, x0=r.branch.x[k]).x
    got = hill_stability(odd, x, p)
    want = hill_stability(full, solve_point(full, p, x0=odd.embed(x, full)).x, p)
    assert not got.stable and not want.stable  # the middle branch
    np.testing.assert_allclose(np.sort_complex(got.exponents), np.sort_complex(want.exponents),
                               atol=1e-8)


@pytest.mark.parametrize("dense", [True, False])
def test_the_exponents_come_in_one_order_on_every_run(monkeypatch, dense):
    """The same point gives the same exponents in the same order, run after run: ARPACK's
    start vector is seeded, and a conjugate pair (real parts equal to round-off) is ordered
    by its imaginary part, positive first (its order flipped between runs before, so two
    runs of a shipped case differed in their ``floquet`` datasets)."""
    from microslip.solve import stability

    if not dense:
        monkeypatch.setattr(stability, "DENSE", 0)  # the ARPACK path on a small model
    hb = duffing(0.3, 5)
    p = OperatingPoint(1.2)
    x = solve_point(hb, p).x
    runs = [hill_stability(hb, x, p).exponents for _ in range(3)]
    for other in runs[1:]:
        np.testing.assert_array_equal(other, runs[0])
    pair = runs[0][:2]
    assert pair[0] == pytest.approx(pair[1].conjugate(), rel=1e-9) and pair[0].imag > 0
    # a permutation of the same values sorts back into that order
    shuffled = np.random.default_rng(1).permutation(runs[0])
    np.testing.assert_array_equal(shuffled[stability._leading_first(shuffled, 1.2)],
                                  runs[0])
