"""The peer benchmark's arithmetic (bench/peer/peer_bench.py), checked against values worked out by
hand, without Blender or a render: the time at which a ladder reaches an error, and the median
time of a ladder point rendered several times."""
import math
import os
import sys
import types
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..",
                                "bench", "peer"))
import peer_bench  # noqa: E402


def ladder(*points):
    """[(spp, seconds, rel_mse)] -> the ladder's point dicts."""
    return [{"spp": n, "seconds": t, "process_seconds": t + 1.0, "rel_mse": e}
            for n, t, e in points]


class TimeToError(unittest.TestCase):
    # Error halving with each doubling of time: 1 s -> 0.1, 2 s -> 0.05, 4 s -> 0.025.
    HALVING = ladder((1, 1.0, 0.1), (2, 2.0, 0.05), (4, 4.0, 0.025))

    def test_a_point_on_the_ladder_is_its_time(self):
        t, extrapolated = peer_bench.time_to_error(self.HALVING, 0.05)
        self.assertAlmostEqual(t, 2.0, places=9)
        self.assertFalse(extrapolated)

    def test_between_points_it_interpolates_in_log_log(self):
        # 0.025 * sqrt(2) lies halfway between 0.05 and 0.025 in log: halfway between 2 and 4 s
        # in log, sqrt(8) s.
        t, extrapolated = peer_bench.time_to_error(self.HALVING, 0.025 * math.sqrt(2.0))
        self.assertAlmostEqual(t, math.sqrt(8.0), places=9)
        self.assertFalse(extrapolated)

    def test_whole_process_times_are_read_from_their_own_key(self):
        t, _ = peer_bench.time_to_error(self.HALVING, 0.05, key="process_seconds")
        self.assertAlmostEqual(t, 3.0, places=9)

    def test_only_the_last_crossing_counts(self):
        # 0.04 at 2 s is below 0.05, but the error rises to 0.06 at 4 s: the ladder reaches 0.05
        # for good between 4 s (0.06) and 8 s (0.02), at 4 * 2^(ln(5/6) / ln(1/3)) s = 4.4876 s.
        points = ladder((1, 1.0, 0.1), (2, 2.0, 0.04), (4, 4.0, 0.06), (8, 8.0, 0.02))
        t, extrapolated = peer_bench.time_to_error(points, 0.05)
        self.assertAlmostEqual(t, 4.0 * 2.0 ** (math.log(5 / 6) / math.log(1 / 3)), places=9)
        self.assertAlmostEqual(t, 4.4876, places=4)
        self.assertFalse(extrapolated)

    def test_below_the_target_from_the_first_point_extrapolates_back(self):
        # 4 spp at 1 s gives 0.01 and 8 spp at 2 s gives 0.005: error x time is constant, so
        # 0.02 would take 0.5 s (flagged as extrapolated), above the floor of 1 spp (0.25 s).
        points = ladder((4, 1.0, 0.01), (8, 2.0, 0.005))
        t, extrapolated = peer_bench.time_to_error(points, 0.02)
        self.assertAlmostEqual(t, 0.5, places=9)
        self.assertTrue(extrapolated)
        # ... but never below the time of one sample per pixel: 0.2 would take 0.05 s, so 0.25 s.
        t, extrapolated = peer_bench.time_to_error(points, 0.2)
        self.assertAlmostEqual(t, 0.25, places=9)
        self.assertTrue(extrapolated)

    def test_never_reached_extrapolates_forward_along_the_last_points(self):
        # The last three points fall as 1/t: 0.001 would take 10 times the last point's 4 s.
        t, extrapolated = peer_bench.time_to_error(self.HALVING, 0.0025)
        self.assertAlmostEqual(t, 40.0, places=6)
        self.assertTrue(extrapolated)

    def test_an_error_that_stops_falling_is_never_reached(self):
        points = ladder((1, 1.0, 0.1), (2, 2.0, 0.1), (4, 4.0, 0.1))
        self.assertEqual(peer_bench.time_to_error(points, 0.05), (None, True))


class RepeatedRenders(unittest.TestCase):
    @staticmethod
    def timed(repeat, seconds):
        """SceneBench.timed with --repeat `repeat` over renders taking `seconds` in turn."""
        bench = types.SimpleNamespace(a=types.SimpleNamespace(repeat=repeat))
        it = iter(seconds)

        def render():
            t = next(it)
            return {"seconds": t, "process_seconds": 10.0 * t}
        return peer_bench.SceneBench.timed(bench, render)

    def test_the_median_of_the_runs_is_the_time_and_the_runs_are_kept(self):
        t = self.timed(3, [0.55, 0.37, 0.48])
        self.assertEqual(t["seconds"], 0.48)
        self.assertEqual(t["process_seconds"], 4.8)
        self.assertEqual(t["seconds_runs"], [0.55, 0.37, 0.48])
        self.assertEqual(t["process_seconds_runs"], [5.5, 3.7, 4.8])

    def test_one_render_is_its_own_time(self):
        t = self.timed(1, [0.5])
        self.assertEqual(t, {"seconds": 0.5, "process_seconds": 5.0})


if __name__ == "__main__":
    unittest.main()
