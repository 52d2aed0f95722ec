"""Harmonic balance: time integration, energy balance, limits, derivatives."""

import numpy as np
import pytest
from derivatives import fd_residual_jacobian
from jenkins_dti import steady_peak
from models import jenkins_oscillator, normal_oscillator, three_dof_cyclic_like

from microslip.fourier import Harmonics
from microslip.solve.continuation import Settings
from microslip.solve.hbm import Contact, HarmonicBalance
from microslip.solve.linear import Excitation, LinearDynamics, OperatingPoint
from microslip.solve.response import solve_point, sweep


@pytest.fixture(scope="module")
def jenkins_frf():
    hb = jenkins_oscillator()
    return sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(0.5))


# ~9 s (ten converged time integrations); the fast suite keeps HBM against time integration on
# the blade-damper (test_blade_damper) and the loops (test_dti)
@pytest.mark.slow
def test_jenkins_peak_matches_time_integration(jenkins_frf):
    r = jenkins_frf
    assert r.branch.complete
    w_hb, a_hb = r.peak(0)
    hb, h = r.model, r.model.harmonics

    def dti(w):
        # start the integration from the HB state: only shortens the transient,
        # the integrator runs until its own period repeats to 1e-9
        p = OperatingPoint(w)
        x = solve_point(hb, p, x0=r.branch.x[np.argmin(np.abs(r.values - w))]).x
        Q = hb.recover(x, p)[0]
        T0 = hb.contact_response(x, p, histories=True)[0].T[0, 0, 0]
        return steady_peak(1.0, 0.02, 1.0, 3.0, 0.05, 0.1, w, h.synthesis[0] @ Q,
                           w * h.synthesis[0] @ (h.derivative @ Q), T0, tol=1e-9)[0]

    # golden section on the DTI amplitude around the HB peak frequency
    a, b = w_hb - 0.004, w_hb + 0.004
    g = (np.sqrt(5) - 1) / 2
    c, d = b - g * (b - a), a + g * (b - a)
    fc, fd = dti(c), dti(d)
    for _ in range(8):
        if fc > fd:
            b, d, fd = d, c, fc
            c = b - g * (b - a)
            fc = dti(c)
        else:
            a, c, fc = c, d, fd
            d = a + g * (b - a)
            fd = dti(d)
    a_dti = max(fc, fd)
    # HB at H = 7 truncates harmonics above 7 (~1e-4 here); 1e-3 holds it with margin
    assert a_hb == pytest.approx(a_dti, rel=1e-3)
    # the published orientation values (peak near 1.841 at w near 1.002)
    assert a_hb == pytest.approx(1.841, abs=2e-3) and w_hb == pytest.approx(1.002, abs=2e-3)


def test_energy_balance_at_every_point(jenkins_frf):
    r = jenkins_frf
    for i in range(0, len(r), 5):
        e = r.energy(i)
        assert e["normal"] == 0.0
        # excitation work = viscous + friction, to the Newton tolerance (1e-9 of the force)
        assert e["excitation"] == pytest.approx(e["viscous"] + e["friction"], abs=1e-9)
        assert e["friction"] >= -1e-12


def test_energy_balance_with_condensation_and_complex_kinematics():
    h = Harmonics.up_to(3, 128)
    hb = three_dof_cyclic_like(h)
    for w in (0.8, 1.7, 2.5):
        sol = solve_point(hb, OperatingPoint(w))
        assert sol.converged
        e = hb.energy_balance(sol.x, OperatingPoint(w))
        total = e["viscous"] + e["friction"] + e["normal"]
        assert e["excitation"] == pytest.approx(total, abs=1e-8 * abs(e["excitation"]) + 1e-12)


