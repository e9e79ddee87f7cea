"""Unit tests of krr_eval.stats against hand-computed and textbook values."""
import math
import unittest

from krr_eval import stats


class MeanCiTest(unittest.TestCase):
    def test_textbook_sample(self):
        # x = 2,4,4,4,5,5,7,9: mean 5, s = sqrt(32/7); t(0.975, 7) = 2.364624252
        e = stats.mean_ci([2, 4, 4, 4, 5, 5, 7, 9])
        self.assertEqual(e.mean, 5.0)
        self.assertEqual(e.n, 8)
        self.assertAlmostEqual(e.half, 2.364624252 * math.sqrt(32 / 7.0) / math.sqrt(8), places=7)
        self.assertAlmostEqual(e.lo, 5.0 - e.half)
        self.assertAlmostEqual(e.hi, 5.0 + e.half)
        self.assertAlmostEqual(stats.std([2, 4, 4, 4, 5, 5, 7, 9]), math.sqrt(32 / 7.0))

    def test_level_99(self):
        # t(0.995, 7) = 3.499483297
        e = stats.mean_ci([2, 4, 4, 4, 5, 5, 7, 9], level=0.99)
        self.assertAlmostEqual(e.half, 3.499483297 * math.sqrt(32 / 7.0) / math.sqrt(8), places=6)

    def test_single_value_has_no_interval(self):
        e = stats.mean_ci([3.0])
        self.assertEqual(e.mean, 3.0)
        self.assertTrue(math.isnan(e.half))

    def test_bad_input(self):
        with self.assertRaisesRegex(ValueError, "no data"):
            stats.mean_ci([])
        with self.assertRaisesRegex(ValueError, "NaN"):
            stats.mean_ci([1.0, float("nan")])
        with self.assertRaisesRegex(ValueError, "level"):
            stats.mean_ci([1.0, 2.0], level=95)


class TTestTest(unittest.TestCase):
    # Welch's t-test, Wikipedia example 1: t = -2.46, df = 24.99, p = 0.021
    A1 = [27.5, 21.0, 19.0, 23.6, 17.0, 17.9, 16.9, 20.1, 21.9, 22.6, 23.1, 19.6, 19.0, 21.7, 21.4]
    A2 = [27.1, 22.0, 20.8, 23.4, 23.4, 23.5, 25.8, 22.0, 24.8, 20.2, 21.9, 22.1, 22.9, 20.5, 24.4]

    def test_welch_textbook(self):
        r = stats.welch_t_test(self.A1, self.A2)
        self.assertAlmostEqual(r.statistic, -2.46, places=2)
        self.assertAlmostEqual(r.df, 24.99, places=2)
        self.assertAlmostEqual(r.p, 0.021, places=3)
        # symmetric in the samples up to the sign of t
        r2 = stats.welch_t_test(self.A2, self.A1)
        self.assertAlmostEqual(r2.statistic, -r.statistic)
        self.assertAlmostEqual(r2.p, r.p)

    def test_welch_hand_computed_statistic(self):
        a, b = [1.0, 2.0, 3.0], [4.0, 6.0, 8.0, 10.0]
        # var a = 1, var b = 20/3; se^2 = 1/3 + 5/3 = 2; t = (2 - 7)/sqrt(2)
        # df = 2^2 / ((1/3)^2/2 + (5/3)^2/3) = 4 / (1/18 + 25/27)
        r = stats.welch_t_test(a, b)
        self.assertAlmostEqual(r.statistic, -5 / math.sqrt(2))
        self.assertAlmostEqual(r.df, 4 / (1 / 18.0 + 25 / 27.0))

    def test_welch_constant_samples(self):
        self.assertEqual(stats.welch_t_test([1, 1], [1, 1]).p, 1.0)
        self.assertEqual(stats.welch_t_test([1, 1], [2, 2]).p, 0.0)
        with self.assertRaisesRegex(ValueError, "at least 2"):
            stats.welch_t_test([1], [1, 2])

    def test_paired(self):
        # differences 1,2,2,3: mean 2, s = sqrt(2/3), t = 2 / (s/2) = 4.898979; p(t3) = 0.01628
        r = stats.paired_t_test([1, 2, 3, 4], [0, 0, 1, 1])
        self.assertAlmostEqual(r.statistic, 2 / (math.sqrt(2 / 3.0) / 2))
        self.assertEqual(r.df, 3)
        self.assertAlmostEqual(r.p, 0.01628, places=5)
        self.assertEqual(stats.paired_t_test([1, 2], [1, 2]).p, 1.0)
        with self.assertRaisesRegex(ValueError, "length"):
            stats.paired_t_test([1, 2], [1, 2, 3])

    def test_mann_whitney(self):
        # U = 0; mu = 4.5, sigma = sqrt(3*3*7/12); z = (0 - 4.5 + 0.5)/sigma = -1.7457; p = 0.08086
        r = stats.mann_whitney([1, 2, 3], [4, 5, 6])
        self.assertEqual(r.statistic, 0.0)
        self.assertAlmostEqual(r.p, 0.08086, places=4)
        self.assertEqual(stats.mann_whitney([2, 2], [2, 2, 2]).p, 1.0)


