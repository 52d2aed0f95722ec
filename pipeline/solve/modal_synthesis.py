"""The forced response synthesized from one nonlinear mode (single nonlinear mode theory:
Szemplinska-Stupnicka; Krack 2015, eq. 17).

Near the mode's resonance the response to the excitation ``e F_1 cos(Omega t)`` (the
model's excitation at multiplier e) is the mode's motion at the level a whose amplitude
balances the excitation's modal force ``phi(a) = psi_1(a)^H F_1``:

    | omega(a)^2 - Omega^2 + i Omega xi(a) | a = e | phi(a) |.

So the FRF at any excitation level is the backbone read at two frequencies per level,

    Omega^2 = omega^2 - xi^2 / 2 +- sqrt((e |phi| / a)^2 - xi^2 (omega^2 - xi^2 / 4)),

and its resonance peak sits at the level where ``e = a xi sqrt(omega^2 - xi^2 / 4) /
|phi|``, at ``Omega = sqrt(omega^2 - xi^2 / 2)``: one backbone gives the peak at every
excitation level (Firrone & Zucca Fig. 6) and, one per design, the peak against a design
parameter (Fig. 22). The motion there is the mode's, the responses its harmonics.
Valid where the mode dominates the response (well separated, lightly damped modes); the
response's phase to the excitation: ``exp(i theta) = e phi / (a (omega^2 - Omega^2 + i
Omega xi))`` on the fundamental, ``exp(i n theta)`` on harmonic n.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .nonlinear_modes import Backbone, ModalBalance
from .response import solve_point


@dataclass(frozen=True)
class Synthesis:
    """A backbone's levels with the modal force of an excitation (m levels).

    amplitude: (m,) modal amplitude a; omega, xi: (m,) [rad/s], [1/s]; modal_force: (m,)
    complex phi = psi_1^H F_1 at unit excitation multiplier [N kg^-1/2]."""

    amplitude: np.ndarray
    omega: np.ndarray
    xi: np.ndarray
    modal_force: np.ndarray

    @property
    def peak_excitation(self) -> np.ndarray:
        """(m,) the excitation multiplier whose resonance peak is at each level."""
        return (self.amplitude * self.xi * np.sqrt(self.omega**2 - self.xi**2 / 4.0)
                / np.abs(self.modal_force))

    @property
    def peak_frequency(self) -> np.ndarray:
        """(m,) the resonance frequency at each level [rad/s]."""
        return np.sqrt(self.omega**2 - self.xi**2 / 2.0)

    def frequencies(self, excitation: float) -> tuple[np.ndarray, np.ndarray]:
        """(m,) the two frequencies [rad/s] at which each level is the response to the
        excitation multiplier (below and above the resonance; NaN where the level is not
        reached)."""
        w2, xi = self.omega**2, self.xi
        disc = (excitation * np.abs(self.modal_force) / self.amplitude) ** 2 \
            - xi**2 * (w2 - xi**2 / 4.0)
        root = np.sqrt(np.where(disc >= 0.0, disc, np.nan))
        low = w2 - xi**2 / 2.0 - root
        return np.sqrt(np.where(low > 0.0, low, np.nan)), np.sqrt(w2 - xi**2 / 2.0 + root)

    def peak_level(self, excitation: float) -> int | None:
        """Where the resonance peak at this excitation multiplier is: i, the level between
        backbone points i and i + 1 (the first crossing from the lowest level: the main
        branch), or None when the backbone's range does not reach it."""
        below = self.peak_excitation <= excitation
        crossing = np.flatnonzero(below[:-1] & ~below[1:])
        return int(crossing[0]) if len(crossing) else None


def synthesis(modal: ModalBalance, mode: Backbone) -> Synthesis:
    """The modal force of ``modal``'s model's excitation at every level of ``mode``."""
    phi = np.array([modal.modal_force(x, w, xi, a) for x, w, xi, a in
                    zip(mode.x, mode.omega, mode.xi, mode.amplitude)], dtype=complex)
    return Synthesis(mode.amplitude, mode.omega, mode.xi, phi)