def test_recovery_satisfies_every_equation():
    """Seed eq. 9: the recovered DOFs satisfy D_n Q_n = F_n + F_nl at all DOFs."""
    h = Harmonics.up_to(3, 128)
    hb = three_dof_cyclic_like(h)
    p = OperatingPoint(1.3, mass_multiplier=1.4)
    sol = solve_point(hb, p)
    Q = hb.recover(sol.x, p)
    D = hb.linear.dynamic_stiffness(p)
    Qc = h.to_complex(Q)
    fnl = np.zeros_like(Q)
    for c, g in zip(hb.contacts, hb.relative_displacements(sol.x)):
        f = c.elements.evaluate(g, h, jacobian=False).forces
        Bh = {o: np.asarray(c.kinematics[o]) for o in h.orders}
        fc = h.to_complex(f.reshape(-1, h.n_coeffs))
        fnl -= h.from_complex({o: Bh[o].conj().T @ fc[o] for o in h.orders}, (3,))
    lhs = h.from_complex({o: D[k] @ Qc[o] for k, o in enumerate(h.orders)}, (3,))
    rhs = h.real_vector(hb.F_ext).reshape(3, -1) + fnl
    assert np.max(np.abs(lhs - rhs)) <= 1e-8


@pytest.mark.parametrize("coupled", [False, True])
@pytest.mark.parametrize("parameter", ["frequency", "excitation", "mass", "preload"])
def test_residual_derivatives_match_central_differences(coupled, parameter):
    h = Harmonics.up_to(3, 128)
    hb = three_dof_cyclic_like(h, coupled)
    p = OperatingPoint(1.3, excitation=1.2, mass_multiplier=1.5, preload=1.1)
    rng = np.random.default_rng(5)
    x = hb.linear_guess(p) + 0.05 * rng.normal(size=hb.n_unknowns)
    R, J, dR = hb.residual(x, p, parameter)
    eps = 1e-7
    Jfd = fd_residual_jacobian(hb, x, p, eps)
    assert np.max(np.abs(J - Jfd)) <= 1e-6 * np.max(np.abs(J))
    v = p.get(parameter)
    dfd = (hb.residual(x, p.set(parameter, v + eps), jacobian=False)[0]
           - hb.residual(x, p.set(parameter, v - eps), jacobian=False)[0]) / (2 * eps)
    assert np.max(np.abs(dR - dfd)) <= 1e-6 * max(np.max(np.abs(dR)), 1e-3)


def free_response(w, k=1.0, m=1.0, c=0.02, P=0.1):
    return P / abs(k - m * w**2 + 1j * c * w)


@pytest.mark.parametrize("w", [0.7, 1.0, 1.6])
def test_limits_vanishing_friction_and_stuck_contact(w):
    # mu N -> 0: the free oscillator
    free = solve_point(jenkins_oscillator(H=3, n_samples=64, fs=0.0), OperatingPoint(w))
    assert free.converged and free.x[1] ** 2 + free.x[2] ** 2 == pytest.approx(
        free_response(w) ** 2, rel=1e-10)
    # friction limit far above the spring force: the tangential spring stays stuck
    stuck = solve_point(jenkins_oscillator(H=3, n_samples=64, fs=1e3), OperatingPoint(w))
    assert np.hypot(stuck.x[1], stuck.x[2]) == pytest.approx(
        free_response(w, k=4.0), rel=1e-10)
    # a gap that never closes (law B with N0 << 0): the free oscillator again
    gap = solve_point(normal_oscillator(n0=-1e3, H=3, ns=64), OperatingPoint(w))
    assert np.hypot(gap.x[1], gap.x[2]) == pytest.approx(free_response(w), rel=1e-10)


@pytest.mark.parametrize("ratio", [1e-3, 1e-1, 1e1, 1e2])
def test_contact_stiffness_extremes_converge(ratio):
    hb = jenkins_oscillator(H=5, n_samples=128, kt=ratio)
    r = sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(0.5))
    assert r.branch.complete, r.branch.message
    assert np.all(np.isfinite(r.branch.x))
    amp = r.amplitude([0])[:, 0]
    # bounded above by the free oscillator's peak (friction only removes energy)
    assert amp.max() <= free_response(1.0) * 1.001
    e = r.energy(int(np.argmax(amp)))
    assert e["excitation"] == pytest.approx(e["viscous"] + e["friction"], abs=1e-8)


