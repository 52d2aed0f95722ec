"""Nonlinear modes (extended periodic motion concept) and the forced response synthesized
from them, against closed forms, finite differences, energy balances and direct FRFs."""

import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.linalg as sla

from microslip import case as cases
from microslip.app.run import run_case
from microslip.bench.demos import jenkins_oscillator
from microslip.draw import backbones
from microslip.fourier import Harmonics
from microslip.laws.coulomb import ContactElements
from microslip.solve.hbm import Contact, HarmonicBalance
from microslip.solve.linear import Excitation, LinearDynamics, OperatingPoint
from microslip.solve.modal_synthesis import peak, synthesis
from microslip.solve.nonlinear_modes import ModalBalance, backbone
from microslip.solve.response import sweep

# the Jenkins oscillator of microslip.bench.demos: m x'' + k x + T = 0, slip force fs
M_, K_, KT, FS = 1.0, 1.0, 3.0, 0.05


def describing_function(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequency and xi = 2 zeta w of the Jenkins oscillator at displacement
    amplitude A by the describing function (first harmonic): stuck below A_s = fs / kt;
    above, k_eq = kt / pi (b - sin(2 b) / 2) with cos b = 1 - 2 A_s / A, and the
    dissipation 4 fs (A - A_s) per cycle balanced by the self-excitation's pi w xi m A^2."""
    As = FS / KT
    b = np.arccos(np.clip(1.0 - 2.0 * As / A, -1.0, 1.0))
    keq = np.where(A > As, KT / np.pi * (b - 0.5 * np.sin(2.0 * b)), KT)
    w = np.sqrt((K_ + keq) / M_)
    return w, np.where(A > As, 4.0 * FS * (A - As), 0.0) / (np.pi * w * M_ * A**2)


def test_jenkins_backbone_is_the_describing_function():
    """With the fundamental alone the mode is the describing function's, exactly but for
    the sampled friction force (O(h^3) with the sub-sample corrections, measured 6.3e-9 in
    w and 2.4e-7 in xi at 1024 samples, 4.2e-7 / 1.4e-5 at 256); stuck below A_s."""
    hb = jenkins_oscillator(1, 1024, c=0.0)
    modal = ModalBalance(hb, OperatingPoint(1.0))
    start = modal.linear_modes(1)[0]
    assert start.omega == pytest.approx(2.0, rel=1e-12)  # sqrt((k + kt) / m)
    mode = backbone(modal, start, (1e-3, 12.0))
    assert mode.status == "complete"
    levels = np.geomspace(0.02, 10.0, 9)  # above A_s = 0.0167: partial to gross slip
    got = np.array([mode.at(a)[1:] for a in levels])
    w, xi = describing_function(levels / np.sqrt(M_))
    np.testing.assert_allclose(got[:, 0], w, rtol=1e-7)
    np.testing.assert_allclose(got[:, 1], xi, rtol=1e-6)
    stuck = mode.amplitude < 0.9 * FS / KT
    np.testing.assert_allclose(mode.omega[stuck], 2.0, rtol=1e-12)
    np.testing.assert_allclose(mode.xi[stuck], 0.0, atol=1e-12)
    assert mode.omega[-1] == pytest.approx(1.0, rel=1e-3)  # gross slip: the free mode


def _two_dimensional_model(proportional: bool = False, jacobian: str = "auto"
                           ) -> HarmonicBalance:
    """Three masses, viscous damping, one 2D friction contact with a variable normal load
    (law D) on DOFs 0 and 2; DOF 1 touches no contact (condensed). ``proportional``: the
    damping proportional to M and to K with the contact stuck (real linear modes)."""
    h = Harmonics.up_to(3, 128)
    K = np.array([[3.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.5]])
    M = np.diag([1.0, 2.0, 0.5])
    contact = ContactElements.create("D", kt=2.0, kn=5.0, mu=0.3, n0=0.2, n_points=1)
    B = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.3], [0.0, 0.0, 1.0]])  # u1, u2, v
    stuck = B.T @ np.diag([2.0, 2.0, 5.0]) @ B  # kt, kt, kn
    C = 0.01 * (K + stuck if proportional else K) + 0.02 * M
    lin = LinearDynamics.create(K, M, C, harmonics=h)
    return HarmonicBalance(lin, [Contact("c", contact, B)], Excitation.single(3, 1, 0.1), h,
                           jacobian=jacobian)