@dataclass(frozen=True)
class Peak:
    """The resonance peak at one excitation multiplier, synthesized from a mode: its level
    (modal amplitude a), frequency [rad/s], the mode's unknowns x there (the motion's
    harmonics, phase as the mode's), omega, xi of the level and its modal force phi."""

    excitation: float
    amplitude: float
    frequency: float
    x: np.ndarray
    omega: float
    xi: float
    modal_force: complex


def peak(modal: ModalBalance, mode: Backbone, syn: Synthesis, excitation: float,
         xtol: float = 1e-12, max_iter: int = 60) -> Peak | None:
    """The resonance peak at this excitation multiplier: the level where the synthesized
    peak excitation equals it, by Brent's method in log a between the two backbone levels
    that bracket it (each trial a Newton solve of the mode at that level; the peak
    excitation is only piecewise smooth where contacts change state, which an unbracketed
    secant can leave); None out of range or where a trial level has no solution."""
    from scipy.optimize import brentq

    i = syn.peak_level(excitation)
    if i is None:
        return None
    ends = {float(np.log(mode.amplitude[k])): float(np.log(syn.peak_excitation[k]
                                                           / excitation)) for k in (i, i + 1)}
    levels: dict[float, tuple[Peak, float]] = {}

    def level(lc: float) -> tuple[Peak, float]:
        """The peak candidate at level exp(lc) and log(its peak excitation / excitation)."""
        if lc not in levels:
            # Newton can cycle between two linear pieces where a level sits on a stick/slip
            # kink: then the level a little off it (SHIFT of the bracket) stands in
            for shift in (0.0, SHIFT, -SHIFT):
                a = float(np.exp(lc + shift * (lb - la)))
                solved = mode.at(a)
                if solved is not None:
                    break
            else:
                raise _NoLevel
            x, w, xi = solved
            phi = modal.modal_force(x, w, xi, a)
            one = Synthesis(np.array([a]), np.array([w]), np.array([xi]), np.array([phi]))
            levels[lc] = (Peak(excitation, a, float(one.peak_frequency[0]), x, w, xi, phi),
                          float(np.log(one.peak_excitation[0] / excitation)))
        return levels[lc]

    la, lb = sorted(ends)
    try:
        lc = brentq(lambda v: ends[v] if v in ends else level(v)[1], la, lb, xtol=xtol,
                    rtol=4 * np.finfo(float).eps, maxiter=max_iter)
        return level(lc)[0]
    except (_NoLevel, RuntimeError):
        return None


#: Where Newton fails at a trial level of the peak search, the level this share of the
#: bracket off it is tried instead: the peak excitation there differs by its slope times
#: that (~1e-5 on 15_blisk_damper's brackets), far below the synthesis' own error.
SHIFT = 1e-3


class _NoLevel(Exception):
    """A trial level of the peak search where the mode has no solution."""


def forced_check(modal: ModalBalance, p: Peak) -> np.ndarray | None:
    """The forced balance solved directly at the synthesized peak's frequency and
    excitation, from the mode's motion moved to the phase the excitation gives it (one
    Newton solve): its unknowns, or None where Newton fails. Where the mode dominates the
    response it is the synthesized motion; how far apart they are says how far the
    synthesis can be trusted there."""
    model, Om = modal.model, p.frequency
    theta = float(np.angle(p.excitation * p.modal_force
                           / (p.omega**2 - Om**2 + 1j * Om * p.xi)))
    guess = shifted(model.harmonics, p.x, model.dofs.size, theta)
    r = solve_point(model, modal.forced(Om, p.excitation), x0=guess, retry=False,
                    explain=False)
    return r.x if r.converged else None


def shifted(model_harmonics, x: np.ndarray, n_dof: int, theta: float) -> np.ndarray:
    """The unknowns of a motion delayed by the phase theta of its fundamental: harmonic n
    times exp(i n theta) (a forced response's guess from the mode's motion)."""
    h = model_harmonics
    X = h.to_complex(x.reshape(n_dof, h.n_coeffs))
    return h.from_complex({o: v * np.exp(1j * o * theta) for o, v in X.items()},
                          (n_dof,)).ravel()