# 1e4 between the others: slow (3.7 s of the fast suite)
@pytest.mark.parametrize("ratio", [1e3, pytest.param(1e4, marks=pytest.mark.slow), 1e6])
def test_stiff_contacts_converge_or_stop_with_a_remedy(ratio):
    """Where stick arcs shrink below the sample spacing the sampled Coulomb
    force is a staircase in the unknowns: converge, or stop saying why and what
    to change; never a NaN."""
    for ns in (128, 256):
        r = sweep(jenkins_oscillator(H=5, n_samples=ns, kt=ratio), "frequency", 0.5, 2.5,
                  OperatingPoint(0.5))
        assert np.all(np.isfinite(r.branch.x))
        if not r.branch.complete:
            assert "raise n_samples" in r.branch.message
            assert "frequency" in r.branch.message


def test_stiff_contact_resolved_by_more_samples():
    r = sweep(jenkins_oscillator(H=5, n_samples=1024, kt=1e3), "frequency", 0.5, 2.5,
              OperatingPoint(0.5))
    assert r.branch.complete, r.branch.message
    # the stuck-spring limit bounds the peak frequency from above: sqrt(k + kt)
    assert r.omega[np.argmax(r.amplitude([0])[:, 0])] < np.sqrt(1e3 + 1)


@pytest.mark.parametrize("P,state", [(1e-9, "stick"), (1e4, "gross slip")])
def test_excitation_extremes(P, state):
    w = 0.7
    hb = jenkins_oscillator(H=7, n_samples=256, P=P)
    sol = solve_point(hb, OperatingPoint(w))
    assert sol.converged
    amp = np.hypot(sol.x[1], sol.x[2])
    if state == "stick":  # all stuck: the linear system k + kt
        assert amp == pytest.approx(free_response(w, k=4.0, P=P), rel=1e-8)
    else:  # stick arc (~1e-3 rad) below one sample; friction negligible against the load
        assert amp == pytest.approx(free_response(w, P=P), rel=1e-4)
    assert hb.contact_response(sol.x, OperatingPoint(w))[0].state_names == [state]


@pytest.mark.parametrize("H,ns", [(1, 16), (3, 64), (15, 512), (31, 2048)])
def test_many_harmonics_converge(H, ns):
    hb = jenkins_oscillator(H=H, n_samples=ns)
    p = OperatingPoint(1.0)
    sol = solve_point(hb, p)
    assert sol.converged and np.all(np.isfinite(sol.x))
    e = hb.energy_balance(sol.x, p)
    assert e["excitation"] == pytest.approx(e["viscous"] + e["friction"], abs=1e-8)


def test_harmonic_truncation_converges_to_the_dti_peak():
    """More harmonics -> peak amplitude converges (odd harmonics only matter)."""
    peaks = []
    for H in (1, 3, 7):
        r = sweep(jenkins_oscillator(H=H, n_samples=256), "frequency", 0.9, 1.1,
                  OperatingPoint(0.9))
        peaks.append(r.peak(0)[1])
    assert abs(peaks[2] - peaks[1]) < abs(peaks[1] - peaks[0])


def test_bad_input_is_rejected_before_work():
    h = Harmonics.up_to(1)
    with pytest.raises(ValueError, match="'M' is 2x2, expected 1x1"):
        LinearDynamics.create([[1.0]], np.eye(2), harmonics=h)
    with pytest.raises(ValueError, match="'M' is not symmetric"):
        LinearDynamics.create(np.eye(2), [[1.0, 0.5], [0.0, 1.0]], harmonics=h)
    with pytest.raises(ValueError, match="no matrix for harmonic orders"):
        LinearDynamics.create({0: [[1.0]]}, [[1.0]], harmonics=h)
    hb = jenkins_oscillator(H=1, n_samples=16)
    with pytest.raises(ValueError, match="zero length"):
        sweep(hb, "frequency", 1.0, 1.0, OperatingPoint(1.0))
    with pytest.raises(ValueError, match="'parameter' = 'speed'"):
        sweep(hb, "speed", 1.0, 2.0, OperatingPoint(1.0))
    with pytest.raises(ValueError, match="frequency range must be > 0"):
        sweep(hb, "frequency", -1.0, 2.0, OperatingPoint(1.0))
    with pytest.raises(ValueError, match="'min_step'"):
        Settings(min_step=1.0, max_step=0.1)
    el = hb.contacts[0].elements
    with pytest.raises(ValueError, match=r"kinematics \(order 0\) has shape"):
        HarmonicBalance(hb.linear, [Contact("w", el, np.ones((2, 1)))],
                        Excitation.single(1, 0, 1.0), h)
    with pytest.raises(ValueError, match="excitation of order 1 has shape"):
        HarmonicBalance(hb.linear, hb.contacts, Excitation({1: np.ones(3)}), h)


