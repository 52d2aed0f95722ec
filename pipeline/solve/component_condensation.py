"""The linear part condensed on the contact DOFs body by body, the large bodies lazily: the
same S_n = D_cc - D_ci D_ii^-1 D_ic as :mod:`condensation`, by a route that factors per
iterate only what the residual needs.

The matrices' pattern splits into connected components (a body; bodies the contacts alone
couple are apart), so D_ii is block-diagonal and S is too. Per component with nc_b contact
and ni_b other DOFs, S_b costs ni_b^3 / 3 to factor D_ii and ni_b^2 nc_b + nc_b^2 ni_b to
form. A continuation puts every Newton iterate at a new frequency, but its residual and
GMRES's products need S x only, D_cc x - D_ci D_ii^-1 D_ic x: a large component (a whole
mistuned disk: 1,152 contact DOFs, 768 others) keeps D_ii's LU and forms S_b only when asked
(a new preconditioner): 90 ms a new frequency against the modal route's receptance (nc_b^2
n_b + nc_b^3 / 3), 190 ms, measured on the 48-blade disk. Small components (the dampers: 24
and 10) are stacked by shape and formed at once, their D_ii inverted in a batch.

Order 0 (D = K_0, the same at every point) is condensed once, as :mod:`modal_condensation`
does. Loads: F_e = F_c - D_ci z, z = D_ii^-1 F_i; recovery q_i = z - D_ii^-1 D_ic q_c.
Frequency derivatives (dD = -2 n^2 w M + i n C): dS X = dD_cc X - dD_ci W - D_ci D_ii^-1
(dD_ic X - dD_ii W) with W = D_ii^-1 D_ic X, and dF_e = dF_c - dD_ci z - D_ci D_ii^-1
(dF_i - dD_ii z).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.linalg as sla

from .modal_condensation import (
    PARAMETERS,
    GroupedCondensed,
    StaticPart,
    component_parts,
    contact_bodies,
)

#: Other DOFs per component up to which a component is formed at every point (its D_ii
#: inverted in a batch with the others of its shape, S_b made): beyond, D_ii is LU-factored
#: and S_b made only when asked.
FORMED_UP_TO = 64
#: Products at one point after which a large component's S_b is made: a lazy product
#: reads D_cc, D_ci, D_ic and solves with D_ii's factors (~3.5 ms at 1,152 contact and 768
#: other DOFs, one thread), S_b's costs 0.9 ms, and making it 380 ms: even after ~150.
FORM_AFTER = 150


@dataclass(frozen=True, eq=False)
class _Block:
    """G components of one shape stacked: per component its contact positions (ncb, among
    0..nc-1), its other positions (nib, among nc..n-1) and its K, M, C over both, contact
    DOFs first (G, nb, nb)."""

    contact: np.ndarray  # (G, ncb) int
    other: np.ndarray  # (G, nib) int, in the order's reordered layout
    K: np.ndarray
    M: np.ndarray
    C: np.ndarray | None  # None: undamped

    @property
    def nc(self) -> int:
        return self.contact.shape[1]

    @property
    def formed(self) -> bool:
        return self.other.shape[1] <= FORMED_UP_TO

    def dynamic(self, order: int, omega: float) -> np.ndarray:
        """(G, nb, nb) D = K - (n w)^2 M + i n w C."""
        w = order * omega
        D = self.K - w * w * self.M
        return D + 1j * w * self.C if self.C is not None else D.astype(complex)

    def d_dynamic(self, order: int, omega: float) -> np.ndarray:
        """(G, nb, nb) dD/dw = -2 n^2 w M + i n C."""
        dD = (-2.0 * order * order * omega) * self.M
        return dD + 1j * order * self.C if self.C is not None else dD.astype(complex)

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in (self.contact, self.other, self.K, self.M)) + \
            (self.C.nbytes if self.C is not None else 0)


@dataclass(frozen=True, eq=False)
class ComponentForm:
    """What every point of a model shares on this route: per dynamic order its components
    stacked by shape (None at order 0), order 0's factored condensation."""

    orders: tuple[int, ...]
    blocks: tuple[tuple[_Block, ...] | None, ...]
    static: StaticPart | None
    n_contact: int
    sizes: tuple[int, ...]

    @classmethod
    def of(cls, linear, nc: int, masses: Sequence[np.ndarray],
           parts: tuple[dict, dict] | None = None) -> ComponentForm | None:
        """The form of a reordered ``linear.LinearDynamics`` (contact DOFs first, nc of
        them) at the masses ``masses`` (per order), None where it has no dynamic order or
        no contact DOF. ``parts``: :func:`component_parts`' of them, where made already."""
        dynamic = [k for k, o in enumerate(linear.orders) if o > 0]
        if not dynamic or nc == 0:
            return None
        parts, same = parts or component_parts(linear, nc, masses)
        blocks: list[tuple[_Block, ...] | None] = [None] * len(linear.orders)
        for k in dynamic:  # orders with the same matrices (a lumped model) share them
            blocks[k] = blocks[same[k]] if same[k] != k else \
                _stacked(parts[k], linear.K[k], masses[k], linear.C[k])
        static = StaticPart.of(linear.K[0], nc, contact_bodies(parts[dynamic[0]])) \
            if linear.orders[0] == 0 else None
        return cls(tuple(linear.orders), tuple(blocks), static, nc, tuple(linear.sizes))

    @staticmethod
    def cost(parts: dict) -> float:
        """Complex multiply-adds of one iterate (the factors; the formed components' S_b)
        over the dynamic orders' components ``parts`` (modal_condensation's): what the
        route choice weighs against the others'."""
        total = 0.0
        for components in parts.values():
            for c, d in components:
                ni = d.size - c.size
                total += ni**3 / 3 + (ni * ni * c.size + c.size**2 * ni
                                      if ni <= FORMED_UP_TO else 0.0)
        return total

    @property
    def nbytes(self) -> int:
        held = {id(b): b.nbytes for bs in self.blocks if bs for b in bs}  # (shared once)
        return sum(held.values()) + (self.static.nbytes if self.static is not None else 0)

    def condensed(self, omega: float, F: Sequence[np.ndarray],
                  dF: Sequence[np.ndarray] | None, parameter: str | None
                  ) -> ComponentCondensed:
        """The condensation at angular frequency ``omega`` [rad/s] of the per-order loads
        ``F`` (reordered, (n_k,)) and their derivatives ``dF`` by ``parameter``."""
        if parameter not in PARAMETERS:
            raise ValueError(f"component condensation: no derivative by {parameter!r}")
        return ComponentCondensed(self, float(omega), tuple(F),
                                  None if dF is None else tuple(dF), parameter)


