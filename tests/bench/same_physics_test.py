"""The same-physics check's arithmetic (bench/peer/same_physics.py) against values worked out by
hand, without Blender or a render: per-pixel means and variances of batch means, tile means and
standard errors, and the three-standard-error test of two renderers' tiles."""
import math
import os
import sys
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..",
                                "bench", "peer"))
import same_physics  # noqa: E402


class PixelMoments(unittest.TestCase):
    def test_mean_and_the_variance_of_the_mean(self):
        # Pixel 0: batches 1, 3 -> mean 2, sample variance ((1-2)^2 + (3-2)^2) / 1 = 2, of the
        # mean 2 / 2 = 1. Pixel 1: 5, 5 -> mean 5, variance 0.
        means, variances = same_physics.pixel_moments([[1.0, 5.0], [3.0, 5.0]])
        self.assertEqual(means, [2.0, 5.0])
        self.assertEqual(variances, [1.0, 0.0])

    def test_four_batches(self):
        # 0, 2, 4, 6: mean 3, sample variance (9 + 1 + 1 + 9) / 3 = 20/3, of the mean 5/3.
        means, variances = same_physics.pixel_moments([[0.0], [2.0], [4.0], [6.0]])
        self.assertAlmostEqual(means[0], 3.0)
        self.assertAlmostEqual(variances[0], 5.0 / 3.0)

    def test_one_batch_gives_no_error_estimate(self):
        with self.assertRaises(ValueError):
            same_physics.pixel_moments([[1.0]])


class Tiles(unittest.TestCase):
    def test_tile_means_and_standard_errors_of_a_2x2_grid(self):
        # A 4x2 image cut 2x2: tiles of 2x1 pixels. Means 1..8, variances all 4: a tile's mean is
        # the mean of its two pixels, its standard error sqrt(4 + 4) / 2 = sqrt(2).
        means = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]
        tiles = same_physics.tile_stats(means, [4.0] * 8, 4, 2, grid=2)
        self.assertEqual([t["mean"] for t in tiles], [1.5, 3.5, 5.5, 7.5])
        for t in tiles:
            self.assertAlmostEqual(t["se"], math.sqrt(2.0))
            self.assertEqual(t["pixels"], 2)

    def test_uneven_sizes_cover_every_pixel_once(self):
        tiles = same_physics.tile_stats([1.0] * 35, [0.0] * 35, 7, 5, grid=4)
        self.assertEqual(sum(t["pixels"] for t in tiles), 35)

    def test_three_standard_errors(self):
        # Differences 0.5 with standard errors 0.3 and 0.4: se of the difference 0.5, z = 1 (ok);
        # 2.0: z = 4 (not).
        a = [{"mean": 1.5, "se": 0.3}, {"mean": 3.0, "se": 0.3}]
        b = [{"mean": 1.0, "se": 0.4}, {"mean": 1.0, "se": 0.4}]
        out = same_physics.compare_tiles(a, b)
        self.assertAlmostEqual(out[0]["se"], 0.5)
        self.assertAlmostEqual(out[0]["z"], 1.0)
        self.assertTrue(out[0]["ok"])
        self.assertAlmostEqual(out[1]["z"], 4.0)
        self.assertFalse(out[1]["ok"])
        self.assertAlmostEqual(same_physics.relative_difference(1.01, 1.0), 0.01)


if __name__ == "__main__":
    unittest.main()
