"""Unit tests of krr_eval.navigation (smoothing, tables, plotting)."""
import os
import tempfile
import unittest

from krr_eval import navigation


class SmoothTest(unittest.TestCase):
    def test_trailing_window(self):
        # window 3 over 1..5: 1, (1+2)/2, (1+2+3)/3, (2+3+4)/3, (3+4+5)/3
        self.assertEqual(navigation.smooth([1, 2, 3, 4, 5], 3), [1.0, 1.5, 2.0, 3.0, 4.0])

    def test_window_one_is_identity(self):
        self.assertEqual(navigation.smooth([3.0, -1.0], 1), [3.0, -1.0])

    def test_bad_window(self):
        with self.assertRaises(ValueError):
            navigation.smooth([1.0], 0)


class TableTest(unittest.TestCase):
    def test_read_and_plot(self):
        with tempfile.TemporaryDirectory() as d:
            p = os.path.join(d, "t.csv")
            with open(p, "w") as f:
                f.write("episode,mean_with,ci95_with,mean_without,ci95_without,success_with,success_without\n")
                for e in range(1, 21):
                    f.write("%d,%f,1,%f,1,0.5,0.4\n" % (e, -10 + e, -20 + e))
            t = navigation.read_table(p)
            self.assertEqual(len(t["episode"]), 20)
            self.assertAlmostEqual(navigation.advantage(t), 10.0)
            self.assertAlmostEqual(navigation.advantage(t, 5), 10.0)
            png = os.path.join(d, "p.png")
            navigation.plot({"small": t, "large": t}, png)
            with open(png, "rb") as f:
                self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")
            # A site's own domain by its name (rosrun krr_eval nav_transfer --domains NAME).
            one = os.path.join(d, "one.png")
            navigation.plot({"office_50x50": t}, one)
            self.assertTrue(os.path.getsize(one) > 0)

    def test_empty_table_is_an_error(self):
        with tempfile.TemporaryDirectory() as d:
            p = os.path.join(d, "t.csv")
            with open(p, "w") as f:
                f.write("episode,mean_with\n")
            with self.assertRaises(ValueError):
                navigation.read_table(p)


if __name__ == "__main__":
    unittest.main()