def _stacked(parts, K, M, C) -> tuple[_Block, ...]:
    """The components (contact positions, every position) grouped by shape."""
    by_shape: dict[tuple[int, int], list] = {}
    for c, d in parts:
        by_shape.setdefault((c.size, d.size), []).append(d)
    damped = bool(np.any(C))
    out = []
    for (ncb, _), members in by_shape.items():
        idx = np.array(members)  # (G, nb): contact positions first (ascending)
        rows, cols = idx[:, :, None], idx[:, None, :]
        out.append(_Block(idx[:, :ncb], idx[:, ncb:], K[rows, cols], M[rows, cols],
                          C[rows, cols] if damped else None))
    return tuple(out)


@dataclass(eq=False)
class _AtPoint:
    """One group at a point: D's blocks and D_ii's inverse (formed) or LU factors (large),
    S_b where formed."""

    block: _Block
    order: int
    omega: float
    derivative: bool  # by frequency: dD/dw made when first asked
    D: np.ndarray  # (G, nb, nb)
    inverse: np.ndarray | None  # (G, nib, nib) D_ii^-1 (formed)
    lus: tuple | None  # per component the LU of D_ii (large)
    S: np.ndarray | None  # (G, ncb, ncb) (formed, or made)
    products: int = 0  # lazy S products so far

    @classmethod
    def of(cls, b: _Block, order: int, omega: float, derivative: bool) -> _AtPoint:
        D = b.dynamic(order, omega)
        n, at = b.nc, (b, order, omega, derivative, D)
        if b.other.shape[1] == 0:
            return cls(*at, None, None, D.copy())
        if b.formed:
            inverse = np.linalg.inv(D[:, n:, n:])
            S = D[:, :n, :n] - D[:, :n, n:] @ (inverse @ D[:, n:, :n])
            return cls(*at, inverse, None, S)
        lus = tuple(sla.lu_factor(Dg[n:, n:], check_finite=False) for Dg in D)
        return cls(*at, None, lus, None)

    @cached_property
    def dD(self) -> np.ndarray | None:
        """(G, nb, nb) dD/dw, None where the derivative is not by frequency."""
        return self.block.d_dynamic(self.order, self.omega) if self.derivative else None

    @property
    def contact(self) -> np.ndarray:
        """(G, ncb) the components' contact positions."""
        return self.block.contact

    def solve_ii(self, X: np.ndarray) -> np.ndarray:
        """D_ii^-1 X per component, X (G, nib, m)."""
        if self.inverse is not None:
            return self.inverse @ X
        if self.lus is None:
            return X
        return np.stack([sla.lu_solve(lu, x, check_finite=False)
                         for lu, x in zip(self.lus, X)])

    def product(self, X: np.ndarray) -> np.ndarray:
        """S_b X per component, X (G, ncb, m)."""
        self.products += 1
        if self.S is not None or self.products > FORM_AFTER:
            return self.S_b() @ X
        n, D = self.block.nc, self.D
        return D[:, :n, :n] @ X - D[:, :n, n:] @ self.solve_ii(D[:, n:, :n] @ X)

    def d_product(self, X: np.ndarray) -> np.ndarray:
        """dS_b X per component, X (G, ncb, m) (zero where the derivative is not by
        frequency)."""
        if not self.derivative:
            return np.zeros_like(X)
        n, D, dD = self.block.nc, self.D, self.dD
        out = dD[:, :n, :n] @ X
        if self.block.other.shape[1] == 0:
            return out
        W = self.solve_ii(D[:, n:, :n] @ X)
        V = dD[:, n:, :n] @ X - dD[:, n:, n:] @ W
        return out - dD[:, :n, n:] @ W - D[:, :n, n:] @ self.solve_ii(V)

    def S_b(self) -> np.ndarray:
        """(G, ncb, ncb) S_b."""
        if self.S is None:
            n, D = self.block.nc, self.D
            self.S = D[:, :n, :n] - D[:, :n, n:] @ self.solve_ii(D[:, n:, :n])
        return self.S

    @property
    def nbytes(self) -> int:
        held = [self.D, self.inverse, self.S] + \
            [lu[0] for lu in self.lus or ()]
        # (dD, made by the first frequency product, and S_b, made when asked, counted
        # from the start: the cache weighs a point once)
        later = self.D.nbytes if self.derivative else 0
        if self.S is None:
            later += self.D.shape[0] * self.block.nc**2 * 16
        return sum(a.nbytes for a in held if a is not None) + later


