"""Confidence intervals of a study's summaries: Wilson's for rates, Student-t's for means,
distribution-free ones for medians (cosim.study.summary, cosim.study.fleet_summary)."""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np

CONFIDENCE = 0.95  # -, the intervals' coverage


def wilson(successes: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (NaNs for n = 0)."""
    if n == 0:
        return (math.nan, math.nan)
    z = NormalDist().inv_cdf(0.5 + confidence / 2)
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    # exact at the ends (0 successes: from 0; all: up to 1), whatever the rounding
    low = 0.0 if successes == 0 else max(0.0, centre - half)
    high = 1.0 if successes == n else min(1.0, centre + half)
    return (low, high)


def mean_ci(values: np.ndarray, confidence: float = CONFIDENCE) -> tuple[float, float, float]:
    """Mean and Student-t confidence interval (NaN where undefined). For quantities
    that may take either sign; positive ones (durations, TTC) use `median_ci`."""
    values = values[np.isfinite(values)]
    n = len(values)
    if n == 0:
        return (math.nan, math.nan, math.nan)
    mean = float(values.mean())
    if n == 1:
        return (mean, math.nan, math.nan)
    from scipy import stats

    half = float(stats.t.ppf(0.5 + confidence / 2, n - 1) * values.std(ddof=1) / math.sqrt(n))
    return (mean, mean - half, mean + half)


def median_ci(values: np.ndarray, confidence: float = CONFIDENCE
              ) -> tuple[float, float, float, float]:
    """Median, a distribution-free confidence interval for it and that interval's
    coverage: the order statistics (x_(j), x_(n+1-j)) with the largest j whose
    binomial coverage is at least `confidence`. The bounds are observed values, so
    a positive quantity (a duration, a TTC) never gets a negative bound, and a
    skewed one an honest asymmetric interval. Below 6 values no pair reaches 95 %:
    the interval is then the range, and its coverage (1 - 2 / 2^n) says so.
    NaN where undefined (no finite value; one value: no interval)."""
    x = np.sort(values[np.isfinite(values)])
    n = len(x)
    if n == 0:
        return (math.nan, math.nan, math.nan, math.nan)
    median = float(np.median(x))
    if n == 1:
        return (median, math.nan, math.nan, math.nan)
    from scipy import stats

    # coverage of (x_(j), x_(n+1-j)): P(j <= B < n+1-j), B ~ Binomial(n, 1/2)
    j = np.arange(1, n // 2 + 1)
    coverage = stats.binom.cdf(n - j, n, 0.5) - stats.binom.cdf(j - 1, n, 0.5)
    ok = np.flatnonzero(coverage >= confidence)
    k = int(ok[-1]) if ok.size else 0
    return (median, float(x[j[k] - 1]), float(x[n - j[k]]), float(coverage[k]))
