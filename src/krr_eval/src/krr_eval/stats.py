"""Statistics of the evaluation: means with t-based confidence intervals, Welch and paired
t-tests, paired differences, the trial count a confidence interval of a given width needs,
proportion intervals and tests (Wilson, two-proportion z, McNemar), rank tests, empirical CDFs.

Every function takes plain sequences of numbers (lists, tuples, numpy arrays) and returns
plain Python floats / named tuples, so results can be written to JSON and CSV directly.
Degenerate inputs (too few values, zero variance) give NaN or well-defined limits, never an
exception from deep inside scipy; wrong input (empty data, counts out of range) raises
ValueError naming the argument.
"""
import math
from collections import namedtuple

import numpy as np
from scipy import stats as _st

Estimate = namedtuple("Estimate", "mean half lo hi n")
Estimate.__doc__ = "A mean with the half-width and bounds of its confidence interval."
TestResult = namedtuple("TestResult", "statistic df p")
TestResult.__doc__ = ("A test statistic, its degrees of freedom (NaN if not applicable), "
                      "two-sided p.")
Cdf = namedtuple("Cdf", "x y")
Cdf.__doc__ = "Empirical CDF: sorted values x and the fraction of values <= x at each."


def _array(values, name="values"):
    a = np.asarray(values, dtype=float).ravel()
    if a.size == 0:
        raise ValueError("%s: no data" % name)
    if not np.all(np.isfinite(a)):
        raise ValueError("%s: contains NaN or infinite values" % name)
    return a


def mean(values):
    """Arithmetic mean."""
    return float(np.mean(_array(values)))


def std(values):
    """Sample standard deviation (n-1 denominator); 0 for a single value."""
    a = _array(values)
    return float(np.std(a, ddof=1)) if a.size > 1 else 0.0


def mean_ci(values, level=0.95):
    """Mean and Student-t confidence interval (half-width t_{(1+level)/2, n-1} * s / sqrt(n)).

    With a single value the half-width is NaN (no spread can be estimated).
    """
    if not 0 < level < 1:
        raise ValueError("level must be in (0, 1), got %r" % (level,))
    a = _array(values)
    m, n = float(np.mean(a)), int(a.size)
    if n < 2:
        half = float("nan")
    else:
        half = float(_st.t.ppf(0.5 + level / 2, n - 1) * np.std(a, ddof=1) / math.sqrt(n))
    return Estimate(m, half, m - half, m + half, n)


def _both_constant(a, b):
    return np.all(a == a[0]) and np.all(b == b[0])


def welch_t_test(a, b):
    """Welch's unequal-variance t-test of mean(a) == mean(b); two-sided p.

    If both samples are constant the test is decided exactly: p = 1 when the constants are
    equal, 0 otherwise (scipy would return NaN).
    """
    a, b = _array(a, "a"), _array(b, "b")
    if a.size < 2 or b.size < 2:
        raise ValueError("welch_t_test needs at least 2 values per sample (got %d and %d)"
                         % (a.size, b.size))
    if _both_constant(a, b):
        same = a[0] == b[0]
        return TestResult(0.0 if same else math.copysign(math.inf, a[0] - b[0]), float("nan"),
                          1.0 if same else 0.0)
    va, vb = np.var(a, ddof=1) / a.size, np.var(b, ddof=1) / b.size
    df = (va + vb) ** 2 / (va ** 2 / (a.size - 1) + vb ** 2 / (b.size - 1))
    r = _st.ttest_ind(a, b, equal_var=False)
    return TestResult(float(r.statistic), float(df), float(r.pvalue))


def paired_t_test(a, b):
    """Paired t-test of mean(a - b) == 0 (a[i] and b[i] from the same trial); two-sided p."""
    a, b = _array(a, "a"), _array(b, "b")
    if a.size != b.size:
        raise ValueError("paired_t_test: samples differ in length (%d vs %d)" % (a.size, b.size))
    d = a - b
    if d.size < 2:
        raise ValueError("paired_t_test needs at least 2 pairs")
    if np.all(d == d[0]):
        return TestResult(0.0 if d[0] == 0 else math.copysign(math.inf, d[0]), d.size - 1.0,
                          1.0 if d[0] == 0 else 0.0)
    r = _st.ttest_rel(a, b)
    return TestResult(float(r.statistic), float(d.size - 1), float(r.pvalue))


def paired_difference(a, b, level=0.95):
    """Mean of the paired differences a[i] - b[i] with its Student-t confidence interval and
    the paired t-test: (Estimate, TestResult). a[i] and b[i] come from the same trial."""
    a, b = _array(a, "a"), _array(b, "b")
    if a.size != b.size:
        raise ValueError("paired_difference: samples differ in length (%d vs %d)"
                         % (a.size, b.size))
    return mean_ci(a - b, level), paired_t_test(a, b)


def half_width(sd, n, level=0.95):
    """Half-width t_{(1+level)/2, n-1} * sd / sqrt(n) of the confidence interval of a mean
    (or of a mean paired difference) of n values with standard deviation sd."""
    if n < 2 or n != int(n):
        raise ValueError("half_width needs an integer n >= 2, got %r" % (n,))
    if sd < 0 or not math.isfinite(sd):
        raise ValueError("half_width: sd must be finite and >= 0, got %r" % (sd,))
    return float(_st.t.ppf(0.5 + level / 2, n - 1) * sd / math.sqrt(n))


