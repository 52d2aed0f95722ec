"""The modal route to the condensation on the contact DOFs (solve.modal_condensation)
against the Schur complement of solve.condensation, the independent route: the same S_n,
loads, derivatives and recovered DOFs."""

import numpy as np
import pytest

from microslip.fe.fem import modal_damping
from microslip.fourier import Harmonics
from microslip.solve import modal_condensation as modal
from microslip.solve.condensation import Reordered, condense
from microslip.solve.linear import LinearDynamics, OperatingPoint

# Both routes are exact; they differ by rounding, amplified by the receptance's condition
# (~1e3 here): 1e-10 leaves two orders of margin over the measured 1e-14.
TOL = 1e-10


def _spd(rng, n: int, rigid: int = 0, scale: float = 1.0) -> np.ndarray:
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    lam = np.r_[np.zeros(rigid), rng.uniform(1.0, 10.0, n - rigid)]
    return scale * (Q * lam) @ Q.T


def _two_bodies(rng, hermitian: bool = False):
    """A body with modal damping (40 DOFs) and a free-free one with Rayleigh damping (12,
    two rigid modes), coupled by nothing: contact DOFs on both, the free one's all."""
    nA, nB = 40, 12
    KA, MA = _spd(rng, nA, scale=1e6), _spd(rng, nA) + 2.0 * np.eye(nA)
    if hermitian:  # a cyclic sector's complex Hermitian matrices
        A = 1e4 * (rng.standard_normal((nA, nA)) + 1j * rng.standard_normal((nA, nA)))
        KA = KA + A @ A.conj().T
    KB, MB = _spd(rng, nB, rigid=2, scale=1e5), _spd(rng, nB) + np.eye(nB)
    CA, CB = modal_damping(KA, MA, [0.01]), 3.0 * MB + 1e-5 * KB
    n = nA + nB
    K, M, C = (np.zeros((n, n), dtype=complex) for _ in range(3))
    for sl, k, m, c in ((slice(0, nA), KA, MA, CA), (slice(nA, n), KB, MB, CB)):
        K[sl, sl], M[sl, sl], C[sl, sl] = k, m, c
    dofs = np.r_[3, 7, 11, 20, nA + np.arange(nB)]
    return K, M, C, dofs, np.setdiff1d(np.arange(n), dofs)


def _routes(rng, parameter, hermitian=False, C_of=None, way="modal"):
    """(Schur complement, the modal or component route) of :func:`_two_bodies` (its damping
    replaced by ``C_of(C)``) at 700 rad/s, with random loads (and their derivatives)."""
    from microslip.solve.component_condensation import ComponentForm

    K, M, C, dofs, others = _two_bodies(rng, hermitian)
    C = C if C_of is None else C_of(C)
    orders = (1, 2, 3) if hermitian else (0, 1, 3)  # (order 0 is real: ND 0)
    h = Harmonics(orders, 16)
    lin = Reordered.of(LinearDynamics.create(K, M, C, harmonics=h, n_shared=K.shape[0]),
                       dofs, others)
    point = OperatingPoint(700.0)
    n = K.shape[0]
    F = [rng.standard_normal(n) + 1j * rng.standard_normal(n) for _ in orders]
    dF = None if parameter is None else [rng.standard_normal(n) + 0j for _ in orders]
    dD = lin.linear.d_dynamic_stiffness(point, parameter) if parameter else None
    schur = condense(lin.linear.dynamic_stiffness(point), lin.take(F), dofs.size, dD,
                     None if dF is None else lin.take(dF))
    masses = lin.linear.mass(point)
    form = modal.ModalForm.of(lin.linear, dofs.size, masses, always=True) if way == "modal" \
        else ComponentForm.of(lin.linear, dofs.size, masses)
    return schur, form.condensed(point.omega, lin.take(F),
                                 None if dF is None else lin.take(dF), parameter)


def _err(a, b) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


@pytest.mark.parametrize("parameter", [None, "frequency", "excitation"])
@pytest.mark.parametrize("hermitian", [False, True])
def test_modal_route_is_the_schur_complement(parameter, hermitian):
    rng = np.random.default_rng(1)
    schur, route = _routes(rng, parameter, hermitian)
    assert _err(route.S, schur.S) < TOL
    _agree(route, schur, parameter, rng)


def _agree(route, schur, parameter, rng) -> None:
    """The route's loads, products, recovered DOFs and derivatives are the Schur
    complement's (TOL)."""
    nc = schur.n_contact
    X = rng.standard_normal((3, nc, 2)) + 1j * rng.standard_normal((3, nc, 2))
    assert _err(route.F, schur.F) < TOL
    assert _err(route.S_product(X), schur.S_product(X)) < TOL
    for k in range(3):
        assert _err(route.recover(k, X[k, :, 0]), schur.recover(k, X[k, :, 0])) < TOL
    if parameter is not None:
        assert _err(route.dF, schur.dF) < TOL
    if parameter == "frequency":
        assert _err(route.dS_product(X), schur.dS_product(X)) < TOL


