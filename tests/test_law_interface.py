"""A contact law is an entry of one registry (laws.registry.LAWS) that the case reader and
the harmonic balance find it in: a law written outside the friction kernel, a linear spring
between DOFs, runs a case end to end and gives the closed-form linear response."""

import copy
from dataclasses import dataclass

import numpy as np
import pytest
from case_helpers import TWO_DOF

from microslip import case as cases
from microslip.laws.coulomb import ContactResponse
from microslip.laws.registry import LAWS
from microslip.solve.continuation import Settings
from microslip.solve.linear import OperatingPoint
from microslip.solve.response import solve_point, sweep


@dataclass(frozen=True)
class Springs:
    """P linear springs f = k g on one relative motion: the Jacobian k I, exact."""

    k: np.ndarray

    @property
    def size(self) -> int:
        return self.k.size

    n_components = 1

    def evaluate(self, g, harmonics, *, jacobian=True, histories=False, corrections=True):
        P, nc = self.size, harmonics.n_coeffs
        eye = np.eye(nc)[None, None, :, None, :] * self.k[:, None, None, None, None]
        zeros = np.zeros(P)
        return ContactResponse(self.k[:, None, None] * g, eye if jacobian else None,
                               np.zeros_like(g) if jacobian else None,
                               np.zeros(P, dtype=int), zeros, zeros, zeros,
                               np.ones(P, dtype=int), zeros)

    def stuck_stiffness(self):
        return self.k[:, None]

    def with_preload(self, multiplier):
        return self

    def preload_derivative(self, response):
        return np.zeros_like(response.forces)

    def force_scale(self):
        return 0.0


@dataclass(frozen=True)
class SpringLaw:
    name: str = "spring"
    motions: tuple[str, ...] = ("u",)
    parameters: tuple[str, ...] = ("k",)

    def elements(self, table, n_points=1):
        return Springs(np.full(n_points, float(table["k"])))


K_SPRING = 0.7
SPRING_CASE = copy.deepcopy(TWO_DOF) | {"contacts": [
    {"name": "s", "law": "spring", "k": K_SPRING, "u": {"x": 1.0, "y": -1.0}}]}


@pytest.fixture
def spring_law(monkeypatch):
    monkeypatch.setitem(LAWS, "spring", SpringLaw())


def test_the_case_reader_checks_a_registered_laws_keys(spring_law):
    cases.check(copy.deepcopy(SPRING_CASE))
    bad = copy.deepcopy(SPRING_CASE)
    del bad["contacts"][0]["k"]
    bad["contacts"][0]["kt"] = 1.0
    with pytest.raises(cases.CaseError) as err:
        cases.check(bad)
    assert set(err.value.faults) == {
        "contacts.s.kt: unknown key; did you mean 'k'? allowed: ['enabled', 'k', 'law', "
        "'name', 'u']",
        "contacts.s.k = None: expected a number"}


def test_a_registered_law_gives_the_closed_form_linear_response(spring_law):
    case = cases.Case(copy.deepcopy(SPRING_CASE), "spring.toml")
    hb = cases.lumped_model(case)
    r = sweep(hb, "frequency", 0.5, 2.0, OperatingPoint(0.5), settings=Settings(max_step=0.05))
    assert r.branch.complete and len(r) > 10
    model = SPRING_CASE["model"]
    M, C = np.diag(model["mass"]), np.diag(model["damping"])
    b = np.array([1.0, -1.0])
    K = np.array(model["stiffness"]) + K_SPRING * np.outer(b, b)
    F = np.array([0.1, 0.0])
    for i in range(0, len(r), 5):
        w = r.omega[i]
        X = np.linalg.solve(K - w**2 * M + 1j * w * C, F)  # F cos(w t): x = Re(X e^(i w t))
        coef = r.coefficients([0, 1])[i]
        h = hb.harmonics
        got = coef[:, h.cos_index[0]] - 1j * coef[:, h.sin_index[0]]
        # a linear balance solved by Newton to the continuation's tolerance (1e-10 relative)
        np.testing.assert_allclose(got, X, rtol=1e-8, atol=1e-12)
        assert np.abs(coef[:, h.cos_index[1:]]).max() < 1e-12  # no higher harmonic


def test_the_jacobian_of_a_registered_law_is_the_balances(spring_law):
    # Newton converges in one step on a linear balance only when the law's Jacobian is
    # the one the balance assembles (exact): from zero, one iteration
    hb = cases.lumped_model(cases.Case(copy.deepcopy(SPRING_CASE), "spring.toml"))
    sol = solve_point(hb, OperatingPoint(1.1), settings=Settings(tol=1e-10))
    assert sol.converged and sol.iterations <= 2