@pytest.fixture(scope="module")
def mode_2d():
    hb = _two_dimensional_model()
    modal = ModalBalance(hb, OperatingPoint(1.0))
    return modal, backbone(modal, modal.linear_modes(1)[0], (1e-3, 2.0))


def test_structured_solves_give_the_dense_backbone():
    """Every Newton step of the backbone by GMRES on the bordered structured Jacobian or by
    a dense LU: the same levels (both converge to tol = 1e-9 of the force scale; the levels
    agree to what that leaves, 1e-7 relative)."""
    out = {}
    for structured in (False, True):
        hb = _two_dimensional_model(jacobian="structured" if structured else "dense")
        modal = ModalBalance(hb, OperatingPoint(1.0))
        out[structured] = backbone(modal, modal.linear_modes(1)[0], (1e-3, 2.0))
        assert out[structured].branch.complete
    a, b = out[False], out[True]
    assert hb.preconditioner.solves > 0  # the GMRES path did run
    # the arclength steps follow the iteration counts: the same counts, the same levels
    assert list(a.branch.iterations) == list(b.branch.iterations)
    np.testing.assert_allclose(b.amplitude, a.amplitude, rtol=1e-7)
    np.testing.assert_allclose(b.omega, a.omega, rtol=1e-7)
    np.testing.assert_allclose(b.xi, a.xi, rtol=1e-7, atol=1e-9 * a.omega[0])


def test_the_linear_limit_is_the_stuck_mode_of_the_whole_model():
    """At small amplitude the mode is the linear one of every DOF (the condensed one
    included) with the contact's stick stiffness: an independent eigen-solve of the 3 x 3
    system; with damping proportional to it, xi = 2 zeta w = 0.01 w^2 + 0.02 exactly."""
    hb = _two_dimensional_model(proportional=True)
    modal = ModalBalance(hb, OperatingPoint(1.0))
    mode = backbone(modal, modal.linear_modes(1)[0], (1e-4, 1e-3))
    K = hb.linear.K[1].real + hb.stick_stiffness(1).real
    lam = sla.eigh(K, hb.linear.M[1].real, eigvals_only=True)
    assert mode.status == "complete"
    np.testing.assert_allclose(mode.omega, np.sqrt(lam[0]), rtol=1e-10)
    np.testing.assert_allclose(mode.xi, 0.01 * lam[0] + 0.02, rtol=1e-9)


def test_friction_damps_the_mode_as_it_slips(mode_2d):
    modal, mode = mode_2d
    assert mode.status == "complete"
    assert mode.damping_ratio.max() > 1.5 * mode.damping_ratio[0]
    assert mode.omega[-1] < 0.95 * mode.omega[0]  # softening as the contact slips


def test_every_level_balances_its_energy(mode_2d):
    """Over a cycle the self-excitation's input equals what the viscous damping and the
    contact take (friction and normal work), to the Newton tolerance (1e-9 of the rows:
    measured 4e-10 relative)."""
    modal, mode = mode_2d
    for x, w, xi in zip(mode.x, mode.omega, mode.xi):
        e = modal.energies(x, w, xi)
        taken = e["viscous"] + e["friction"] + e["normal"]
        assert e["modal"] == pytest.approx(taken, rel=1e-8, abs=1e-14)


def test_mass_normalization_over_every_dof(mode_2d):
    """The fundamental of the whole motion (the condensed DOF recovered independently,
    by solving its own row) has X_1^H M_1 X_1 = a^2."""
    modal, mode = mode_2d
    hb, h = modal.model, modal.model.harmonics
    lin = hb.linear
    for x, w, xi, a in zip(mode.x[::4], mode.omega[::4], mode.xi[::4], mode.amplitude[::4]):
        X = h.to_complex(x.reshape(hb.dofs.size, h.n_coeffs))[1]
        D = lin.K[1] - w**2 * lin.M[1] + 1j * w * (lin.C[1] - xi * lin.M[1])
        full = np.zeros(3, dtype=complex)
        full[hb.dofs] = X
        full[1] = -(D[1, hb.dofs] @ X) / D[1, 1]  # no load on the condensed DOF
        assert np.real(np.vdot(full, lin.M[1] @ full)) == pytest.approx(a**2, rel=1e-9)


