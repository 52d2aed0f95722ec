"""Harmonic layout, time sampling and the discrete Fourier pair of the balance.

Convention (Firrone & Zucca eq. 2): ``x(t) = Re(sum_n X_n exp(i n w t))``.
Per DOF the real coefficients are laid out ``[a0, a1, b1, ..., aH, bH]`` with
``x = a0 + sum(a_n cos(n w t) + b_n sin(n w t))``, so that ``X_n = a_n - i b_n``.
Only the orders kept in :class:`Harmonics` appear (e.g. 0 and the odd ones).

Time is sampled uniformly over one period, ``theta_k = w t_k = 2 pi k / N``.
With ``N > 2 max(order)`` the analysis matrix is the exact left inverse of the
synthesis matrix (``A @ E == I``): the transform round-trips to rounding.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

#: Time samples per period of the highest harmonic: 16 resolve the stick-slip transitions
#: of the return map (the speed/accuracy table of ``microslip bench core``). Powers of two
#: nest (every sample of N is one of 2 N), so results converge as samples double.
SAMPLES_PER_ORDER = 16
#: The default's floor: 64 samples per period below H = 3.
LEAST_DEFAULT_SAMPLES = 64


def least_samples(max_order: int) -> int:
    """The fewest time samples per period allowed for harmonics up to ``max_order``: the
    smallest power of two >= SAMPLES_PER_ORDER (max_order + 1)."""
    return 1 << (SAMPLES_PER_ORDER * (max_order + 1) - 1).bit_length()


def default_samples(max_order: int) -> int:
    """Samples per period when a case gives none: :func:`least_samples`, never below
    LEAST_DEFAULT_SAMPLES (both powers of two)."""
    return max(LEAST_DEFAULT_SAMPLES, least_samples(max_order))


class Harmonics:
    """Harmonic orders kept in the balance and the time sampling of one period.

    Parameters
    ----------
    orders:
        Non-negative harmonic orders, e.g. ``range(0, 8)`` or ``[0, 1, 3, 5]``.
    n_samples:
        Time samples per period; must exceed ``2 * max(orders)``. Default from
        :func:`default_samples`.
    """

    def __init__(self, orders, n_samples: int | None = None):
        raw = np.atleast_1d(np.asarray(orders))
        if raw.size == 0:
            raise ValueError("harmonics: 'orders' is empty; give at least one order, e.g. [1]")
        if not np.all(np.equal(np.mod(raw, 1), 0)):
            raise ValueError(f"harmonics: 'orders' must be integers, got {raw.tolist()}")
        ords = sorted({int(o) for o in raw})
        if ords[0] < 0:
            raise ValueError(f"harmonics: 'orders' must be >= 0, got {ords}")
        if n_samples is None:
            n_samples = default_samples(ords[-1])
        if int(n_samples) != n_samples or n_samples <= 2 * ords[-1]:
            raise ValueError(
                f"harmonics: 'n_samples' = {n_samples} is too few for order {ords[-1]}; "
                f"need an integer > 2 * max(orders) = {2 * ords[-1]}"
            )
        self.orders: tuple[int, ...] = tuple(ords)
        self.n_samples: int = int(n_samples)
        self.dynamic_orders: tuple[int, ...] = tuple(o for o in ords if o > 0)

    @classmethod
    def up_to(cls, H: int, n_samples: int | None = None) -> Harmonics:
        """Orders ``0..H``."""
        if int(H) != H or H < 0:
            raise ValueError(f"harmonics: 'H' must be an integer >= 0, got {H}")
        return cls(range(int(H) + 1), n_samples)

    def __repr__(self) -> str:
        return f"Harmonics(orders={list(self.orders)}, n_samples={self.n_samples})"

    def __eq__(self, other) -> bool:
        return (
            isinstance(other, Harmonics)
            and self.orders == other.orders
            and self.n_samples == other.n_samples
        )

    def __hash__(self) -> int:
        return hash((self.orders, self.n_samples))

    # ------------------------------------------------------------------ layout
    @property
    def has_static(self) -> bool:
        return self.orders[0] == 0

    @property
    def n_coeffs(self) -> int:
        """Real coefficients per DOF: 1 for order 0, 2 for every other."""
        return int(self.has_static) + 2 * len(self.dynamic_orders)

    @cached_property
    def coeff_order(self) -> np.ndarray:
        """(n_coeffs,) int: the harmonic order of each coefficient."""
        out = [0] if self.has_static else []
        for o in self.dynamic_orders:
            out += [o, o]
        return np.array(out, dtype=np.int64)

    @cached_property
    def coeff_kind(self) -> np.ndarray:
        """(n_coeffs,) int8: 0 for a0, 1 for a cosine, 2 for a sine coefficient."""
        kind = np.zeros(self.n_coeffs, dtype=np.int8)
        kind[self.cos_index] = 1
        kind[self.sin_index] = 2
        return kind

    @cached_property
    def cos_index(self) -> np.ndarray:
        """(n_dyn,) int: position of a_n for each dynamic order."""
        return int(self.has_static) + 2 * np.arange(len(self.dynamic_orders))

    @cached_property
    def sin_index(self) -> np.ndarray:
        """(n_dyn,) int: position of b_n for each dynamic order."""
        return self.cos_index + 1

    @cached_property
    def static_mask(self) -> np.ndarray:
        """(n_coeffs,) bool: True at a0."""
        return self.coeff_order == 0

    # --------------------------------------------------------------- transforms
    @cached_property
    def theta(self) -> np.ndarray:
        """(n_samples,) phase ``w t`` of each sample, rad."""
        return 2.0 * np.pi * np.arange(self.n_samples) / self.n_samples

    @cached_property
    def synthesis(self) -> np.ndarray:
        """E, (n_samples, n_coeffs): time samples ``x_k = E @ c``."""
        return self.synthesis_at(self.theta)

    def synthesis_at(self, theta: np.ndarray) -> np.ndarray:
        """(len(theta), n_coeffs) synthesis matrix at arbitrary phases."""
        theta = np.asarray(theta, dtype=float)
        E = np.empty((theta.size, self.n_coeffs))
        if self.has_static:
            E[:, 0] = 1.0
        n = np.array(self.dynamic_orders, dtype=float)
        E[:, self.cos_index] = np.cos(np.outer(theta, n))
        E[:, self.sin_index] = np.sin(np.outer(theta, n))
        return E

    @cached_property
    def analysis(self) -> np.ndarray:
        """A, (n_coeffs, n_samples): Fourier coefficients ``c = A @ x``.

        Discrete projection (trapezoidal rule on the period), the exact left
        inverse of :attr:`synthesis` when ``n_samples > 2 max(order)``."""
        A = self.synthesis.T * (2.0 / self.n_samples)
        if self.has_static:
            A[0] *= 0.5
        return np.ascontiguousarray(A)

    @cached_property
    def derivative(self) -> np.ndarray:
        """(n_coeffs, n_coeffs) d/dtheta in coefficient space: ``c' = D @ c``.

        ``d/dtheta (a cos n theta + b sin n theta) = n b cos - n a sin``."""
        D = np.zeros((self.n_coeffs, self.n_coeffs))
        for o, ic, js in zip(self.dynamic_orders, self.cos_index, self.sin_index):
            D[ic, js] = o
            D[js, ic] = -o
        return D

    def time_shift(self, phase: float) -> np.ndarray:
        """(n_coeffs, n_coeffs) orthogonal Q: the coefficients of ``x(theta + phase)`` are
        ``Q @ c`` when ``c`` are those of ``x(theta)`` (phase in rad of the fundamental).

        ``a cos n(theta + p) + b sin n(theta + p)`` has cosine ``a cos np + b sin np`` and
        sine ``b cos np - a sin np``; its inverse is ``Q.T``."""
        Q = np.eye(self.n_coeffs)
        for o, ic, js in zip(self.dynamic_orders, self.cos_index, self.sin_index):
            c, s = np.cos(o * phase), np.sin(o * phase)
            Q[ic, ic], Q[ic, js], Q[js, ic], Q[js, js] = c, s, -s, c
        return Q

    def work(self, force: np.ndarray, displacement: np.ndarray) -> np.ndarray:
        """Work per period of a force on a displacement, from coefficients.

        ``oint f dx = pi * sum_n n (f_a x_b - f_b x_a)``; equal to the sampled
        sum ``sum_k f(theta_k) x'(theta_k) dtheta`` of the projected force.

        force, displacement: (..., n_coeffs). Returns (...) in J (N m)."""
        ic, js = self.cos_index, self.sin_index
        n = np.array(self.dynamic_orders, dtype=float)
        fa, fb = force[..., ic], force[..., js]
        xa, xb = displacement[..., ic], displacement[..., js]
        return np.pi * np.sum(n * (fa * xb - fb * xa), axis=-1)

    def real_matrix(self, S: np.ndarray) -> np.ndarray:
        """Per-order complex operators (n_orders, n, n) -> the real operator on
        DOF-major coefficients, (n * n_coeffs, n * n_coeffs).

        ``X_n = a_n - i b_n`` turns ``Y = S X`` into ``y_a = Re S a + Im S b``,
        ``y_b = -Im S a + Re S b``; order 0 keeps ``Re S``."""
        n, nc = S.shape[1], self.n_coeffs
        R = np.zeros((n, nc, n, nc))
        # one (n, n) strided slice per coefficient pair: basic slicing, no index arrays
        # (advanced indexing of the 4-d view cost several times more on large n)
        k0 = int(self.has_static)
        if self.has_static:
            R[:, 0, :, 0] = S[0].real
        for k, (a, b) in enumerate(zip(self.cos_index, self.sin_index)):
            Sr, Si = S[k0 + k].real, S[k0 + k].imag
            R[:, a, :, a] = Sr
            R[:, b, :, b] = Sr
            R[:, a, :, b] = Si
            np.negative(Si, out=R[:, b, :, a])
        return R.reshape(n * nc, n * nc)

    def real_apply(self, S: np.ndarray, c: np.ndarray) -> np.ndarray:
        """``real_matrix(S) @ c.ravel()`` without forming the real operator: ``Y_n = S_n X_n``
        on the complex amplitudes. S: (n_orders, n, n); c: (n, n_coeffs) or its ravel.
        Returns (n * n_coeffs,)."""
        n, k0 = S.shape[1], int(self.has_static)
        c = np.reshape(c, (n, self.n_coeffs))
        X = np.empty((len(self.orders), n), dtype=complex)  # X_n = a_n - i b_n
        if self.has_static:
            X[0] = c[:, 0]
        X[k0:] = (c[:, k0::2] - 1j * c[:, k0 + 1::2]).T
        # einsum, not BLAS: a threaded matrix-vector product costs a thread hand-off that
        # exceeds its flops here (15 ms against 0.5 on a busy 2-core machine, n = 432)
        return self.real_vector(np.einsum("kij,kj->ki", S, X)).ravel()

    def real_vector(self, F: np.ndarray) -> np.ndarray:
        """Per-order complex vectors (n_orders, n) -> DOF-major coefficients (n, n_coeffs)."""
        c = np.empty((F.shape[1], self.n_coeffs))
        k0 = int(self.has_static)
        if self.has_static:
            c[:, 0] = F[0].real
        c[:, k0::2] = F[k0:].real.T  # a_n (cos_index), then b_n (sin_index)
        c[:, k0 + 1::2] = -F[k0:].imag.T
        return c

    def to_complex(self, c: np.ndarray) -> dict[int, np.ndarray]:
        """Coefficients (..., n_coeffs) -> {order: complex X_n = a_n - i b_n}."""
        out = {}
        if self.has_static:
            out[0] = c[..., 0].astype(complex)
        for o, ic, js in zip(self.dynamic_orders, self.cos_index, self.sin_index):
            out[o] = c[..., ic] - 1j * c[..., js]
        return out

    def from_complex(self, X: dict[int, np.ndarray], shape: tuple[int, ...]) -> np.ndarray:
        """{order: complex X_n} -> real coefficients (*shape, n_coeffs); orders missing
        from ``X`` are zero, orders not kept here are ignored."""
        c = np.zeros((*shape, self.n_coeffs))
        if self.has_static and 0 in X:
            c[..., 0] = np.real(X[0])
        for o, ic, js in zip(self.dynamic_orders, self.cos_index, self.sin_index):
            if o in X:
                c[..., ic] = np.real(X[o])
                c[..., js] = -np.imag(X[o])
        return c

    def peak(self, c: np.ndarray, oversample: int = 4) -> np.ndarray:
        """max_t |x(t)| of coefficient rows (..., n_coeffs), exact to rounding.

        The largest of ``oversample * n_samples`` phases is refined by Newton
        on ``x'(theta) = 0`` (a few iterations: the sampled maximum is within
        half a fine sample of the true one)."""
        c = np.asarray(c, dtype=float)
        flat = c.reshape(-1, self.n_coeffs)
        n_fine = oversample * self.n_samples
        theta = 2.0 * np.pi * np.arange(n_fine) / n_fine
        x = flat @ self.synthesis_at(theta).T
        k = np.argmax(np.abs(x), axis=1)
        th = theta[k]
        d1 = flat @ self.derivative.T  # coefficients of x'
        d2 = d1 @ self.derivative.T  # and of x''
        for _ in range(4):
            E = self.synthesis_at(th)
            step = np.einsum("pc,pc->p", E, d1) / np.where(
                (den := np.einsum("pc,pc->p", E, d2)) != 0, den, 1.0)
            th = th - np.clip(step, -np.pi / n_fine, np.pi / n_fine)
        refined = np.abs(np.einsum("pc,pc->p", self.synthesis_at(th), flat))
        best = np.maximum(refined, np.abs(x[np.arange(flat.shape[0]), k]))
        return best.reshape(c.shape[:-1])
