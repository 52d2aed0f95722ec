"""Small teaching models of the reference text, built through the public API."""

from __future__ import annotations

import numpy as np

from microslip.app import plan
from microslip.fourier import Harmonics
from microslip.laws.coulomb import ContactElements
from microslip.solve.hbm import Contact, HarmonicBalance
from microslip.solve.linear import Excitation, LinearDynamics


def jenkins_oscillator(
    H: int = 7,
    n_samples: int = 256,
    *,
    m: float = 1.0,
    c: float = 0.02,
    k: float = 1.0,
    kt: float = 3.0,
    fs: float = 0.05,
    P: float = 0.1,
) -> HarmonicBalance:
    """A mass on a spring rubbing on a wall through a Jenkins element (law A,
    Firrone & Zucca Fig. 4): ``m x'' + c x' + k x + T = P cos(w t)``, slip force ``fs = mu N0``.

    Defaults are issue 2's benchmark: m = 1 kg, c = 0.02 N s/m, k = 1 N/m,
    kt = 3 N/m, mu N = 0.05 N, P = 0.1 N (peak near 1.841 m at 1.002 rad/s)."""
    h = Harmonics.up_to(H, n_samples)
    lin = LinearDynamics.create([[k]], [[m]], [[c]], harmonics=h)
    wall = ContactElements.create("A", kt=kt, mu=1.0, n0=fs)
    return HarmonicBalance(lin, [Contact("wall", wall, np.array([[1.0]]))],
                           Excitation.single(1, 0, P), h)


def jenkins_case(H: int = 7, n_samples: int = 256) -> dict:
    """:func:`jenkins_oscillator` with its defaults as a case table (one FRF over
    0.5..2.5 rad/s, as ``microslip demo`` sweeps it): what ``case.estimate`` sizes and
    times before the demo runs."""
    # the dry run's reference workload is this oscillator too (at H = 3, 64 samples)
    return plan.REFERENCE | {
        "title": "Jenkins oscillator", "harmonics": {"max": H, "samples": n_samples},
        "analysis": [{"name": "demo", "type": "frf", "start": 0.5, "stop": 2.5,
                      "stability": False}]}