class PairedAndTrialCountTest(unittest.TestCase):
    def test_paired_difference(self):
        # differences 1,2,2,3: mean 2, s = sqrt(2/3); half = t(0.975, 3) * s / 2 with
        # t(0.975, 3) = 3.182446305; paired t = 4.898979, p = 0.01628
        e, t = stats.paired_difference([1, 2, 3, 4], [0, 0, 1, 1])
        self.assertEqual(e.mean, 2.0)
        self.assertEqual(e.n, 4)
        self.assertAlmostEqual(e.half, 3.182446305 * math.sqrt(2 / 3.0) / 2, places=7)
        self.assertAlmostEqual(t.statistic, 2 / (math.sqrt(2 / 3.0) / 2))
        self.assertAlmostEqual(t.p, 0.01628, places=5)
        with self.assertRaisesRegex(ValueError, "length"):
            stats.paired_difference([1, 2], [1])

    def test_half_width(self):
        # the textbook sample of MeanCiTest: s = sqrt(32/7), n = 8, t(0.975, 7) = 2.364624252
        self.assertAlmostEqual(stats.half_width(math.sqrt(32 / 7.0), 8),
                               2.364624252 * math.sqrt(32 / 7.0) / math.sqrt(8), places=7)
        self.assertAlmostEqual(stats.half_width(math.sqrt(32 / 7.0), 8),
                               stats.mean_ci([2, 4, 4, 4, 5, 5, 7, 9]).half)
        self.assertEqual(stats.half_width(0.0, 10), 0.0)
        with self.assertRaises(ValueError):
            stats.half_width(1.0, 1)
        with self.assertRaises(ValueError):
            stats.half_width(-1.0, 10)

    def test_trials_for_half_width(self):
        # sd 1, half 1: n = 6 gives t(0.975, 5) / sqrt(6) = 2.570582 / 2.449490 = 1.0494 > 1,
        # n = 7 gives 2.446912 / 2.645751 = 0.9248 <= 1
        self.assertEqual(stats.trials_for_half_width(1.0, 1.0), 7)
        # large n: (z sd / half)^2 = (1.959964 * 54.69 / 0.5)^2 = 45961.4, plus the t correction
        n = stats.trials_for_half_width(54.69, 0.5)
        self.assertLessEqual(stats.half_width(54.69, n), 0.5)
        self.assertGreater(stats.half_width(54.69, n - 1), 0.5)
        self.assertEqual(n, 45962)
        self.assertEqual(stats.trials_for_half_width(0.0, 0.5), 2)
        with self.assertRaisesRegex(ValueError, "positive"):
            stats.trials_for_half_width(1.0, 0.0)

    def test_mcnemar_paired(self):
        # 1 pair where only a succeeds, 9 where only b does, 5 concordant
        a = [1] + [0] * 9 + [1, 1, 0, 0, 1]
        b = [0] + [1] * 9 + [1, 1, 0, 0, 1]
        t, only_a, only_b = stats.mcnemar_paired(a, b)
        self.assertEqual((only_a, only_b), (1, 9))
        self.assertAlmostEqual(t.p, 22 / 1024.0)
        self.assertEqual(stats.mcnemar_paired([True, False], [True, False])[0].p, 1.0)
        with self.assertRaisesRegex(ValueError, "length"):
            stats.mcnemar_paired([1], [1, 0])