def test_the_jacobian_is_exact(mode_2d):
    """dR/dy and dR/dlog10(a) against central differences (step 1e-7: truncation 1e-14,
    round-off 1e-9 of the entries), away from the solution."""
    modal, mode = mode_2d
    fun = mode.solver.fun
    rng = np.random.default_rng(1)
    for i in (len(mode.amplitude) // 3, 2 * len(mode.amplitude) // 3):
        y = mode.solver.scaled(mode.x[i], mode.omega[i], mode.xi[i], mode.amplitude[i])
        y = y + 1e-3 * rng.standard_normal(y.size)
        lam = float(np.log10(mode.amplitude[i]))
        _, J, R_lam = fun(y, lam, True)
        eps = 1e-7
        fd = np.array([(fun(y + eps * e, lam, False)[0] - fun(y - eps * e, lam, False)[0])
                       / (2 * eps) for e in np.eye(y.size)]).T
        fd_lam = (fun(y, lam + eps, False)[0] - fun(y, lam - eps, False)[0]) / (2 * eps)
        np.testing.assert_allclose(J, fd, atol=1e-7 * np.abs(J).max())
        np.testing.assert_allclose(R_lam, fd_lam, atol=1e-7 * np.abs(J).max())


def test_synthesized_peaks_equal_direct_frf_peaks_where_the_mode_dominates():
    """The Jenkins oscillator of the demo (light viscous damping, 7 harmonics): the peak
    synthesized from one backbone against the refined peak of a full FRF per force. Where
    the damping ratio is small (gross slip, e >= 1) the synthesis holds to 8e-4 (e = 1,
    zeta 2.7 %), 6e-5 (2, 1.5 %) and 2e-5 (5, 1.2 %) measured; in the stick-slip transition
    (e = 0.5, zeta 24 %) it is 10 % off, as single-mode theory is."""
    hb = jenkins_oscillator(7, 256)
    modal = ModalBalance(hb, OperatingPoint(1.0))
    mode = backbone(modal, modal.linear_modes(1)[0], (1e-3, 50.0))
    syn = synthesis(modal, mode)
    h = hb.harmonics
    for e, rtol in ((1.0, 2e-3), (2.0, 2e-4), (5.0, 1e-4)):
        p = peak(modal, mode, syn, e)
        frf = sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(1.0, excitation=e))
        w_peak, a_peak = frf.peak(0)
        assert h.peak(p.x.reshape(1, -1))[0] == pytest.approx(a_peak, rel=rtol)
        assert p.frequency == pytest.approx(w_peak, rel=10 * rtol)
    p = peak(modal, mode, syn, 0.5)
    frf = sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(1.0, excitation=0.5))
    assert abs(h.peak(p.x.reshape(1, -1))[0] / frf.peak(0)[1] - 1.0) > 0.05


CASE = Path(__file__).resolve().parents[1] / "cases" / "08_sdof_nonlinear_modes.toml"


@pytest.fixture(scope="module")
def modes_case(tmp_path_factory):
    out = tmp_path_factory.mktemp("modes")
    return h5py.File(run_case(cases.load(CASE), out, progress=lambda m: None), "r"), out


@pytest.mark.slow  # the shipped case end to end (the type's own run: test_render)
def test_the_modes_case_runs_and_its_peaks_are_the_direct_frfs(modes_case):
    """The shipped case end to end: the stuck linear limit (2 rad/s, zeta = c / (2 m w) =
    0.5 %), and the peaks synthesized at 0.1 and 0.2 N against the FRFs computed in the
    same run (the direct peaks as the continuation sampled them, a little below the true
    ones: 1.0e-3 apart at 0.1 N, where the synthesis itself is 8e-4 off, see above)."""
    f, out = modes_case
    assert f.attrs["status"] == "complete"
    mode = f["mode/curve_000"]
    assert mode["omega"][0] == pytest.approx(2.0, rel=1e-10)
    assert mode["damping_ratio"][0] == pytest.approx(0.02 / 4.0, rel=1e-9)
    peaks = dict(zip(mode["excitations"][()], mode["peak_response"][:, 0]))
    for k, e in ((1, 1.0), (2, 2.0)):
        direct = f[f"frf_force/curve_00{k}/amplitude"][:, 0].max()
        assert peaks[e] == pytest.approx(direct, rel=2e-3)
    for name in ("frequency", "damping", "peaks", "frf"):
        assert (out / f"mode_{name}.png").is_file()


