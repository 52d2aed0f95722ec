"""The Fourier pair of the balance against closed forms."""

import numpy as np
import pytest

from microslip.fourier import Harmonics, default_samples


@pytest.mark.parametrize("orders,ns", [([0, 1, 2, 3], 16), ([1, 3, 5], 11), ([0], 1), ([7], 15)])
def test_analysis_inverts_synthesis(orders, ns):
    h = Harmonics(orders, ns)
    # exact left inverse for ns > 2 max(order): rounding only
    assert np.allclose(h.analysis @ h.synthesis, np.eye(h.n_coeffs), atol=1e-13)


def test_layout_follows_design_convention():
    h = Harmonics([0, 1, 3], 16)
    assert h.n_coeffs == 5
    assert h.coeff_order.tolist() == [0, 1, 1, 3, 3]
    # x = a0 + a1 cos + b1 sin + a3 cos 3 + b3 sin 3
    c = np.array([0.5, 1.0, -2.0, 0.25, 0.75])
    th = h.theta
    x = 0.5 + np.cos(th) - 2 * np.sin(th) + 0.25 * np.cos(3 * th) + 0.75 * np.sin(3 * th)
    assert np.allclose(h.synthesis @ c, x, atol=1e-14)
    # X_n = a_n - i b_n, so that x = Re(sum X_n exp(i n theta))
    X = h.to_complex(c)
    assert X[1] == pytest.approx(1.0 + 2.0j) and X[3] == pytest.approx(0.25 - 0.75j)
    xr = sum(np.real(X[n] * np.exp(1j * n * th)) for n in (0, 1, 3))
    assert np.allclose(xr, x, atol=1e-14)
    assert np.allclose(h.from_complex(X, ()), c)


def test_derivative_and_work_match_sampled_integrals():
    h = Harmonics.up_to(4, 64)
    rng = np.random.default_rng(1)
    f, x = rng.normal(size=(2, h.n_coeffs))
    # d/dtheta of the synthesis, by central differences (error ~ eps^2)
    eps = 1e-5
    dx = (h.synthesis_at(h.theta + eps) - h.synthesis_at(h.theta - eps)) @ x / (2 * eps)
    assert np.allclose(h.synthesis @ (h.derivative @ x), dx, atol=1e-8)
    # work: trapezoid on a fine grid of f(theta) x'(theta) is exact for trig polynomials
    fine = np.linspace(0, 2 * np.pi, 4001)[:-1]
    E = h.synthesis_at(fine)
    w = np.sum((E @ f) * (E @ (h.derivative @ x))) * (2 * np.pi / fine.size)
    assert h.work(f, x) == pytest.approx(w, rel=1e-12)


def test_real_operator_matches_complex_product():
    h = Harmonics([0, 1, 2], 8)
    rng = np.random.default_rng(2)
    n = 3
    S = rng.normal(size=(3, n, n)) + 1j * rng.normal(size=(3, n, n))
    S[0] = S[0].real
    c = rng.normal(size=(n, h.n_coeffs))
    X = h.to_complex(c)
    Y = {o: S[k] @ X[o] for k, o in enumerate(h.orders)}
    assert np.allclose(h.real_matrix(S) @ c.ravel(), h.from_complex(Y, (n,)).ravel())


def test_peak_of_a_pure_cosine():
    h = Harmonics([1, 3], 32)
    # |x| max of cos + 0 is 1; of cos(t) - cos(3t)/3 attained near t = pi/2... sampled check
    assert h.peak(np.array([1.0, 0.0, 0.0, 0.0])) == pytest.approx(1.0)


@pytest.mark.parametrize(
    "orders,ns,msg",
    [([], None, "empty"), ([-1, 1], None, ">= 0"), ([1.5], None, "integers"),
     ([0, 3], 6, "too few")],
)
def test_bad_input_names_the_argument(orders, ns, msg):
    with pytest.raises(ValueError, match=msg):
        Harmonics(orders, ns)


def test_default_samples_grow_with_order():
    assert default_samples(1) == 64 and default_samples(7) == 128 and default_samples(31) == 512
