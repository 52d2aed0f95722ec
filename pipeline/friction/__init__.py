"""Friction contact laws in the frequency domain.

harmonics    the real coefficient layout, time samples and DFT of the harmonic balance
laws         contact laws A-D (1D/2D, constant/variable normal load, coupled or not):
             forces, exact Jacobians, states and dissipation per point
returnmap    the compiled (numba) return map over the sampled period (point, cycle, steps,
             kinks); kernels_cached and
             warm_up tell whether a first run compiles it (cached on disk after)
"""

from .returnmap import kernels_cached, warm_up

__all__ = ["kernels_cached", "warm_up"]