class ComponentCondensed(GroupedCondensed):
    """The condensation at one point by this route, with :class:`~microslip.solve.
    condensation.Condensed`'s interface for the balance (``S``, ``S_product``, ``F``,
    ``dS_product``, ``dF``, ``recover``)."""

    def __init__(self, form: ComponentForm, omega: float, F: tuple, dF: tuple | None,
                 parameter: str | None):
        derivative = parameter == "frequency"
        super().__init__(form, tuple(
            None if bs is None else tuple(_AtPoint.of(b, o, omega, derivative) for b in bs)
            for o, bs in zip(form.orders, form.blocks)), F, dF)

    def _order_loads(self, k: int, a, F: np.ndarray, dF: np.ndarray | None) -> np.ndarray:
        """F_e = F_c - D_ci z of group ``a``; z = D_ii^-1 F_i kept (G, nib, 1)."""
        b, n = a.block, a.block.nc
        F = np.asarray(F, dtype=complex)
        z = a.solve_ii(F[b.other][..., None])
        self.F[k][b.contact] = (F[b.contact][..., None] - a.D[:, :n, n:] @ z)[..., 0]
        if dF is not None:
            dF = np.asarray(dF, dtype=complex)
            dFc, rhs = dF[b.contact][..., None], dF[b.other][..., None]
            if a.derivative:
                dFc = dFc - a.dD[:, :n, n:] @ z
                rhs = rhs - a.dD[:, n:, n:] @ z
            self.dF[k][b.contact] = (dFc - a.D[:, :n, n:] @ a.solve_ii(rhs))[..., 0]
        return z

    def recover(self, k: int, x: np.ndarray) -> np.ndarray:
        """The condensed DOFs' amplitudes (n_k - nc,), in the reordered layout, of order k
        from the contact DOFs' x (nc,)."""
        nc = self.n_contact
        at = self._at[k]
        if at is None:
            return self._z[k] - self.form.static.Y @ x
        q = np.zeros(self.form.sizes[k] - nc, dtype=complex)
        for a, z in zip(at, self._z[k]):
            b, n = a.block, a.block.nc
            if not b.other.shape[1]:
                continue
            xc = np.asarray(x, dtype=complex)[b.contact][..., None]
            q[b.other - nc] = (z - a.solve_ii(a.D[:, n:, :n] @ xc))[..., 0]
        return q

    @property
    def nbytes(self) -> int:
        held = sum(a.nbytes for at in self._at if at is not None for a in at)
        held += len(self._at) * self.n_contact**2 * 16  # S, where the preconditioner asks
        return held + self.F.nbytes * (2 if self.dF is not None else 1) + \
            sum(z.nbytes for zs in self._z if isinstance(zs, list) for z in zs)