@pytest.mark.slow  # as above
def test_a_larger_slip_force_moves_the_damping_to_larger_levels(modes_case):
    """Over the N0 family the level of the largest damping ratio grows with N0 (slip
    starts at kt A = mu N0) while its height stays (the Jenkins optimum is ~25 %, set by
    kt / k alone)."""
    f, _ = modes_case
    members = [f[f"modes_N0/curve_00{k}"] for k in range(3)]
    where = [m["response"][np.argmax(m["damping_ratio"][()]), 0] for m in members]
    assert np.all(np.diff(where) > 0)
    peaks = [m["peak_response"][0, 0] for m in members]  # at 0.2 N: more N0, less slip
    assert np.all(np.diff(peaks) < 0)
    heights = [m["damping_ratio"][()].max() for m in members]
    assert max(heights) / min(heights) < 1.05
    # the optimization from modes drawn: each member's synthesized peak at its N0
    (curve,) = backbones._design_curves(members)
    np.testing.assert_array_equal(curve["x"], [m.attrs["family_value"] for m in members])
    np.testing.assert_array_equal(curve["y"], peaks)
    assert (modes_case[1] / "modes_N0_optimization.png").is_file()


@pytest.mark.parametrize("key, value, expected", [
    ("amplitude", [1.0, 0.1], "analysis.mode.amplitude = [1.0, 0.1]: expected [low, high] m"),
    ("start", "open", "analysis.mode.start = 'open': expected 'stuck'"),
    ("mode", 0, "analysis.mode.mode"),
    ("excitations", [1.0, -2.0], "analysis.mode.excitations = [1.0, -2.0]: expected a list"),
    ("output", "y", "analysis.mode.output = 'y': unknown"),
    ("figure", 5, "analysis.mode.figure = 5: expected text"),
])
def test_bad_keys_are_named_before_any_work(key, value, expected):
    data = tomllib.loads(CASE.read_text())
    data["analysis"][0][key] = value
    with pytest.raises(cases.CaseError) as err:
        cases.check(data)
    assert expected in str(err.value)


def test_a_mode_beyond_the_model_fails_saying_so(tmp_path):
    """The single DOF has one elastic mode: asking for the second is a failed curve whose
    message says how many there are, not a traceback."""
    data = tomllib.loads(CASE.read_text())
    data["analysis"] = [data["analysis"][0] | {"mode": 2}]
    path = run_case(cases.Case(data, "m.toml"), tmp_path, progress=lambda m: None)
    with h5py.File(path) as f:
        assert f["mode"].attrs["status"] == "failed"
        assert "has 1 elastic modes" in f["mode"].attrs["message"]


def test_a_synthesized_peak_where_single_mode_theory_fails_is_told(tmp_path):
    """At 0.05 N the oscillator's peak is in the stick-slip transition (damping ratio 24 %):
    the direct solve at the synthesized peak's frequency is far from it and the run says
    so in one line; at 0.1 N (gross slip) the two agree to the check's 1.2e-3 and nothing
    is said."""
    data = tomllib.loads(CASE.read_text())
    data["analysis"] = [data["analysis"][0] | {"excitations": [0.5, 1.0]}]
    said = []
    path = run_case(cases.Case(data, "m.toml"), tmp_path, progress=said.append)
    warnings = [m for m in said if m.startswith("warning")]
    assert len(warnings) == 1 and "excitation x0.5" in warnings[0], warnings
    assert "single-mode synthesis does not hold there" in warnings[0]
    with h5py.File(path) as f:
        c = f["mode/curve_000"]
        syn, chk = c["peak_response"][:, 0], c["peak_check"][:, 0]
        assert abs(syn[0] / chk[0] - 1) > 0.1
        assert syn[1] == pytest.approx(chk[1], rel=2e-3)


def test_a_second_run_takes_the_backbone_from_the_cache(tmp_path):
    """The same analysis into the same folder again: the backbone is read back (its level
    count said), not recomputed, and the file holds the same numbers."""
    data = tomllib.loads(CASE.read_text())
    data["analysis"] = [data["analysis"][0]]
    said = []
    for _ in range(2):
        path = run_case(cases.Case(data, "m.toml"), tmp_path, progress=said.append)
        with h5py.File(path) as f:
            omega = f["mode/curve_000/omega"][()]
    again = [m for m in said if "from the cache" in m]
    assert len(again) == 1 and f"{len(omega)} levels, complete" in again[0], again