class ProportionTest(unittest.TestCase):
    def test_wilson_at_zero(self):
        # 0/10: upper = (z^2/n) / (1 + z^2/n) with z = 1.959964 -> 0.27753
        e = stats.proportion_ci(0, 10)
        self.assertEqual(e.mean, 0.0)
        self.assertEqual(e.lo, 0.0)
        self.assertAlmostEqual(e.hi, 0.27753, places=5)

    def test_wilson_interior(self):
        # 81/263 (Wilson 1927 style check): hand formula with z = 1.959964
        z, n, p = 1.959963985, 263.0, 81 / 263.0
        c = (p + z * z / (2 * n)) / (1 + z * z / n)
        h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
        e = stats.proportion_ci(81, 263)
        self.assertAlmostEqual(e.lo, c - h, places=9)
        self.assertAlmostEqual(e.hi, c + h, places=9)
        self.assertAlmostEqual(e.lo, 0.2553, places=4)
        self.assertAlmostEqual(e.hi, 0.3662, places=4)

    def test_two_proportion_z(self):
        # 45/100 vs 30/100: pooled 0.375, se = sqrt(.375*.625*.02), z = 2.19089, p = 0.02846
        r = stats.two_proportion_z_test(45, 100, 30, 100)
        self.assertAlmostEqual(r.statistic, 0.15 / math.sqrt(0.375 * 0.625 * 0.02))
        self.assertAlmostEqual(r.p, 0.02846, places=5)
        self.assertEqual(stats.two_proportion_z_test(5, 5, 7, 7).p, 1.0)

    def test_mcnemar(self):
        # 1 vs 9 discordant: p = 2 * (1 + 10) / 2^10
        self.assertAlmostEqual(stats.mcnemar_exact(1, 9).p, 22 / 1024.0)
        self.assertEqual(stats.mcnemar_exact(0, 0).p, 1.0)

    def test_bad_counts(self):
        with self.assertRaisesRegex(ValueError, "proportion_ci"):
            stats.proportion_ci(11, 10)
        with self.assertRaisesRegex(ValueError, "second sample"):
            stats.two_proportion_z_test(1, 2, 3, 0)
        with self.assertRaises(ValueError):
            stats.mcnemar_exact(-1, 2)


class CdfTest(unittest.TestCase):
    def test_ecdf_with_ties(self):
        c = stats.ecdf([3, 1, 2, 2])
        self.assertEqual(c.x, [1.0, 2.0, 2.0, 3.0])
        self.assertEqual(c.y, [0.25, 0.75, 0.75, 1.0])
        self.assertEqual(stats.ecdf_at([3, 1, 2, 2], 2), 0.75)
        self.assertEqual(stats.ecdf_at([3, 1, 2, 2], 0.5), 0.0)

    def test_describe_and_format(self):
        d = stats.describe([1, 2, 3, 6])
        self.assertEqual((d["mean"], d["min"], d["max"], d["n"]), (3.0, 1.0, 6.0, 4))
        self.assertAlmostEqual(d["std"], math.sqrt(14 / 3.0))
        self.assertEqual(stats.format_p(0.0284), "0.028")
        self.assertEqual(stats.format_p(0.00001234), "1.2e-05")
        self.assertEqual(stats.format_p(float("nan")), "n/a")


if __name__ == "__main__":
    unittest.main()
