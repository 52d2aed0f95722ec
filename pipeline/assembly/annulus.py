"""The whole annulus of a cyclic structure from its sector's reductions at every nodal
diameter, tuned or mistuned blade by blade, in real coordinates.

A sector reduced at nodal diameter (ND) h has coordinates q_h = [u_h; eta_h]: master
coordinates u_h (the same physical DOFs at every h, e.g. contact nodes' x, y, z) and modal
coordinates eta_h of its own, with complex Hermitian K_h, M_h (real at h = 0 and h = N/2;
ND N - h is ND h's complex conjugate). Sector s of the annulus carries exp(i h s phi)
R(s phi) (Firrone & Zucca 5.1.1). With the unitary discrete Fourier transform over the
sectors the annulus' motion is

    x_s = R(s phi) sum_h exp(i h s phi) P_h q_h / sqrt(N),     h = 0 .. N-1

and its energy the sum over h of q_h^H K_h q_h: the tuned annulus is block diagonal in h.
Its coordinates here are real: every sector's masters in the global frame (sector-major),
then per ND its modal coordinates (h = 0 and N/2 as they are, real; 0 < h < N/2 as the
real and imaginary parts a, b of sqrt(2) eta_h, eta_{N-h} = conj(eta_h)), so that a real
motion has real coordinates and the matrices are real symmetric.

Blade-to-blade mistuning (a stiffness deviation delta_s of a region of each sector, its
blade) adds sum_s delta_s E_s, E_s the region's strain energy in annulus coordinates: the
region's stiffness K_b (fundamental sector) projected on its motion in sector s,
x_b,s = sum_h exp(i h s phi) W_h q_h / sqrt(N) (W_h: the rows of the region's DOFs of the
ND-h basis). E_s is E_0 seen from sector s: E_s = S_s^T E_0 S_s with S_s the turn of the
annulus by s sectors, so E_0 alone is formed. Exact within the tuned reduction basis (the
mistuned motion is sought in the span of every ND's tuned basis: a subset-of-nominal-modes
method with the reduction's masters kept).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from microslip.geometry.mesh import rotation_z


@dataclass(frozen=True, eq=False)
class SectorND:
    """One sector reduced at one nodal diameter: stiffness and mass (n, n) complex
    Hermitian (real at ND 0 and N/2) over [masters (the annulus' shared n_master
    coordinates); modal coordinates]; ``region``: (n_b, n) the rows of the mistuned
    region's DOFs (fundamental sector's frame) of the basis, or None."""

    stiffness: np.ndarray
    mass: np.ndarray
    region: np.ndarray | None = None


def _pair_transform(m: int) -> np.ndarray:
    """(2m, 2m) complex Q: [eta_h; eta_{N-h}] = Q [a; b], eta_h = (a + i b) / sqrt(2)."""
    eye = np.eye(m)
    return np.block([[eye, 1j * eye], [eye, -1j * eye]]) / np.sqrt(2.0)


def as_real(A: np.ndarray, what: str) -> np.ndarray:
    """The real part of an annulus quantity whose imaginary part the conjugate ND pairs
    cancel (ValueError where they do not: reductions that are not each other's
    conjugates)."""
    A = np.asarray(A)
    scale = max(float(np.abs(A).max()), 1e-300) if A.size else 1.0
    imag = float(np.abs(A.imag).max()) / scale if A.size else 0.0
    if imag > 1e-10:
        raise ValueError(f"annulus: the {what} is not real ({imag:.1e} of its size): the "
                         "reductions are not conjugate-consistent")
    return np.ascontiguousarray(A.real)


@dataclass(frozen=True, eq=False)
class Annulus:
    """The annulus of ``sectors`` sectors from its sector's reductions ``nd`` (ND 0 ..
    N // 2). ``n_master``: the master coordinates each sector shares across its NDs, the
    first of every ND's coordinates; ``triples``: they are x, y, z triples in the global
    frame (turned by R(s phi) in sector s), else scalars along the axis of symmetry or
    a sector's own direction (a lumped model).

    Coordinates (``n``): N n_master masters (sector s at s n_master...), then per ND
    0 .. N // 2 its modal coordinates (``modal_slices``; 0 < h < N/2: [a; b])."""

    sectors: int
    nd: Mapping[int, SectorND]
    n_master: int
    triples: bool = True

    def __post_init__(self) -> None:
        N = self.sectors
        if sorted(self.nd) != list(range(N // 2 + 1)):
            raise ValueError(f"annulus: reductions at ND {sorted(self.nd)}; every ND 0.."
                             f"{N // 2} is needed for {N} sectors")
        if self.triples and self.n_master % 3:
            raise ValueError(f"annulus: {self.n_master} master coordinates are not x, y, z "
                             "triples")
        for h, s in self.nd.items():
            if s.stiffness.shape != s.mass.shape or s.stiffness.shape[0] < self.n_master:
                raise ValueError(f"annulus: ND {h}: stiffness {s.stiffness.shape} and mass "
                                 f"{s.mass.shape} over at least {self.n_master} masters")

    # ------------------------------------------------------------------ layout
    @property
    def phi(self) -> float:
        return 2.0 * np.pi / self.sectors

    def n_modes(self, h: int) -> int:
        """Modal coordinates of ND h's reduction."""
        return self.nd[h].stiffness.shape[0] - self.n_master

    @cached_property
    def modal_slices(self) -> dict[int, slice]:
        """ND h (0 .. N // 2) -> its modal coordinates in the annulus ([a; b] for a
        travelling pair)."""
        out, at = {}, self.sectors * self.n_master
        for h in range(self.sectors // 2 + 1):
            width = self.n_modes(h) * (1 if self.standing(h) else 2)
            out[h] = slice(at, at + width)
            at += width
        return out

    @property
    def n(self) -> int:
        return self.modal_slices[self.sectors // 2].stop

    def standing(self, h: int) -> bool:
        """Whether ND h's waves stand (h = 0, N/2: real matrices, its coordinates real)."""
        return h == 0 or 2 * h == self.sectors

    def _turn(self, s: int) -> np.ndarray:
        """(n_master, n_master) R(s phi) on every triple (the identity for scalars)."""
        if not self.triples:
            return np.eye(self.n_master)
        return np.kron(np.eye(self.n_master // 3), rotation_z(s * self.phi))

    # ------------------------------------------------------------ the transform
    def to_nd(self, h: int) -> np.ndarray:
        """(n_h, n) complex: ND h's coordinates q_h (h = 0 .. N-1) from the annulus'."""
        return self._transforms[h]

    @cached_property
    def _transforms(self) -> list[np.ndarray]:
        """Every ND's :meth:`to_nd`, formed once (the matrices, the region's motion and
        each wave read them)."""
        return [self._to_nd(h) for h in range(self.sectors)]

    def _to_nd(self, h: int) -> np.ndarray:
        N, nm, phi = self.sectors, self.n_master, self.phi
        g = h if 2 * h <= N else N - h  # the reduction it conjugates
        T = np.zeros((nm + self.n_modes(g), self.n), dtype=complex)
        for s in range(N):  # u_h = sum_s exp(-i h s phi) R(s phi)^T x_s / sqrt(N)
            T[:nm, s * nm:(s + 1) * nm] = np.exp(-1j * h * s * phi) * self._turn(s).T
        T[:nm] /= np.sqrt(N)
        m, cols = self.n_modes(g), self.modal_slices[g]
        if self.standing(g):
            T[nm:, cols] = np.eye(m)
        else:  # eta_h = (a + i b) / sqrt 2, eta_{N-h} its conjugate
            sign = 1.0 if h == g else -1.0
            T[nm:, cols] = np.hstack([np.eye(m), sign * 1j * np.eye(m)]) / np.sqrt(2.0)
        return T

    def _nd_matrix(self, h: int, which: str) -> np.ndarray:
        g = h if 2 * h <= self.sectors else self.sectors - h
        A = getattr(self.nd[g], which)
        return A if h == g else A.conj()

    def _assembled(self, which: str) -> np.ndarray:
        out = np.zeros((self.n, self.n), dtype=complex)
        for h in range(self.sectors):
            T = self.to_nd(h)
            out += T.conj().T @ self._nd_matrix(h, which) @ T
        return as_real(0.5 * (out + out.conj().T), which)

    @cached_property
    def stiffness(self) -> np.ndarray:
        """(n, n) the tuned annulus' stiffness (real symmetric)."""
        return self._assembled("stiffness")

    @cached_property
    def mass(self) -> np.ndarray:
        """(n, n) the annulus' mass (real symmetric; mistuning leaves it)."""
        return self._assembled("mass")

    # ---------------------------------------------------------------- motions
    def motion(self, z: np.ndarray) -> dict[int, np.ndarray]:
        """ND h (0 .. N-1) -> its coordinates q_h of the annulus motion ``z`` (n,)."""
        return {h: self.to_nd(h) @ z for h in range(self.sectors)}

    def travelling(self, h: int, q: np.ndarray) -> np.ndarray:
        """(n,) complex: the annulus coordinates of the travelling wave of ND h (0 .. N-1)
        whose fundamental sector carries q (the sector model's own coordinates): sector s
        exp(i h s phi) R(s phi) q. Its real part (times exp(i w t)) is a real motion."""
        T = self.to_nd(h)
        # T is a co-isometry onto ND h: T T^H = I, and the wave is T^H q sqrt(N)
        return np.sqrt(self.sectors) * (T.conj().T @ q)

    def masters_of(self, z: np.ndarray, s: int) -> np.ndarray:
        """(n_master,) sector s's master coordinates (global frame) of ``z``."""
        return z[s * self.n_master:(s + 1) * self.n_master]

    # ------------------------------------------------------------- mistuning
    def shift(self, s: int) -> np.ndarray:
        """(n, n) real orthogonal S_s: the coordinates of a motion turned back by s
        sectors (sector s's motion seen in sector 0): masters x'_t = R(-s phi) x_{t+s},
        modal eta'_h = exp(i h s phi) eta_h."""
        return self._shift_columns(np.eye(self.n), s)

    def region_motion(self, s: int = 0) -> np.ndarray:
        """(n_b, n) real: the mistuned region's displacement in sector s (its own frame)
        from the annulus coordinates."""
        N, phi = self.sectors, self.phi
        out = np.zeros((self._region(0).shape[0], self.n), dtype=complex)
        for h in range(N):
            g = h if 2 * h <= N else N - h
            W = self._region(g) if h == g else self._region(g).conj()
            out += np.exp(1j * h * s * phi) * (W @ self.to_nd(h))
        return as_real(out / np.sqrt(N), "region's motion")

    def _region(self, h: int) -> np.ndarray:
        W = self.nd[h].region
        if W is None:
            raise ValueError(f"annulus: ND {h}'s reduction has no mistuned region's rows")
        return W

    def region_energy(self, region_stiffness: np.ndarray) -> np.ndarray:
        """(n, n) E_0: the strain energy of sector 0's region (``region_stiffness``:
        (n_b, n_b) [N/m], dense or sparse, its stiffness) in annulus coordinates."""
        B = self.region_motion(0)
        E = B.T @ np.asarray(region_stiffness @ B)
        return 0.5 * (E + E.T)

    def mistuned_stiffness(self, deviation: Sequence[float],
                           region_energy: np.ndarray) -> np.ndarray:
        """(n, n): the annulus' stiffness with sector s's region stiffer by deviation[s]
        (a fraction: 0.02 = 2 % stiffer), ``region_energy`` E_0
        (:meth:`region_energy`)."""
        delta = np.asarray(deviation, dtype=float)
        if delta.shape != (self.sectors,):
            raise ValueError(f"annulus: {delta.size} deviations for {self.sectors} sectors")
        K = self.stiffness.copy()
        for s in np.flatnonzero(delta):
            K += delta[s] * self.turned(region_energy, int(s))
        return K

    def turned(self, A: np.ndarray, s: int) -> np.ndarray:
        """(n, n) S_s^T A S_s (:meth:`shift`) in O(n^2): S_s only moves sector blocks
        (turning their triples) and turns each ND's [a; b] pairs, so it is applied to
        the columns and then the rows, never formed."""
        return self._shift_columns(self._shift_columns(A, s).T, s).T

    def _shift_columns(self, A: np.ndarray, s: int) -> np.ndarray:
        """A S_s for A (k, n)."""
        N, nm, phi = self.sectors, self.n_master, self.phi
        out = np.empty_like(A)
        for t in range(N):  # S's block (t, t + s) is R(-s phi) on every triple
            src = (t + s) % N
            block = A[:, t * nm:(t + 1) * nm]
            if self.triples:
                block = (block.reshape(len(A), nm // 3, 3) @ rotation_z(-s * phi)
                         ).reshape(len(A), nm)
            out[:, src * nm:(src + 1) * nm] = block
        for h, cols in self.modal_slices.items():
            c, sn = np.cos(h * s * phi), np.sin(h * s * phi)
            if self.standing(h):
                out[:, cols] = c * A[:, cols]
                continue
            m = self.n_modes(h)
            a, b = A[:, cols.start:cols.start + m], A[:, cols.start + m:cols.stop]
            out[:, cols.start:cols.start + m] = c * a + sn * b
            out[:, cols.start + m:cols.stop] = c * b - sn * a
        return out
