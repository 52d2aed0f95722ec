"""The linear part condensed on the contact DOFs through its own modes, where its damping is
diagonal in them: the same S_n = D_cc - D_ci D_ii^-1 D_ic as :mod:`condensation`, by
another route that costs what the contacts need, not what the other DOFs number.

Where an order's K, M, C are diagonal together in the modes Phi of (K, M) (Phi^H M Phi = I,
Phi^H K Phi = diag(lam), Phi^H C Phi = diag(c): every body damped by modal ratios on its
own modes or Rayleigh's alpha M + beta K), the dynamic stiffness at w_n = n w is
D = Phi^-H diag(d) Phi^-1 with d = lam - w_n^2 + i w_n c, its inverse the receptance
H = Phi diag(1/d) Phi^H, and the Schur complement of the other DOFs is S = (H_cc)^-1.
Per connected component of the matrices' pattern (a body; bodies the contacts alone couple
are apart) an iterate costs nc_b^2 n_b to form H_cc (real modes: two real products, half
that) and nc_b^3 / 3 to factor it, against the Schur complement's n_i^3 / 3 + n_i^2 nc +
nc^2 n_i over every other DOF: the whole disk's thousands of modal coordinates, a handful
of contact DOFs per body each.

Order 0 (w = 0: a free-free damper's rigid modes have d = 0) keeps the Schur complement of
:mod:`condensation`, whose K_0 does not depend on the point: factored once.

The loads condense as F_e = S H_c. F; the other DOFs come back from the contact DOFs' q_c
through the contact reaction G = S q_c - F_e: q = Phi diag(1/d) Phi^H (F + G) (Firrone &
Zucca eq. 9 in modal form). Frequency derivatives: dS = -S dH S with
dH = Phi_c diag(-(dd/dw) / d^2) Phi_c^H.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
import scipy.linalg as sla

from microslip.fe.fem import RIGID_SHARE

from .blocks import BlockDiagonal, pattern_components
from .condensation import real_product

#: The modal route is taken where its per-iterate cost (complex multiply-adds) is at least
#: this many times below the Schur complement's: its set-up (an eigendecomposition per
#: component, once per model) and its rounding (another route to the same numbers) pay only
#: where it saves much.
MODAL_GAIN = 4.0
#: Complex multiply-adds of the Schur route per iterate below which it stays: a few
#: milliseconds either way (every cyclic sector case of the shipped set, whose numbers the
#: other route would move by rounding for no gain).
MODAL_FROM = 1e8
#: Largest off-diagonal of Phi^H C Phi, relative to its largest diagonal entry, that counts
#: as diagonal (modal damping formed from the same modes agrees to rounding, ~1e-13).
DIAGONAL_TOL = 1e-8
#: Contact DOFs per component up to which the receptance is inverted (batched, small),
#: above which it is LU-factored (a third of the work, one body at a time).
INVERT_UP_TO = 256
#: Parameters whose derivative the modal route forms; "mass" (M changes, and with it the
#: modes) and a nonlinear mode's self-excitation take the Schur complement.
PARAMETERS = (None, "frequency", "excitation", "preload")


@dataclass(frozen=True, eq=False)
class _Group:
    """G components of one shape stacked: nb DOFs each, ncb of them contact DOFs."""

    contact: np.ndarray  # (G, ncb) int: positions among the contact DOFs, 0..nc-1
    dofs: np.ndarray  # (G, nb) int: positions in the reordered matrices, contact ones first
    modes: np.ndarray  # (G, nb, nb) Phi, mass-normalised (real where the matrices are)
    lam: np.ndarray  # (G, nb) eigenvalues, rad^2/s^2
    damping: np.ndarray  # (G, nb) diag(Phi^H C Phi), 1/s

    @property
    def at_contacts(self) -> np.ndarray:
        """(G, ncb, nb) Phi's rows at the contact DOFs."""
        return self.modes[:, : self.contact.shape[1], :]

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in (self.contact, self.dofs, self.modes, self.lam,
                                      self.damping))


