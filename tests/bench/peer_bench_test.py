"""The peer benchmark's arithmetic (bench/peer/peer_bench.py), checked against values worked out by
hand, without Blender or a render: the time at which a ladder reaches an error, the interleaved
order of the timing passes and the median time of a ladder point rendered several times."""
import math
import os
import sys
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


class InterleavedTiming(unittest.TestCase):
    @staticmethod
    def points(tag, n):
        return [{"id": "%s%d" % (tag, i), "seconds": 100.0, "process_seconds": 200.0}
                for i in range(n)]

    def test_each_renderers_points_are_spread_over_the_pass(self):
        # 2 Cycles points at 1/4 and 3/4 of the pass, 4 dofcache points at 1/8, 3/8, 5/8, 7/8.
        order = peer_bench.interleave([self.points("c", 2), self.points("d", 4)])
        self.assertEqual([p["id"] for p in order], ["d0", "c0", "d1", "d2", "c1", "d3"])

    def test_equal_queues_alternate(self):
        order = peer_bench.interleave([self.points("c", 3), self.points("d", 3)])
        self.assertEqual([p["id"] for p in order], ["c0", "d0", "c1", "d1", "c2", "d2"])

    def test_passes_alternate_direction_and_times_are_medians(self):
        cyc, dof = self.points("c", 1), self.points("d", 2)
        calls = []
        # Times drift upwards over the run: 1, 2, 3, ... seconds in call order.
        def render(p):
            calls.append(p["id"])
            t = float(len(calls))
            return {"seconds": t, "process_seconds": t + 0.5}
        renders = peer_bench.timing_passes([cyc, dof], 3, render)
        self.assertEqual(renders, 9)
        # d0 at 1/4, c0 at 1/2, d1 at 3/4; the second pass backwards.
        self.assertEqual(calls, ["d0", "c0", "d1", "d1", "c0", "d0", "d0", "c0", "d1"])
        # c0 ran 2nd, 5th and 8th: median 5 s; d0 1st, 6th, 7th: 6 s; d1 3rd, 4th, 9th: 4 s.
        self.assertEqual(cyc[0]["seconds"], 5.0)
        self.assertEqual(cyc[0]["seconds_runs"], [2.0, 5.0, 8.0])
        self.assertEqual(cyc[0]["process_seconds"], 5.5)
        self.assertEqual(dof[0]["seconds"], 6.0)
        self.assertEqual(dof[1]["seconds"], 4.0)
        # The untimed discovery render's times are kept beside them.
        self.assertEqual(cyc[0]["discovery_seconds"], 100.0)
        self.assertEqual(dof[1]["discovery_process_seconds"], 200.0)

    def test_no_pass_keeps_the_discovery_times(self):
        cyc = self.points("c", 2)
        self.assertEqual(peer_bench.timing_passes([cyc, []], 0, None), 0)
        self.assertEqual(cyc[0]["seconds"], 100.0)
        self.assertNotIn("discovery_seconds", cyc[0])


class ApertureMapping(unittest.TestCase):
    def test_cycles_is_given_the_corner_angle_less_half_a_sector(self):
        # Measured with bench/peer/bokeh_mapping.py: Cycles puts a corner of its 6-blade bokeh at
        # its rotation + 30 deg, of its 5-blade at + 36 deg; dofcache's rotation is the corner's.
        self.assertEqual(peer_bench.cycles_aperture({"blades": 6, "rotation": 20.0, "ratio": 2.0}),
                         {"blades": 6, "rotation_deg": -10.0, "ratio": 2.0})
        self.assertEqual(peer_bench.cycles_aperture({"blades": 5, "rotation": 90.0})["rotation_deg"],
                         54.0)
        self.assertEqual(peer_bench.cycles_aperture({"ratio": 1.5}),
                         {"blades": 0, "rotation_deg": 0.0, "ratio": 1.5})
        self.assertEqual(peer_bench.cycles_config_args({"aperture": {"blades": 6,
                                                                     "rotation_deg": -10.0,
                                                                     "ratio": 2.0}}),
                         ["--aperture-blades", "6", "--aperture-rotation", "-10.0",
                          "--aperture-ratio", "2.0"])


class CyclesAtItsBest(unittest.TestCase):
    def test_the_defaults_configuration_passes_blenders_defaults(self):
        configs = dict(peer_bench.CYCLES_CONFIGS)
        self.assertEqual(peer_bench.cycles_config_args(configs["fixed"]), [])
        self.assertEqual(peer_bench.cycles_config_args(configs["defaults"]),
                         ["--adaptive-threshold", "0.01", "--light-threshold", "0.01"])



class DofcacheLadder(unittest.TestCase):
    """SceneBench.dof_ladder with renders replaced by an error of 0.08 / spp, 0.1 s per sample."""

    def ladder(self, start, min_target, max_target):
        bench = peer_bench.SceneBench.__new__(peer_bench.SceneBench)
        bench.plan = {"spp_cap": 65536}
        rendered = []

        def point(config, spp, ref, stem):
            rendered.append(spp)
            return {"spp": spp, "seconds": 0.1 * spp, "process_seconds": 0.1 * spp,
                    "rel_mse": 0.08 / spp}
        bench.dof_point = point
        pts = bench.dof_ladder({}, start, None, min_target, 1e9, "t", max_target)
        return [p["spp"] for p in pts], rendered

    def test_it_goes_up_until_below_the_smallest_target(self):
        # 0.08 / spp <= 0.002 / 1.1 from spp 44 on: 4, 8, 16, 32, 64.
        self.assertEqual(self.ladder(4, 0.002, 0.01)[0], [4, 8, 16, 32, 64])

    def test_a_start_below_the_largest_target_goes_down_until_above_it(self):
        # 0.08 / 4 = 0.02 is below 0.05: 2 gives 0.04, still below; 1 gives 0.08, above.
        spp, rendered = self.ladder(4, 0.002, 0.05)
        self.assertEqual(spp, [1, 2, 4, 8, 16, 32, 64])
        self.assertEqual(sorted(rendered), spp)  # each point rendered once
        # Target 0.05 now lies between 1 and 2 spp: interpolated, not extrapolated.
        pts = [{"spp": s, "seconds": 0.1 * s, "rel_mse": 0.08 / s} for s in spp]
        t, extrapolated = peer_bench.time_to_error(pts, 0.05)
        self.assertFalse(extrapolated)
        self.assertAlmostEqual(t, 0.1 * 0.08 / 0.05, places=9)

    def test_it_stops_going_down_at_one_sample(self):
        self.assertEqual(self.ladder(2, 0.0001, 0.5)[0][0], 1)

if __name__ == "__main__":
    unittest.main()
