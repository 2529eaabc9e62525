"""The dump hook's tensor reader under hostile DROID objects (real torch tensors): a fixed-seed run
of fuzz_hook.py's mutational fuzzer, and one regression test per kind of defect the fuzzer found,
each asserting the exact ValueError (naming the attribute) that replaced the TypeError,
IndexError, AttributeError, KeyError, RuntimeError or OverflowError raised before.

Needs torch (Debian's python3-torch): skipped without it. Run: PYTHONPATH=share/droid python3 -m
unittest discover -s share/droid/tests -v
"""

import io
import os
import tempfile
import time
import unittest
import warnings

import numpy as np

try:
    import torch
except ImportError:  # the rest of share/droid/tests runs without torch
    torch = None

import dbacov_dump

if torch is not None:
    import fuzz_hook

SEED, CASES = 20250601, 300


@unittest.skipIf(torch is None, "python3-torch is not installed")
class FixedSeedFuzzTest(unittest.TestCase):
    def test_fixed_seed_cases_keep_the_contract(self):
        start = time.monotonic()
        counts, findings = fuzz_hook.fuzz(SEED, cases=CASES)
        self.assertEqual(findings, [], "\n".join(findings))
        self.assertEqual(counts["cases"], CASES)
        # Neither side degenerate: valid objects are read, broken ones refused.
        self.assertGreater(counts["valid"], CASES // 6, counts)
        self.assertGreater(counts["refused"], CASES // 3, counts)
        self.assertLess(time.monotonic() - start, 60)

    def test_a_case_replays_exactly(self):
        a, b = fuzz_hook.Case(SEED, 17), fuzz_hook.Case(SEED, 17)
        self.assertEqual(a.mutations, b.mutations)

    def test_command_line_prints_counts(self):
        import subprocess
        import sys
        r = subprocess.run([sys.executable, "-B", fuzz_hook.__file__, "--seconds", "1",
                            "--seed", "3"], capture_output=True, text=True, timeout=120)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertRegex(r.stdout, r"^fuzz_hook: seed 3: \d+ cases in [0-9.]+ s \(\d+/s\), \d+ "
                                   r"valid, \d+ refused, 0 findings\n$")


@unittest.skipIf(torch is None, "python3-torch is not installed")
class FoundByFuzzingTest(unittest.TestCase):
    """One test per kind of defect: each was another exception type before, from an attribute
    missing or shaped otherwise than DROID's."""

    N = 5

    def setUp(self):
        rng = np.random.default_rng(4)
        self.video = fuzz_hook.FakeVideo(rng, self.N, 8, 6, 8)
        self.graph = fuzz_hook.FakeGraph(rng, self.N, 6, 8, edges=6, inactive=3)

    def refused(self, message, error=ValueError, **kwargs):
        with self.assertRaises(error) as e:
            dbacov_dump.snapshot_arrays(self.video, self.graph, 1, **kwargs)
        self.assertEqual(str(e.exception), message)

    def read(self, **kwargs):
        return dbacov_dump.snapshot_arrays(self.video, self.graph, 1, **kwargs)

    def test_missing_attributes_are_named(self):  # was AttributeError / TypeError
        for owner, name in (("video", "poses"), ("video", "disps"), ("video", "intrinsics"),
                            ("graph", "ii"), ("graph", "jj"), ("graph", "target"),
                            ("graph", "weight"), ("graph", "ii_inac"), ("graph", "jj_inac"),
                            ("graph", "target_inac"), ("graph", "weight_inac")):
            for how in ("delete", "None"):
                with self.subTest(name=name, how=how):
                    self.setUp()
                    obj = getattr(self, owner)
                    delattr(obj, name) if how == "delete" else setattr(obj, name, None)
                    self.refused(f"{owner}.{name} is missing (None or no such attribute)",
                                 include_inactive=True)
        self.setUp()
        del self.video.tstamp
        self.refused("video.tstamp is missing (None or no such attribute), and so is "
                     "video.timestamp (GO-SLAM's name): expected the keyframes' time stamps")
        self.setUp()
        del self.video.counter
        self.refused("video.counter.value is missing: expected the number of keyframes "
                     "(DROID's DepthVideo.counter, a multiprocessing Value)")
        self.setUp()
        self.video.get_lock = None
        self.refused("video.get_lock is missing or not callable: expected DROID's "
                     "DepthVideo.get_lock() (the lock of its buffers)")
        # Optional ones stay optional: no images, no sensor depth, no stereo flag.
        self.setUp()
        del self.video.images, self.video.disps_sens, self.video.stereo
        self.assertNotIn("disps_sens", self.read())

    def test_scalars_objects_and_0d_tensors_are_refused_by_shape_or_dtype(self):
        # was TypeError ('float' object is not subscriptable, unhashable slice), IndexError
        # (slice() cannot be applied to a 0-dim tensor), KeyError (a dict indexed by slot)
        cases = [("poses", 1.5, "video.poses has shape (), expected (slots, 7)"),
                 ("disps", torch.tensor(2.0), "video.disps has shape (), expected (slots, *, *)"),
                 ("disps_sens", {"a": 1}, "video.disps_sens has the dtype object, expected real "
                                          "numbers (a float or integer dtype)"),
                 ("images", {"a": 1}, "video.images has the dtype object, expected real "
                                      "numbers (a float or integer dtype)"),
                 ("tstamp", torch.tensor(3.0), "video.tstamp has shape (), expected (slots,): "
                                               "one time stamp per keyframe slot")]
        for name, value, message in cases:
            with self.subTest(name=name):
                self.setUp()
                setattr(self.video, name, value)
                self.refused(message)
        self.setUp()
        self.graph.ii = 2.0
        self.refused("graph.ii has shape (), expected (E,)")

    def test_counter_values_that_are_not_a_keyframe_count(self):
        # was TypeError (None), silent truncation (2.5 -> 2), OverflowError (2**70)
        for value, message in [
                (None, "video.counter.value is missing: expected the number of keyframes "
                       "(DROID's DepthVideo.counter, a multiprocessing Value)"),
                (2.5, "video.counter.value is 2.5 (float), expected an integer in the int64 "
                      "range"),
                ("5", "video.counter.value is '5' (str), expected an integer in the int64 "
                      "range"),
                (True, "video.counter.value is True (bool), expected an integer in the int64 "
                       "range"),
                (2 ** 70, f"video.counter.value is {2 ** 70} (int), expected an integer in the "
                          "int64 range"),
                (0, "video.counter.value is 0: the video holds no keyframe (expected at least "
                    "1)"),
                (9, "video.poses has 8 slots, fewer than the video.counter.value = 9 "
                    "keyframes")]:
            with self.subTest(value=value):
                self.setUp()
                self.video.counter.value = value
                self.refused(message)
        self.setUp()
        self.video.counter.value = torch.tensor(self.N)  # a 0-d integer tensor is a count
        self.assertEqual(self.read()["poses"].shape, (self.N, 7))

    def test_images_without_a_slot_per_keyframe(self):  # was IndexError in the image digest
        self.video.images = self.video.images[:3]
        self.refused("video.images has shape (3, 3, 48, 64), expected (slots, 3, 8H, 8W) with "
                     "at least the video.counter.value = 5 slots")
        self.setUp()
        self.video.images = self.video.images[:, 0, 0]
        self.refused("video.images has shape (8, 64), expected (slots, 3, 8H, 8W) with at least "
                     "the video.counter.value = 5 slots")

    def test_edge_counts_that_disagree(self):
        # was AttributeError ('bool' object has no attribute 'any') for ii/jj, and IndexError /
        # RuntimeError from the inactive edges' mask
        self.graph.jj = self.graph.jj[:-1]
        self.refused("graph.jj has 5 edges but graph.ii has 6: expected one index pair per edge")
        self.setUp()
        self.graph.jj_inac = self.graph.jj_inac[:-1]
        self.refused("graph.jj_inac has 2 edges but graph.ii_inac has 3: expected one index "
                     "pair per edge", include_inactive=True)
        self.setUp()
        self.graph.weight_inac = self.graph.weight_inac[:, :2]
        self.refused("graph.weight_inac has shape (1, 2, 6, 8, 2), expected (1,E,H,W,2) with "
                     "E = 3 (the edges of graph.ii_inac)", include_inactive=True)
        self.setUp()
        self.graph.target_inac = self.graph.target_inac.permute(3, 1, 0, 2, 4)
        self.refused("graph.target_inac has shape (8, 3, 1, 6, 2), expected (1,E,H,W,2) with "
                     "E = 3 (the edges of graph.ii_inac)", include_inactive=True)
        self.setUp()
        self.graph.weight = torch.cat([self.graph.weight, self.graph.weight[:, :, :1]], 2)
        self.refused("graph.weight has shape (1, 6, 7, 8, 2): its H x W grid 7 x 8 is not "
                     "graph.target's 6 x 8")
        # Inactive edges as a list and a NumPy array are read as DROID's tensors are.
        self.setUp()
        want = self.read(include_inactive=True)
        self.graph.ii_inac = self.graph.ii_inac.tolist()
        self.graph.jj_inac = self.graph.jj_inac.numpy()
        got = self.read(include_inactive=True)
        for k in want:
            np.testing.assert_array_equal(got[k], want[k], err_msg=k)

    def test_shapes_that_were_flattened_silently(self):
        self.graph.ii = self.graph.ii[None]
        self.refused("graph.ii has shape (1, 6), expected (E,)")
        self.setUp()
        self.video.tstamp = torch.stack([self.video.tstamp, self.video.tstamp], 1)
        self.refused("video.tstamp has shape (8, 2), expected (slots,): one time stamp per "
                     "keyframe slot", error=dbacov_dump.KeyframeTimeError)

    def test_dtypes_numpy_cannot_take(self):  # was TypeError: unsupported ScalarType BFloat16
        want = self.read()
        self.video.poses = self.video.poses.to(torch.bfloat16)
        got = self.read()
        np.testing.assert_array_equal(got["poses"],
                                      self.video.poses[:self.N].float().numpy())
        self.assertEqual(got["poses"].dtype, np.float32)
        self.assertFalse(np.array_equal(got["poses"], want["poses"]))  # rounded by DROID's side
        self.setUp()
        with warnings.catch_warnings():  # torch: "ComplexHalf support is experimental"
            warnings.simplefilter("ignore")
            self.video.disps = self.video.disps.to(torch.complex32)
        self.refused("video.disps has the complex dtype complex32: its imaginary part would be "
                     "dropped; expected real numbers")
        self.setUp()
        self.graph.weight = self.graph.weight.to(torch.complex64).conj()  # conjugate bit set
        self.refused("graph.weight has the complex dtype complex64: its imaginary part would be "
                     "dropped; expected real numbers")

    def test_integers_beyond_int64(self):  # was OverflowError, or a wrapped keyframe index
        with self.assertRaises(ValueError) as e:
            dbacov_dump.snapshot_arrays(self.video, self.graph, 2 ** 70)
        self.assertEqual(str(e.exception), f"snapshot_id is {2 ** 70} (int), expected an "
                                           "integer in the int64 range")
        self.graph.ii = self.graph.ii.to(torch.float64)
        self.graph.ii[2] = 2.0 ** 64
        self.refused("graph.ii[2] is 1.8446744073709552e+19, beyond the int64 range of keyframe "
                     "indices")
        self.setUp()
        self.video.tstamp = self.video.tstamp.to(torch.float64)
        self.video.tstamp[self.N] = 1e300  # beyond the counter: never an image index, ignored
        frames = self.read()["tstamp"]
        np.testing.assert_array_equal(frames, self.video.tstamp[:self.N].numpy())
        self.video.tstamp[1] = 1e300
        self.refused("video.tstamp[1] is 1e+300, beyond the integers that a float64 holds "
                     "exactly (2**53): not an image index", error=dbacov_dump.KeyframeTimeError)

    def test_stereo_flag_that_is_not_a_bool(self):  # was RuntimeError (ambiguous truth value)
        self.graph.jj[0] = self.graph.ii[0]
        self.video.stereo = torch.tensor([True, False])
        self.refused("video.stereo is tensor([ True, False]) (Tensor), expected True or False "
                     "(DepthVideo(stereo=...))")
        self.video.stereo = np.bool_(True)
        self.assertIn("stereo_rig", self.read())

    def test_equal_nan_intrinsics_rows_do_not_differ(self):
        self.video.intrinsics[:, 2] = float("nan")
        self.assertTrue(np.isnan(self.read()["intrinsics"][2]))  # values are checked later

    def test_the_hook_reports_a_failure_once_whatever_its_numbers(self):
        stream = io.StringIO()
        with tempfile.TemporaryDirectory() as out:
            dumper = dbacov_dump.DbaDumper(out, stream=stream)
            for count, n in enumerate((9, 10, 11, 12)):
                self.video.counter.value = n
                self.assertIsNone(dumper(self.video, self.graph, count))
            self.assertEqual(os.listdir(out), [])
        self.assertEqual(dumper.failures, 4)
        lines = stream.getvalue().splitlines()
        self.assertEqual(len(lines), 1, lines)
        self.assertIn("video.poses has 8 slots, fewer than the video.counter.value = 9", lines[0])


if __name__ == "__main__":
    unittest.main()
