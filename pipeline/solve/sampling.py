"""Sampled uncertainty studies: the design of the samples and the statistics of what they give.

A parameter is uncertain with a distribution (:class:`Distribution`: uniform, normal,
lognormal) or held at a value. The uncertain ones span a seeded low-discrepancy design on
the unit cube (SciPy's ``qmc``: scrambled Sobol', whose first n points are the same for any
longer run of the same seed, or Latin hypercube), mapped through each distribution's inverse
CDF. The statistics of a sampled quantity are its percentiles, the probability that it
exceeds a limit (with its binomial standard error) and, per parameter, the Spearman rank
correlation and the partial rank correlation coefficient (PRCC: the rank correlation left
when the other parameters' ranks are regressed out; Marino et al., J. Theor. Biol. 254,
2008), both robust to monotone non-linear dependence.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats
from scipy.stats import qmc

#: The families of distributions and the keys of each.
FAMILIES = {"uniform": "[low, high]", "normal": "{mean, sigma}",
            "lognormal": "{median, sigma} (sigma of the logarithm)"}
DESIGNS = ("sobol", "lhs")
#: The percentiles a study reports [%].
PERCENTILES = (5.0, 50.0, 95.0)


@dataclass(frozen=True)
class Distribution:
    """One uncertain parameter: ``family`` (FAMILIES) and its two numbers (uniform: low,
    high; normal: mean, sigma; lognormal: median, sigma of the logarithm)."""

    family: str
    a: float
    b: float

    def quantile(self, u: np.ndarray) -> np.ndarray:
        """The values at probabilities ``u`` in (0, 1) (the inverse CDF)."""
        if self.family == "uniform":
            return self.a + u * (self.b - self.a)
        z = stats.norm.ppf(u)
        if self.family == "normal":
            return self.a + self.b * z
        return self.a * np.exp(self.b * z)

    @property
    def median(self) -> float:
        return float(self.quantile(np.array(0.5)))


def design(distributions: list[Distribution], n: int, kind: str = "sobol", seed: int = 0
           ) -> np.ndarray:
    """(n, len(distributions)) samples: the seeded ``kind`` design on the unit cube through
    each distribution's quantile."""
    d = len(distributions)
    if kind == "sobol":
        # scrambled: no point on the cube's faces (whose normal or lognormal quantile is
        # infinite), and an unbiased estimate
        u = qmc.Sobol(d, scramble=True, rng=np.random.default_rng(seed)).random(n)
    elif kind == "lhs":
        u = qmc.LatinHypercube(d, rng=np.random.default_rng(seed)).random(n)
    else:
        raise ValueError(f"design = {kind!r}: expected one of {list(DESIGNS)}")
    return np.column_stack([dist.quantile(u[:, j]) for j, dist in enumerate(distributions)])


@dataclass(frozen=True)
class Statistics:
    """Of n samples of a quantity y over p parameters: ``percentiles`` (PERCENTILES),
    ``mean``, ``std``; ``exceedance`` P(y > limit) and its binomial standard error
    (NaN without a limit); per parameter ``spearman`` and ``prcc`` (NaN where a parameter
    or y does not vary)."""

    percentiles: np.ndarray
    mean: float
    std: float
    exceedance: float
    exceedance_error: float
    spearman: np.ndarray
    prcc: np.ndarray
    count: int


def statistics(x: np.ndarray, y: np.ndarray, limit: float | None = None) -> Statistics:
    """The statistics of ``y`` (n,) sampled at ``x`` (n, p); samples where y is NaN (not
    solved) are left out."""
    ok = np.isfinite(y)
    x, y = x[ok], y[ok]
    n = y.size
    if n == 0:
        nan = np.full(x.shape[1], np.nan)
        return Statistics(np.full(len(PERCENTILES), np.nan), np.nan, np.nan, np.nan, np.nan,
                          nan, nan, 0)
    p, error = exceedance(y, limit)
    return Statistics(np.percentile(y, PERCENTILES), float(np.mean(y)),
                      float(np.std(y, ddof=1)) if n > 1 else 0.0, p, error,
                      rank_correlation(x, y), partial_rank_correlation(x, y), n)