@dataclass(frozen=True, eq=False)
class StaticPart:
    """Order 0's condensation, factored once: S_0 = D_cc - D_ci Y, Y = D_ii^-1 D_ic, held
    as its bodies' blocks (each body's contact DOFs couple only among themselves: on a
    mistuned disk a product reads the annulus's 1,152^2 and the 48 dampers' 24^2, not
    2,304^2)."""

    blocks: BlockDiagonal  # S_0 (nc, nc)
    Dci: np.ndarray  # (nc, ni)
    Y: np.ndarray  # (ni, nc)
    lu: tuple | None

    @classmethod
    def of(cls, D: np.ndarray, nc: int, bodies: list[np.ndarray] | None = None
           ) -> StaticPart:
        """``bodies``: the contact positions of each body (the dynamic orders'
        components; what couples them at order 0 is held apart, sparse); None: the
        components of S_0's pattern."""
        Dci = D[:nc, nc:]
        if D.shape[0] == nc:
            S, Y, lu = np.array(D[:nc, :nc]), np.zeros((0, nc), dtype=D.dtype), None
        else:
            lu = sla.lu_factor(D[nc:, nc:], check_finite=False)
            Y = sla.lu_solve(lu, D[nc:, :nc], check_finite=False)
            S = D[:nc, :nc] - Dci @ Y
        # (exact zeros between bodies: D_ii's LU eliminates within each body)
        return cls(BlockDiagonal.of(S, bodies), Dci, Y, lu)

    @property
    def n_contact(self) -> int:
        return self.blocks.n

    @property
    def S(self) -> np.ndarray:
        """(nc, nc) S_0, dense."""
        return self.blocks.dense()

    def product(self, x: np.ndarray) -> np.ndarray:
        """S_0 x, x (nc, ...) real or complex."""
        return self.blocks.product(x)

    def condensed_load(self, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(F_e (nc,), z = D_ii^-1 F_i) of a load (n,) in the reordered layout."""
        nc = self.n_contact
        if self.lu is None:
            return F[:nc].astype(complex), np.zeros(0, dtype=complex)
        z = _lu_solve(self.lu, F[nc:])
        return F[:nc] - self.Dci @ z, z

    @property
    def nbytes(self) -> int:
        return self.blocks.nbytes + self.Y.nbytes + (self.lu[0].nbytes if self.lu else 0)


@dataclass(frozen=True, eq=False)
class ModalForm:
    """What every point of a model shares on the modal route: per dynamic order its
    components' modes (``None`` at order 0), order 0's factored condensation."""

    orders: tuple[int, ...]
    groups: tuple[tuple[_Group, ...] | None, ...]
    static: StaticPart | None
    n_contact: int

    @classmethod
    def of(cls, linear, nc: int, masses: Sequence[np.ndarray], always: bool = False,
           parts: tuple[dict, dict] | None = None) -> ModalForm | None:
        """The modal form of a reordered ``linear.LinearDynamics`` (contact DOFs first, nc
        of them) with the masses ``masses`` (per order, at the point's mass multiplier), or
        None where the damping is not diagonal in the modes, a mass matrix is not
        positive definite, or (unless ``always``) the route would not save MODAL_GAIN x
        the work of an iterate that costs MODAL_FROM or more."""
        dynamic = [k for k, o in enumerate(linear.orders) if o > 0]
        if not dynamic or nc == 0:
            return None
        parts, same = parts or component_parts(linear, nc, masses)
        if not always:
            schur, modal = route_costs(linear, nc, masses, parts)
            if schur < MODAL_FROM or modal * MODAL_GAIN > schur:
                return None
        groups: list[tuple[_Group, ...] | None] = [None] * len(linear.orders)
        for k in dynamic:
            if same[k] != k:
                groups[k] = groups[same[k]]
                continue
            try:
                groups[k] = _grouped(parts[k], linear.K[k], masses[k], linear.C[k])
            except (np.linalg.LinAlgError, ValueError):
                return None  # M not positive definite, or C not diagonal in the modes
        static = None
        if linear.orders[0] == 0:
            static = StaticPart.of(linear.K[0], nc, contact_bodies(parts[dynamic[0]]))
        return cls(tuple(linear.orders), tuple(groups), static, nc)

    @property
    def nbytes(self) -> int:
        seen, total = set(), 0
        for gs in self.groups:
            for g in gs or ():
                if id(g) not in seen:
                    seen.add(id(g))
                    total += g.nbytes
        return total + (self.static.nbytes if self.static is not None else 0)

    def condensed(self, omega: float, F: Sequence[np.ndarray],
                  dF: Sequence[np.ndarray] | None, parameter: str | None) -> ModalCondensed:
        """The condensation at angular frequency ``omega`` [rad/s] of the per-order loads
        ``F`` (reordered, (n_k,)) and their derivatives ``dF`` by ``parameter``."""
        if parameter not in PARAMETERS:
            raise ValueError(f"modal condensation: no derivative by {parameter!r}")
        return ModalCondensed(self, float(omega), tuple(F),
                              None if dF is None else tuple(dF), parameter)


@dataclass(frozen=True, eq=False)
class _OrderAtPoint:
    """One dynamic order's group at a point: 1/d, d(1/d)/dw and the factored receptance."""

    group: _Group
    inv_d: np.ndarray  # (G, nb)
    delta: np.ndarray | None  # (G, nb) d(1/d)/dw, or None (no frequency derivative)
    inverse: np.ndarray | None  # (G, ncb, ncb) H_cc^-1 (small components)
    lus: tuple | None  # per component the LU of H_cc (large ones)

    @classmethod
    def of(cls, g: _Group, order: int, omega: float, derivative: bool) -> _OrderAtPoint:
        w = order * omega
        d = g.lam - w * w + 1j * w * g.damping
        inv_d = 1.0 / d
        delta = -(-2.0 * order * w + 1j * order * g.damping) * inv_d**2 if derivative \
            else None
        H = _receptance(g.at_contacts, inv_d)
        if H.shape[1] == 0:
            return cls(g, inv_d, delta, H, None)
        if H.shape[1] <= INVERT_UP_TO:
            return cls(g, inv_d, delta, np.linalg.inv(H), None)
        return cls(g, inv_d, delta, None,
                   tuple(sla.lu_factor(h, check_finite=False, overwrite_a=True) for h in H))

    @property
    def contact(self) -> np.ndarray:
        """(G, ncb) the components' contact positions."""
        return self.group.contact

    def solve(self, X: np.ndarray) -> np.ndarray:
        """S X = H_cc^-1 X per component, X (G, ncb, m) complex."""
        if self.inverse is not None:
            return self.inverse @ X
        return np.stack([_lu_solve(lu, x) for lu, x in zip(self.lus, X)])

    def product(self, X: np.ndarray) -> np.ndarray:
        """S X per component (H_cc^-1 X)."""
        return self.solve(X)

    def d_product(self, X: np.ndarray) -> np.ndarray:
        """dS X = -S dH S X per component, dH = Phi_c diag(d(1/d)/dw) Phi_c^H (zero where
        the derivative is not by frequency)."""
        if self.delta is None:
            return np.zeros_like(X)
        y = self.from_contacts(self.solve(X)) * self.delta[..., None]
        return -self.solve(self.at_contacts(y))

    def S_b(self) -> np.ndarray:
        """(G, ncb, ncb) H_cc^-1."""
        if self.inverse is not None:
            return self.inverse
        eye = np.eye(self.group.contact.shape[1])
        return np.stack([_lu_solve(lu, eye) for lu in self.lus])

    def modal(self, F: np.ndarray) -> np.ndarray:
        """(G, nb, m) Phi^H F of loads F (G, nb, m)."""
        return real_product(np.swapaxes(self.group.modes, 1, 2).conj(), F)

    def at_contacts(self, w: np.ndarray) -> np.ndarray:
        """(G, ncb, m) Phi_c w of modal amplitudes w (G, nb, m)."""
        return real_product(self.group.at_contacts, w)

    def from_contacts(self, X: np.ndarray) -> np.ndarray:
        """(G, nb, m) Phi_c^H X of contact vectors X (G, ncb, m)."""
        return real_product(np.swapaxes(self.group.at_contacts, 1, 2).conj(), X)

    @property
    def nbytes(self) -> int:
        held = self.inverse.nbytes if self.inverse is not None else \
            sum(lu[0].nbytes for lu in self.lus)
        return held + self.inv_d.nbytes * (2 if self.delta is not None else 1)


class GroupedCondensed:
    """S, S_product and dS_product of a condensation at one point held per order as groups
    of components (``_at``: None at order 0, whose ``form.static`` serves it), each group
    at the point giving its ``contact`` positions (G, ncb), ``S_b()`` (G, ncb, ncb),
    ``product(x)`` S_b x and ``d_product(x)`` dS_b x for x (G, ncb, m)."""

    def __init__(self, form: Any, at: tuple, F: tuple, dF: tuple | None):
        """Per order the groups ``at`` at the point (None at order 0) and the condensed
        loads: order 0's by ``form.static``, each dynamic order's by :meth:`_order_loads`."""
        self.form, self.n_contact, self._at = form, form.n_contact, at
        self.F = np.empty((len(F), self.n_contact), dtype=complex)
        self.dF = None if dF is None else np.zeros_like(self.F)
        self._z: list = [None] * len(F)  # order 0: D_ii^-1 F_i; dynamic: per group
        for k, groups in enumerate(at):
            dFk = None if dF is None else dF[k]
            if groups is None:
                self.F[k], self._z[k] = form.static.condensed_load(F[k])
                if dFk is not None:
                    self.dF[k] = form.static.condensed_load(dFk)[0]
            else:
                self._z[k] = [self._order_loads(k, a, F[k], dFk) for a in groups]

    def _order_loads(self, k: int, a, F: np.ndarray, dF: np.ndarray | None) -> np.ndarray:
        """Group ``a``'s condensed loads of dynamic order k written into F[k] (and dF[k]);
        what recovery keeps of them."""
        raise NotImplementedError

    @cached_property
    def S(self) -> np.ndarray:
        """(n_orders, nc, nc) complex, block-diagonal over the components at every dynamic
        order."""
        nc = self.n_contact
        out = np.zeros((len(self._at), nc, nc), dtype=complex)
        for k, at in enumerate(self._at):
            if at is None:
                out[k] = self.form.static.S
                continue
            for a in at:
                c = a.contact
                if c.shape[1]:
                    out[k][c[:, :, None], c[:, None, :]] = a.S_b()
        return out

    def S_product(self, X: np.ndarray) -> np.ndarray:
        """S_k X_k per order: X (n_orders, nc, ...) complex, the same shape back."""
        static = self.form.static
        return self._per_group(X, lambda a, x: a.product(x),
                               None if static is None else static.product)

    def dS_product(self, X: np.ndarray) -> np.ndarray:
        """dS_k X_k per order (by frequency; zero by the other parameters and at order 0)."""
        return self._per_group(X, lambda a, x: a.d_product(x), None)

    def _per_group(self, X: np.ndarray, apply, static) -> np.ndarray:
        """Per dynamic order ``apply(group at the point, (G, ncb, m))`` on X gathered at the
        group's contact positions and scattered back; order 0 ``static(X_0)`` (zero where
        None)."""
        out = np.zeros(X.shape, dtype=complex)
        nc = self.n_contact
        for k, at in enumerate(self._at):
            x = X[k].reshape(nc, -1)
            if at is None:
                if static is not None:
                    out[k] = static(x).reshape(X[k].shape)
                continue
            o = out[k].reshape(nc, -1)
            for a in at:
                c = a.contact
                if c.shape[1]:
                    o[c] = apply(a, x[c])
        return out


class ModalCondensed(GroupedCondensed):
    """The condensation at one point by the modal route, with :class:`~microslip.solve.
    condensation.Condensed`'s interface for the balance (``S``, ``S_product``, ``F``,
    ``dS_product``, ``dF``, ``recover``)."""

    def __init__(self, form: ModalForm, omega: float, F: tuple, dF: tuple | None,
                 parameter: str | None):
        derivative = parameter == "frequency"
        super().__init__(form, tuple(
            None if gs is None else tuple(_OrderAtPoint.of(g, o, omega, derivative)
                                          for g in gs)
            for o, gs in zip(form.orders, form.groups)), F, dF)

    def _order_loads(self, k: int, a, F: np.ndarray, dF: np.ndarray | None) -> np.ndarray:
        """F_e = S H_c. F of group ``a``; its modal load Phi^H F kept (G, nb, 1)."""
        g = a.group
        w = a.modal(F[g.dofs][..., None])
        if not g.contact.shape[1]:
            return w
        Fe = a.solve(a.at_contacts(w * a.inv_d[..., None]))
        self.F[k][g.contact] = Fe[..., 0]
        if dF is not None:
            rhs = a.modal(dF[g.dofs][..., None]) * a.inv_d[..., None]
            if a.delta is not None:
                rhs = rhs + a.delta[..., None] * (w - a.from_contacts(Fe))
            self.dF[k][g.contact] = a.solve(a.at_contacts(rhs))[..., 0]
        return w

    def recover(self, k: int, x: np.ndarray) -> np.ndarray:
        """The condensed DOFs' amplitudes (n_k - nc,), in the reordered layout, of order k
        from the contact DOFs' x (nc,)."""
        nc = self.n_contact
        at = self._at[k]
        if at is None:
            return self._z[k] - self.form.static.Y @ x
        n = max(int(a.group.dofs.max(initial=-1)) for a in at) + 1
        q = np.zeros(n, dtype=complex)
        for a, w in zip(at, self._z[k]):
            g = a.group
            if g.contact.shape[1]:
                react = a.solve(x[g.contact][..., None]) - self.F[k][g.contact][..., None]
                w = w + a.from_contacts(react)
            q[g.dofs] = real_product(g.modes, w * a.inv_d[..., None])[..., 0]
        return q[nc:]

    @property
    def nbytes(self) -> int:
        held = sum(a.nbytes for at in self._at if at is not None for a in at)
        return held + self.F.nbytes * (2 if self.dF is not None else 1) + \
            sum(w.nbytes for zs in self._z if isinstance(zs, list) for w in zs)


def component_parts(linear, nc: int, masses: Sequence[np.ndarray]) -> tuple[dict, dict]:
    """Per dynamic order k its components (:func:`body_components`), and the first order with
    the same matrices (a lumped model's orders share theirs)."""
    dynamic = [k for k, o in enumerate(linear.orders) if o > 0]
    parts, same = {}, {}
    for k in dynamic:
        same[k] = next((j for j in dynamic if j < k and _same(linear, masses, j, k)), k)
        parts[k] = parts[same[k]] if same[k] != k else \
            body_components(linear.K[k], masses[k], linear.C[k], nc)
    return parts, same


def contact_bodies(components: list[tuple[np.ndarray, np.ndarray]]) -> list[np.ndarray]:
    """The contact positions of each component that has some (:func:`body_components`')."""
    return [c for c, _ in components if c.size]


def route_costs(linear, nc: int, masses: Sequence[np.ndarray], parts: dict
                ) -> tuple[float, float]:
    """Complex multiply-adds of an iterate by the Schur complement over every other DOF
    and by the modal route (``parts``: :func:`component_parts`' first)."""
    dynamic = [k for k, o in enumerate(linear.orders) if o > 0]
    n_i = [linear.sizes[k] - nc for k in dynamic]
    schur = sum(ni**3 / 3 + ni**2 * nc + nc**2 * ni for ni in n_i)
    # real modes form the receptance by two real products: half a complex one
    share = {k: 1.0 if _complex(linear, masses, k) else 0.5 for k in dynamic}
    modal = sum(share[k] * c.size**2 * d.size + c.size**3 / 3 for k in dynamic
                for c, d in parts[k])
    return schur, modal


def body_components(K: np.ndarray, M: np.ndarray, C: np.ndarray, nc: int
                    ) -> list[tuple[np.ndarray, np.ndarray]]:
    """Connected components of the pattern of K, M, C: per component (its contact
    positions < nc, every position: contact ones first)."""
    # (each ascending: its contact positions, < nc, first)
    return [(d[d < nc], d) for d in pattern_components((K != 0) | (M != 0) | (C != 0))]


def _grouped(parts, K, M, C) -> tuple[_Group, ...]:
    """The components' modes, stacked by shape. ValueError where C is not diagonal in
    them; LinAlgError where M is not positive definite."""
    by_shape: dict[tuple[int, int], list] = {}
    for c, d in parts:
        by_shape.setdefault((c.size, d.size), []).append((c, d))
    groups = []
    for members in by_shape.values():
        modes, lams, damps = [], [], []
        for _, d in members:
            ix = np.ix_(d, d)
            lam, phi, c = diagonal_modes(K[ix], M[ix], C[ix])
            modes.append(phi)
            lams.append(lam)
            damps.append(c)
        groups.append(_Group(np.array([c for c, _ in members]),
                             np.array([d for _, d in members]), np.array(modes),
                             np.array(lams), np.array(damps)))
    return tuple(groups)


def diagonal_modes(K: np.ndarray, M: np.ndarray, C: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lam (n,), Phi (n, n) mass-normalised, c (n,)) with Phi^H K Phi = diag(lam) and
    Phi^H C Phi = diag(c) to DIAGONAL_TOL. ValueError where C is not diagonal in the modes
    of (K, M); LinAlgError where M is not positive definite."""
    if not _imaginary(K, M, C):
        K, M, C = K.real, M.real, C.real  # (held complex, real: a real eigenproblem, 4x less)
    lam, phi = sla.eigh(K, M, check_finite=False)
    cm = phi.conj().T @ C @ phi
    c = np.real(np.diag(cm)).copy()
    # against the largest: a body's rigid modes are degenerate, and any rounding-level
    # damping on them (a Rayleigh part's alpha M is exact there, but beta K is rounding)
    # turns, in their arbitrary basis, into off-diagonals far above their own damping but
    # ~1e-9 of the largest, negligible against their d = -w^2 (measured on the 24-blade
    # disk's dampers, when modal ratios still damped rigid modes: 9e-6 of 2e3)
    off = np.abs(cm - np.diag(np.diag(cm))).max(initial=0.0)
    if off > DIAGONAL_TOL * max(np.abs(c).max(initial=0.0), 1e-300):
        raise ValueError("damping not diagonal in the modes")
    # rigid below modal damping's own threshold, which leaves them undamped (an undamped
    # elastic mode refuses the route: its receptance is infinite there, S finite)
    elastic = lam > RIGID_SHARE * max(float(np.abs(lam).max(initial=0.0)), 1e-300)
    if np.any(elastic & (c <= 0.0)):  # (its receptance is infinite at its frequency)
        raise ValueError("an undamped elastic mode")
    return lam, phi, c


def _complex(linear, masses, k: int) -> bool:
    """Whether order k's matrices hold an imaginary part (complex modes), over the whole
    order: a real body beside complex ones is counted complex (the estimate errs towards
    the Schur route; diagonal_modes decides per component)."""
    return _imaginary(linear.K[k], masses[k], linear.C[k])


def _imaginary(*arrays: np.ndarray) -> bool:
    """Whether any of ``arrays`` holds a nonzero imaginary part (complex-held real is real)."""
    return any(np.iscomplexobj(A) and np.any(A.imag) for A in arrays)


def _same(linear, masses, j: int, k: int) -> bool:
    return all(A[j].shape == A[k].shape and (A[j] is A[k] or np.array_equal(A[j], A[k]))
               for A in (linear.K, masses, linear.C))


def _receptance(Phic: np.ndarray, inv_d: np.ndarray) -> np.ndarray:
    """(G, ncb, ncb) H_cc = Phi_c diag(1/d) Phi_c^H; a real Phi as two real products (a
    complex one would copy Phi to complex and do twice the work)."""
    right = np.swapaxes(Phic, 1, 2).conj()
    if np.iscomplexobj(Phic):
        return (Phic * inv_d[:, None, :]) @ right
    return (Phic * inv_d.real[:, None, :]) @ right \
        + 1j * ((Phic * inv_d.imag[:, None, :]) @ right)


def _lu_solve(lu: tuple, b: np.ndarray) -> np.ndarray:
    """lu_solve of a real or complex right side on real or complex factors."""
    if np.iscomplexobj(b) and not np.iscomplexobj(lu[0]):
        return sla.lu_solve(lu, b.real, check_finite=False) \
            + 1j * sla.lu_solve(lu, b.imag, check_finite=False)
    return sla.lu_solve(lu, b, check_finite=False)