def test_orders_with_dofs_of_their_own():
    """Reduced cyclic bodies keep a different number of modal DOFs per nodal diameter: the
    balance needs only the DOFs shared by every order. The model of three_dof_cyclic_like
    with its third DOF (no contact touches it; it carries the loads) made each order's own,
    in another scale per order and padded at orders 1 and 3 by decoupled DOFs, is the same
    physics: the same solution, and every order's equations hold at every DOF."""
    h = Harmonics.up_to(3, 128)
    ref = three_dof_cyclic_like(h)
    lin = ref.linear
    K, M, C, Mp, F = {}, {}, {}, {}, {}
    for k, o in enumerate(h.orders):
        extra = 2 if o in (1, 3) else 0
        T = np.eye(3 + extra, dtype=complex)
        T[2, 2] = 1.5 + o  # q_2 = (1.5 + o) y: another coordinate per order

        def lift(A, pad, T=T, extra=extra):
            out = np.zeros((3 + extra, 3 + extra), dtype=complex)
            out[:3, :3] = A
            out[3:, 3:] = pad * np.eye(extra)
            return T.conj().T @ out @ T

        K[o], M[o], C[o] = lift(lin.K[k], 5.0), lift(lin.M[k], 1.0), lift(lin.C[k], 0.1)
        Mp[o] = lift(lin.M_part[k], 0.0)
        f = np.zeros(3 + extra, dtype=complex)
        f[:3] = ref.excitation.forces.get(o, np.zeros(3))
        F[o] = T.conj().T @ f
    own = HarmonicBalance(
        LinearDynamics.create(K, M, C, harmonics=h, mass_part=Mp, n_shared=2),
        [Contact(c.name, c.elements, {o: np.asarray(c.kinematics[o])[:, :2]
                                      for o in h.orders}) for c in ref.contacts],
        Excitation(F), h)
    assert own.linear.sizes == (3, 5, 3, 5) and own.linear.n_dof == 2
    p = OperatingPoint(1.3, mass_multiplier=1.4)
    a, b = solve_point(ref, p), solve_point(own, p)
    assert a.converged and b.converged
    # same unknowns, same equations: agreement to the Newton tolerance (1e-9 of the forces)
    np.testing.assert_allclose(b.x, a.x, atol=1e-8 * np.abs(a.x).max())
    # every order's own DOFs satisfy that order's equations (Firrone & Zucca eq. 9)
    D = own.linear.dynamic_stiffness(p)
    Fo, _ = own.forces(p)
    X = own.recover_orders(b.x, p)
    fc = [h.to_complex(r.forces.reshape(-1, h.n_coeffs)) for r in own.contact_response(b.x, p)]
    for k, o in enumerate(h.orders):
        fnl = np.zeros(X[k].size, dtype=complex)
        for c, f in zip(own.contacts, fc):
            fnl[:2] -= np.asarray(c.kinematics[o])[:, :2].conj().T @ f[o]
        r = D[k] @ X[k] - Fo[k] - fnl
        assert np.abs(r).max() < 1e-8 * np.abs(Fo[k]).max(initial=1.0)
    # the energy balance counts the damping of the orders' own DOFs; what is left is the
    # Newton residual (1e-9 of the forces) times the motion, far below 1e-6
    e = own.energy_balance(b.x, p)
    assert e["excitation"] == pytest.approx(e["viscous"] + e["friction"] + e["normal"],
                                            rel=1e-6)
    assert e["viscous"] > 0.01 * e["excitation"]  # the damping is not negligible here