def exceedance(y: np.ndarray, limit: float | None) -> tuple[float, float]:
    """(P(y > limit), its binomial standard error sqrt(p (1 - p) / n)) over the n finite
    values of ``y`` (NaN, NaN without a limit or a value)."""
    y = y[np.isfinite(y)]
    if limit is None or not y.size:
        return np.nan, np.nan
    p = float(np.mean(y > limit))
    return p, float(np.sqrt(p * (1 - p) / y.size))


def exceedance_text(p: float, error: float, n: int) -> str:
    """An exceedance probability for the terminal: "= p +- error", or where none (or
    every one) of the n values exceeded, where the standard error says nothing, the
    count and the exact one-sided 95 % bound 1 - 0.05^(1/n) (Clopper-Pearson; the rule of
    three's 3 / n for large n, which reaches 1 at n = 3)."""
    if not n or not np.isfinite(p):
        return "= n/a (no value)"
    if p in (0.0, 1.0):
        bound = 1.0 - 0.05 ** (1.0 / n)
        side = f"< {bound:.3g}" if p == 0 else f"> {1 - bound:.3g}"
        return f"= {p:g} ({int(p * n)} of {n}; {side} at 95 %)"
    return f"= {p:.3f} +- {error:.3f}"


#: a peak within this share of the window's span of either end is the window's end: the
#: sweep's largest point there is where the range stops, not a resonance
EDGE_SHARE = 1e-3


def at_window_edge(omega: np.ndarray, window: tuple[float, float]) -> np.ndarray:
    """(n,) bool: the peak frequencies ``omega`` (NaN: False) at or beyond an end of
    ``window`` (a branch may fold past it)."""
    lo, hi = window
    tol = EDGE_SHARE * (hi - lo)
    omega = np.asarray(omega, dtype=float)
    with np.errstate(invalid="ignore"):
        return (omega <= lo + tol) | (omega >= hi - tol)


def window_edge_text(omega: np.ndarray, window: tuple[float, float], what: list[str]
                     ) -> str:
    """"" where no peak of ``omega`` (NaN: a sample left out of the statistics) sits at an
    end of ``window``; else a line naming the count among the finite ones, the first few
    of ``what`` (each peak's name) and what to do: such a peak is where the window stops, a
    lower bound of its resonance's."""
    edge = np.flatnonzero(at_window_edge(omega, window))
    if not edge.size:
        return ""
    named = ", ".join(f"{what[i]} ({omega[i]:.6g} rad/s)" for i in edge[:3])
    more = f" and {edge.size - 3} more" if edge.size > 3 else ""
    return (f"{edge.size} of {int(np.isfinite(omega).sum())} peaks at an end of the window "
            f"[{window[0]:g}, {window[1]:g}] rad/s: {named}{more}; each is a lower bound "
            "of its resonance's: widen the window")


def _ranks(a: np.ndarray) -> np.ndarray:
    return stats.rankdata(a, axis=0)


def _correlation(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a - a.mean(), b - b.mean()
    den = np.sqrt((a @ a) * (b @ b))
    return float(a @ b / den) if den > 0 else np.nan


def rank_correlation(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(p,) Spearman's rank correlation of each column of ``x`` (n, p) with ``y`` (n,)."""
    rx, ry = _ranks(x), _ranks(y)
    return np.array([_correlation(rx[:, j], ry) for j in range(x.shape[1])])


def partial_rank_correlation(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(p,) PRCC of each column of ``x`` with ``y``: the correlation of the residuals of
    its ranks and of y's ranks after a least-squares fit on the other columns' ranks (and
    a constant). NaN for a column that does not vary, or with fewer samples than p + 2."""
    n, p = x.shape
    rx, ry = _ranks(x), _ranks(y)
    out = np.full(p, np.nan)
    varies = np.ptp(x, axis=0) > 0
    if n < p + 2:
        return out
    for j in np.flatnonzero(varies):
        others = np.column_stack([np.ones(n), rx[:, [k for k in range(p) if k != j and
                                                    varies[k]]]])
        fit = np.linalg.lstsq(others, np.column_stack([rx[:, j], ry]), rcond=None)[0]
        res = np.column_stack([rx[:, j], ry]) - others @ fit
        out[j] = _correlation(res[:, 0], res[:, 1])
    return out