def trials_for_half_width(sd, half, level=0.95):
    """The smallest n >= 2 with half_width(sd, n, level) <= half: how many (paired) trials a
    confidence interval of that half-width needs, given the standard deviation of one trial
    (of one paired difference). Starts from the normal approximation (z sd / half)^2 and
    steps up for the t quantile."""
    if not half > 0:
        raise ValueError("trials_for_half_width: half must be positive, got %r" % (half,))
    if sd < 0 or not math.isfinite(sd):
        raise ValueError("trials_for_half_width: sd must be finite and >= 0, got %r" % (sd,))
    z = float(_st.norm.ppf(0.5 + level / 2))
    n = max(2, int(math.ceil((z * sd / half) ** 2)))
    while half_width(sd, n, level) > half:  # t > z: a few more trials
        n += 1
    return n


def mann_whitney(a, b):
    """Mann-Whitney U test (two-sided, asymptotic with continuity correction) of a vs b.

    Returns U of sample a; p = 1 if every value of both samples is equal.
    """
    a, b = _array(a, "a"), _array(b, "b")
    if _both_constant(a, b) and a[0] == b[0]:
        return TestResult(a.size * b.size / 2.0, float("nan"), 1.0)
    r = _st.mannwhitneyu(a, b, alternative="two-sided", method="asymptotic")
    return TestResult(float(r.statistic), float("nan"), float(r.pvalue))


def _check_count(k, n, what):
    if n != int(n) or k != int(k) or n < 1 or not 0 <= k <= n:
        raise ValueError("%s: need integers 0 <= successes <= trials, trials >= 1 (got %r of %r)"
                         % (what, k, n))


def proportion_ci(successes, trials, level=0.95):
    """Proportion with its Wilson score interval (well-behaved at 0 and 1, unlike Wald's)."""
    _check_count(successes, trials, "proportion_ci")
    z = float(_st.norm.ppf(0.5 + level / 2))
    n, p = float(trials), successes / float(trials)
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return Estimate(p, half, max(0.0, centre - half), min(1.0, centre + half), int(trials))


def two_proportion_z_test(k1, n1, k2, n2):
    """Pooled two-proportion z-test of k1/n1 == k2/n2; two-sided p (normal approximation)."""
    _check_count(k1, n1, "two_proportion_z_test (first sample)")
    _check_count(k2, n2, "two_proportion_z_test (second sample)")
    p1, p2 = k1 / float(n1), k2 / float(n2)
    pooled = (k1 + k2) / float(n1 + n2)
    se = math.sqrt(pooled * (1 - pooled) * (1.0 / n1 + 1.0 / n2))
    if se == 0:
        return TestResult(0.0, float("nan"), 1.0)
    z = (p1 - p2) / se
    return TestResult(z, float("nan"), float(2 * _st.norm.sf(abs(z))))


def mcnemar_exact(only_a, only_b):
    """Exact McNemar test for paired binary outcomes.

    only_a: pairs where only the first condition succeeded; only_b: only the second.
    p = two-sided binomial test of only_a ~ Bin(only_a + only_b, 1/2); 1 if no discordant pair.
    """
    if only_a < 0 or only_b < 0 or only_a != int(only_a) or only_b != int(only_b):
        raise ValueError("mcnemar_exact: counts must be non-negative integers")
    n = int(only_a + only_b)
    if n == 0:
        return TestResult(0.0, float("nan"), 1.0)
    return TestResult(float(only_a), float("nan"),
                      float(_st.binomtest(int(only_a), n, 0.5).pvalue))


def mcnemar_paired(a, b):
    """Exact McNemar test on paired booleans a[i], b[i] (same trial): returns (TestResult,
    only_a, only_b), only_a = pairs where only a is true, only_b = only b."""
    a = np.asarray(a, dtype=bool).ravel()
    b = np.asarray(b, dtype=bool).ravel()
    if a.size != b.size:
        raise ValueError("mcnemar_paired: samples differ in length (%d vs %d)" % (a.size, b.size))
    if a.size == 0:
        raise ValueError("mcnemar_paired: no data")
    only_a, only_b = int(np.count_nonzero(a & ~b)), int(np.count_nonzero(b & ~a))
    return mcnemar_exact(only_a, only_b), only_a, only_b


def ecdf(values):
    """Empirical CDF: (sorted values, fraction of values <= each); ties share the top step."""
    a = np.sort(_array(values))
    y = np.searchsorted(a, a, side="right") / float(a.size)
    return Cdf([float(v) for v in a], [float(v) for v in y])


def ecdf_at(values, t):
    """Fraction of values <= t."""
    a = _array(values)
    return float(np.count_nonzero(a <= t)) / a.size


def describe(values):
    """Mean, sample std, min, max and n of the values as a dict."""
    a = _array(values)
    return {"mean": float(np.mean(a)), "std": std(a), "min": float(np.min(a)),
            "max": float(np.max(a)), "n": int(a.size)}


def format_p(p):
    """A p-value as the paper prints it (3 decimals), small ones in scientific notation."""
    if p is None or (isinstance(p, float) and math.isnan(p)):
        return "n/a"
    if p < 0.001:
        return "%.1e" % p
    return "%.3f" % p
