"""The assembly model and its recovery: from harmonic-balance unknowns back to bodies,
patches, nodes and named outputs (what results, maps and pictures need)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from microslip.fe.reduced_model import ReducedModel
from microslip.laws.coulomb import ContactResponse, slip_share
from microslip.solve.hbm import HarmonicBalance
from microslip.solve.linear import OperatingPoint

from .spec import AssemblySpec


@dataclass(frozen=True, eq=False)
class BodyLayout:
    """Where one body sits in the assembly model.

    offset: its first master DOF among the shared DOFs (3 per master node, x y z);
    models, conjugate: per harmonic order, the reduced model and whether its complex
    conjugate is used (a backward wave)."""

    body: str
    cyclic: bool
    offset: int
    master_nodes: np.ndarray
    models: tuple[ReducedModel, ...]
    conjugate: tuple[bool, ...]

    @property
    def n_masters(self) -> int:
        return 3 * len(self.master_nodes)

    @property
    def disk(self) -> bool:
        """The bladed disk: a cyclic body, or the whole disk's annulus (what the free
        limit keeps)."""
        return self.cyclic or self.models[0].method == "annulus"

    def indices(self, k: int, own_start: int) -> np.ndarray:
        """Positions of the body's reduced coordinates (masters, then modes) in order k's
        vector, given where its modes start there."""
        return np.concatenate([np.arange(self.offset, self.offset + self.n_masters),
                               np.arange(own_start, own_start + self.models[k].n_modes)])


def body_positions(layout: tuple[BodyLayout, ...] | list[BodyLayout], k: int,
                   n_dof: int) -> list[tuple[BodyLayout, np.ndarray]]:
    """Each body with its positions in order k's vector: masters in the shared part, then
    the modes of every body in turn past it."""
    out, own = [], n_dof
    for b in layout:
        out.append((b, b.indices(k, own)))
        own += b.models[k].n_modes
    return out


@dataclass(frozen=True, eq=False)
class ContactPoints:
    """The node pairs behind one contact of the model: a structured patch's in grid order
    (row-major ``grid`` (n1, n2)); named surfaces' in side a's node order (``grid`` (P,)).

    nodes_a: (P,) the pairs' nodes on body a; nodes_b: side b's nodes (a patch's (P,) node
    for node; a surface's, those its interpolation uses; none on the ground, body_b None);
    frames: (P, 3, 3) rows t1, t2, n; gaps: (P,) initial normal gap [m] (positive open)."""

    patch: str
    body_a: str
    body_b: str | None
    nodes_a: np.ndarray
    nodes_b: np.ndarray
    grid: tuple[int, ...]
    frames: np.ndarray
    gaps: np.ndarray


@dataclass(frozen=True)
class PatchState:
    """One patch at one solution, per node pair in grid order (row-major (n1, n2)).

    state: (P,) int8 state over the period (states.STICK .. OPEN; with two 1D elements per
    pair, the worse of the two: their normal is shared, so they lift off together);
    static: (P, 3) static contact forces [T0_1, T0_2, N0] in the pair's frame [N];
    slip_share: the share of the patch's node pairs that slip (stick-slip or gross slip)."""

    state: np.ndarray
    static: np.ndarray

    @property
    def slip_share(self) -> float:
        return slip_share(self.state)


def patch_states(names: list[str], points: Mapping[str, ContactPoints],
                 responses: list[ContactResponse]) -> dict[str, PatchState]:
    """Per patch its :class:`PatchState`, from the responses of the contacts ``names`` (the
    model's contacts in order: a 2D patch has one, a 1D+1D patch two, "<patch>.t1/.t2")."""
    parts: dict[str, list[tuple[str, ContactResponse]]] = {}
    for name, r in zip(names, responses):
        parts.setdefault(points[name].patch, []).append((name, r))
    out = {}
    for patch, items in parts.items():
        state = np.max([r.state for _, r in items], axis=0).astype(np.int8)
        static = np.zeros((state.size, 3))
        if len(items) == 1:  # one 2D element: [T1, T2, N]
            static[:] = items[0][1].forces[:, :, 0]
        else:  # "<patch>.t1", "<patch>.t2": [T, N] each, half the normal stiffness each
            for name, r in items:
                j = 0 if name.endswith(".t1") else 1
                static[:, j] = r.forces[:, 0, 0]
                static[:, 2] += r.forces[:, 1, 0]
        out[patch] = PatchState(state, static)
    return out


#: Cyclic bodies' DOFs from which their free response is solved through their modes
#: (below, a dense solve per frequency costs milliseconds).
FREE_MODAL_FROM = 600


@dataclass(frozen=True, eq=False)
class AssemblyModel:
    """A harmonic-balance model built from reduced bodies and contact patches.

    hb: what the solvers take; layout: the bodies; dof_nodes: (n_dof,) global node of each
    shared DOF (x, y, z in turn); outputs: name -> (n_dof,) row giving the output from the
    shared DOFs; points: contact name -> its node pairs."""

    hb: HarmonicBalance
    layout: tuple[BodyLayout, ...]
    dof_nodes: np.ndarray
    outputs: Mapping[str, np.ndarray]
    points: Mapping[str, ContactPoints]
    spec: AssemblySpec

    def patches(self, x: np.ndarray, point: OperatingPoint) -> dict[str, PatchState]:
        """Per patch its node pairs' states and static forces at a solution ``x``."""
        return patch_states([c.name for c in self.hb.contacts], self.points,
                            self.hb.contact_response(x, point))

    def body_coordinates(self, x: np.ndarray, point: OperatingPoint
                         ) -> dict[str, list[np.ndarray]]:
        """Per body, per harmonic order, the (r,) complex reduced coordinates (its masters,
        then its fixed-interface modes at the order's ND) of a solution ``x`` (Firrone & Zucca
        eq. 9: the modes recovered from the masters per order)."""
        X = self.hb.recover_orders(x, point)
        n_dof = self.hb.linear.n_dof
        out: dict[str, list[np.ndarray]] = {b.body: [] for b in self.layout}
        for k in range(len(self.hb.harmonics.orders)):
            for b, idx in body_positions(self.layout, k, n_dof):
                out[b.body].append(X[k][idx])
        return out

    def wave_numbers(self) -> tuple[int, ...]:
        """Per harmonic order, the signed ND of the wave that carries it: sector s of the
        disk moves with exp(i n s 2 pi / Ns) times sector 0, every body of the sector alike
        (n < 0: a backward wave, the complex conjugate model). Zeros without a cyclic body."""
        b = next((b for b in self.layout if b.cyclic), None)
        if b is None:
            return (0,) * len(self.hb.harmonics.orders)
        return tuple(-m.nodal_diameter if c else m.nodal_diameter
                     for m, c in zip(b.models, b.conjugate))

    def displacements(self, x: np.ndarray, point: OperatingPoint, body: str,
                      nodes: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(nodes (p,), coefficients (p, 3, n_coeffs) [m]) of one body's recovery nodes
        (or the given ones among them) at a solution: the reduced coordinates through each
        order's recovery matrix (conjugated for a backward wave), in the real harmonic
        layout."""
        b = next((b for b in self.layout if b.body == body), None)
        if b is None:
            raise ValueError(f"body {body!r}: not in the model; bodies "
                             f"{[x.body for x in self.layout]}")
        q = self.body_coordinates(x, point)[body]
        h = self.hb.harmonics
        U = {}
        for k, o in enumerate(h.orders):
            model = b.models[k]
            u = model.recover(q[k].conj() if b.conjugate[k] else q[k], nodes)
            U[o] = u.conj() if b.conjugate[k] else u
        first = b.models[0]
        chosen = first.recovery_nodes if nodes is None else np.asarray(nodes).ravel()
        return chosen, h.from_complex(U, (len(chosen), 3))

    def output_coefficients(self, x: np.ndarray, point: OperatingPoint,
                            names: list[str] | None = None) -> np.ndarray:
        """(n_outputs, n_coeffs) real coefficients of the named outputs [m]."""
        Q = self.hb.recover(x, point)
        names = list(self.outputs) if names is None else names
        return np.array([self.outputs[n] @ Q for n in names]).reshape(len(names), -1)

    def linear_outputs(self, point: OperatingPoint, springs: str = "stuck",
                       names: list[str] | None = None, static: bool = True) -> np.ndarray:
        """(n_outputs, n_coeffs) output coefficients of a linear limit, solved directly order
        by order (no harmonic balance): ``springs = "stuck"`` every contact replaced by its
        stick springs (kt, kn; the friction limit never reached), ``"normal"`` by its normal
        springs alone (mu = 0, contacts never opening), ``"free"`` the cyclic bodies alone
        (no damper, no contact). The springs carry the preload kn Delta at order 0.
        ``static = False`` leaves order 0 out (its coefficients zero): what a vibration
        measure needs, at half the cost."""
        if springs not in ("stuck", "normal", "free"):
            raise ValueError(f"springs = {springs!r}: expected 'stuck', 'normal' or 'free'")
        hb, h = self.hb, self.hb.harmonics
        n_dof = hb.linear.n_dof
        # (the free limit through the modes needs no D: a whole disk's is GBs an order)
        D = None if springs == "free" else hb.linear.dynamic_stiffness(point)
        F, _ = hb.forces(point)
        X = []
        for k, o in enumerate(h.orders):
            if o == 0 and not static:
                X.append(np.zeros(n_dof, dtype=complex))
                continue
            if springs == "free":
                keep = self._cyclic_indices(k)
                x = np.zeros(F[k].size, dtype=complex)
                x[keep] = self._free_response(k, o, point, F[k], keep)
                X.append(x[:n_dof])
                continue
            A, b = D[k].copy(), F[k].copy()
            A[:n_dof, :n_dof] += self._spring_stiffness(o, springs)
            if o == 0:  # the preload kn Delta of the normal springs
                for c in hb.contacts:
                    B = np.asarray(c.kinematics[o]).reshape(c.elements.size, -1, n_dof)
                    b[:n_dof] -= B[:, -1, :].conj().T @ c.elements.n0
            X.append(np.linalg.solve(A, b)[:n_dof])
        Q = h.from_complex({o: X[k] for k, o in enumerate(h.orders)}, (n_dof,))
        names = list(self.outputs) if names is None else names
        return np.array([self.outputs[n] @ Q for n in names]).reshape(len(names), -1)

    def _free_response(self, k: int, order: int, point: OperatingPoint, F: np.ndarray,
                       keep: np.ndarray) -> np.ndarray:
        """The cyclic bodies' response to F alone at order k: D[keep, keep]^-1 F[keep], by
        their modes where their damping is diagonal in them and they are large (a whole
        disk's annulus: one eigendecomposition, then n^2 a frequency instead of a dense
        solve, n^3 / 3, at each of a peak search's hundred frequencies)."""
        from microslip.solve.modal_condensation import diagonal_modes

        def direct():
            D = self.hb.linear.dynamic_stiffness(point)[k]
            return np.linalg.solve(D[np.ix_(keep, keep)], F[keep])

        if keep.size < FREE_MODAL_FROM or point.xi:
            return direct()
        cache = self.__dict__.setdefault("_free_modes", {})
        lin = self.hb.linear
        mats = (lin.K[k], lin.mass(point)[k], lin.C[k])
        key = (*(id(A) for A in mats), keep.size)  # orders with the same matrices share
        if key not in cache:
            if len(cache) >= len(self.hb.harmonics.orders):
                cache.clear()  # (another mass multiplier: the last one's modes kept)
            ix = np.ix_(keep, keep)
            try:
                cache[key] = diagonal_modes(*(A[ix] for A in mats))
            except (ValueError, np.linalg.LinAlgError):
                cache[key] = None
        if cache[key] is None:
            return direct()
        lam, phi, c = cache[key]
        w = order * point.omega
        return phi @ ((phi.conj().T @ F[keep]) / (lam - w * w + 1j * w * c))

    def linear_frequencies(self, point: OperatingPoint, order: int, springs: str = "stuck",
                           count: int = 10) -> np.ndarray:
        """(count,) the lowest natural frequencies [Hz] of a linear limit (``springs`` as
        ``linear_outputs``: every contact stuck, or the cyclic bodies alone) on harmonic
        ``order``'s reduced matrices (its nodal diameter), undamped, at the point's mass
        multiplier; a harmonic of frequency f there is excited at w = 2 pi f / order."""
        if springs not in ("stuck", "free"):
            raise ValueError(f"springs = {springs!r}: expected 'stuck' or 'free'")
        hb = self.hb
        k = list(hb.harmonics.orders).index(order)
        n_dof = hb.linear.n_dof
        K, M = hb.linear.K[k].copy(), hb.linear.mass(point)[k]
        if springs == "free":
            keep = self._cyclic_indices(k)
            K, M = K[np.ix_(keep, keep)], M[np.ix_(keep, keep)]
        else:
            K[:n_dof, :n_dof] += self._spring_stiffness(order, springs)
        lam = sla.eigh(0.5 * (K + K.conj().T), 0.5 * (M + M.conj().T), eigvals_only=True)
        return np.sqrt(np.clip(lam[:count], 0.0, None)) / (2 * np.pi)

    def _spring_stiffness(self, order: int, springs: str) -> np.ndarray:
        """(n_dof, n_dof) sum B^H k B over every contact at harmonic ``order``: its stick
        springs (kt, kn; ``springs = "stuck"``) or its normal springs alone ("normal")."""
        n_dof = self.hb.linear.n_dof
        out = np.zeros((n_dof, n_dof))  # (complex where a contact's kinematics is)
        for c in self.hb.contacts:
            el = c.elements
            B = np.asarray(c.kinematics[order]).reshape(-1, n_dof)
            k_c = np.zeros((el.size, el.n_components))
            if springs == "stuck":
                k_c[:, : el.dim] = el.kt
            k_c[:, -1] = el.kn
            out = out + B.conj().T @ (k_c.reshape(-1, 1) * B)
        return out

    def _cyclic_indices(self, k: int) -> np.ndarray:
        """Order k's positions of the disk's coordinates (masters and modes)."""
        keep = [idx for b, idx in body_positions(self.layout, k, self.hb.linear.n_dof)
                if b.disk]
        return np.concatenate(keep) if keep else np.zeros(0, dtype=int)
