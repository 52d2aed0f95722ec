"""Contact laws in the frequency domain: friction (laws A-D) and the benchmark springs.

interface    the contact-law interface (a law builds contact sets the harmonic balance
             evaluates: forces, exact Jacobian, stuck stiffness, preload response)
coulomb      friction laws A-D (1D/2D, constant/variable normal load, coupled or not):
             forces, exact Jacobians, states and dissipation per point
springs      the benchmark nonlinearities: polynomial and unilateral springs (AFT)
registry     LAWS, every contact law by the name a case gives
states       the contact states, per sample and per point over a period
returnmap    the compiled (numba) return map over the sampled period; kernels_cached and
             warm_up tell whether a first run compiles it (cached on disk after)
"""

from .returnmap import kernels_cached, warm_up

__all__ = ["kernels_cached", "warm_up"]