def test_frequency_derivative_against_differences():
    """dS/dw and dF_e/dw of the modal route against central differences of its own S and
    F_e: h = 3e-6 w, truncation (h / distance to the nearest resonance)^2 ~1e-7 (1e-4 measured
    at 1e-4 w, a resonance 1 % away), rounding 1e-15 / 3e-6 ~ 1e-9."""
    rng = np.random.default_rng(2)
    K, M, C, dofs, others = _two_bodies(rng)
    h = Harmonics((0, 1, 2), 16)
    lin = Reordered.of(LinearDynamics.create(K, M, C, harmonics=h, n_shared=K.shape[0]),
                       dofs, others)
    n = K.shape[0]
    F = lin.take([rng.standard_normal(n) + 1j * rng.standard_normal(n) for _ in range(3)])
    zero = [np.zeros(n, dtype=complex)] * 3
    form = modal.ModalForm.of(lin.linear, dofs.size, lin.linear.M, always=True)
    w, dw = 650.0, 0.002
    at = form.condensed(w, F, zero, "frequency")
    up, down = (form.condensed(w + s, F, None, None) for s in (dw, -dw))
    X = rng.standard_normal((3, dofs.size)) + 0j
    fd = (up.S_product(X) - down.S_product(X)) / (2 * dw)
    assert _err(at.dS_product(X), fd) < 1e-6
    assert _err(at.dF[1:], (up.F - down.F)[1:] / (2 * dw)) < 1e-6


def test_the_route_is_refused_where_it_does_not_hold_or_pay():
    rng = np.random.default_rng(3)
    K, M, C, dofs, others = _two_bodies(rng)
    h = Harmonics((0, 1), 16)

    def form(C, always):
        lin = Reordered.of(LinearDynamics.create(K, M, C, harmonics=h, n_shared=K.shape[0]),
                           dofs, others).linear
        return modal.ModalForm.of(lin, dofs.size, lin.M, always=always)

    assert form(C, True) is not None
    # damping not diagonal in the modes (a dashpot between two DOFs of the modal body)
    dashpot = C.copy()
    dashpot[np.ix_([0, 1], [0, 1])] += 50.0 * np.array([[1, -1], [-1, 1]])
    assert form(dashpot, True) is None
    # undamped: the receptance is infinite at each elastic mode's frequency
    assert form(np.zeros_like(C), True) is None
    # 52 DOFs: an iterate of either route costs microseconds, the Schur one stays
    assert form(C, False) is None


def _dashpot(C):
    """A dashpot between two DOFs of the modal body: damping no mode diagonalizes (the
    modal route refuses it; this one does not need it)."""
    C = C.copy()
    C[np.ix_([0, 1], [0, 1])] += 50.0 * np.array([[1, -1], [-1, 1]])
    return C


@pytest.mark.parametrize("formed_up_to", [0, 64])  # the 40-DOF body factored, or formed
@pytest.mark.parametrize("parameter", [None, "frequency", "excitation"])
@pytest.mark.parametrize("hermitian", [False, True])
@pytest.mark.parametrize("damping", ["modal", "dashpot", "none"])
def test_component_route_is_the_schur_complement(formed_up_to, parameter, hermitian,
                                                 damping, monkeypatch):
    # the same products as the modal route's test; rounding alone separates the routes
    # (no receptance: its condition does not enter), TOL as there
    from microslip.solve import component_condensation as component

    monkeypatch.setattr(component, "FORMED_UP_TO", formed_up_to)
    rng = np.random.default_rng(1)
    C_of = {"modal": None, "dashpot": _dashpot, "none": np.zeros_like}[damping]
    schur, route = _routes(rng, parameter, hermitian, C_of, "component")
    _agree(route, schur, parameter, rng)
    dynamic = [b for b in route.form.blocks if b is not None]
    assert all(b is dynamic[0] for b in dynamic)  # one matrix set: its blocks held once
    assert "S" not in route.__dict__  # the products above went without the matrix
    assert _err(route.S, schur.S) < TOL


def test_a_large_components_S_is_made_after_many_products(monkeypatch):
    # lazy products up to FORM_AFTER at a point, then S_b made once and used: the same
    # products either way (to rounding, TOL)
    from microslip.solve import component_condensation as component

    monkeypatch.setattr(component, "FORMED_UP_TO", 0)
    monkeypatch.setattr(component, "FORM_AFTER", 3)
    rng = np.random.default_rng(4)
    schur, route = _routes(rng, "frequency", False, way="component")
    X = rng.standard_normal((3, schur.n_contact, 1)) + 0j
    made = []
    for _ in range(5):
        assert _err(route.S_product(X), schur.S_product(X)) < TOL
        made.append(all(a.S is not None for at in route._at if at for a in at))
    assert made == [False, False, False, True, True]
    assert _err(route.dS_product(X), schur.dS_product(X)) < TOL
