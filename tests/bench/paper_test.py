"""The parts of scripts/bench paper that decide what is reported: the variants table, the ratios
and the usage errors. Timings themselves are never tested; these are the pure functions around them."""
import argparse
import contextlib
import io
import math
import os
import sys
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))

from bench_lib import paper  # noqa: E402


def quartiles(median, mean=None):
    return {"median": median, "mean": mean if mean is not None else median, "iqr": 1.0, "n": 10}


class Variants(unittest.TestCase):
    def summary(self, **variants):
        return {"path": "hdr", "native": quartiles(200.0, 210.0), "split": quartiles(100.0, 120.0),
                "periphery": quartiles(80.0), "variants": variants}

    def test_each_variant_is_reported_over_the_plain_split(self):
        r = paper.path_ratios(self.summary(**{"split-tls": quartiles(105.0), "split-guard": quartiles(60.0)}))
        self.assertAlmostEqual(r["split/native"], 0.5)
        self.assertAlmostEqual(r["split/native by means"], 120.0 / 210.0)
        self.assertAlmostEqual(r["periphery/native"], 0.4)
        self.assertAlmostEqual(r["split-tls/split"], 1.05)
        self.assertAlmostEqual(r["split-guard/split"], 0.6)

    def test_no_variant_no_ratio(self):
        r = paper.path_ratios(self.summary())
        self.assertEqual(sorted(r), ["periphery/native", "split/native", "split/native by means"])

    def test_results_from_before_the_variants_table_keep_their_tls_split(self):
        old = {"path": "direct", "native": quartiles(200.0), "split": quartiles(100.0), "periphery": None,
               "split_tls": quartiles(110.0), "split_tls_rounds": [109.0, 111.0]}
        self.assertEqual(list(paper.variants_of(old)), ["split-tls"])
        self.assertEqual(paper.variants_of(old)["split-tls"]["rounds"], [109.0, 111.0])
        self.assertAlmostEqual(paper.path_ratios(old)["split-tls/split"], 1.1)

    def test_the_run_lists_its_variants_in_table_order(self):
        res = {"config": {"tls": True, "agent_scissor": "guard:64"}}
        self.assertEqual(paper.run_variants(res), ["split-tls", "split-guard"])
        self.assertEqual(paper.variant_label(res, "split-guard"), "split, agent scissor (guard:64)")
        self.assertEqual(paper.run_variants({"config": {"tls": False}}), [])


class Swapped(unittest.TestCase):
    """--client-renders fovea: the swapped split is a variant, summarised from its own stats rows."""

    def test_the_command_line_takes_client_renders(self):
        parser = argparse.ArgumentParser()
        paper.register(parser.add_subparsers(dest="command"))
        args = parser.parse_args(["paper", "--client-renders", "fovea", "--periphery-quality", "lossless"])
        self.assertEqual((args.client_renders, args.periphery_quality), ("fovea", "lossless"))
        self.assertEqual(parser.parse_args(["paper"]).client_renders, "periphery")
        res = {"config": {"tls": False, "client_renders": "fovea"}}
        self.assertEqual(paper.run_variants(res), ["split-swapped"])
        self.assertEqual(paper.run_variants({"config": {"client_renders": "periphery"}}), [])

    def test_its_summary_counts_the_periphery_not_the_tiles(self):
        rows = [{"frame_ms": "50", "periphery_ms": "10", "periphery_bytes": "51200", "periphery_decode_ms": "2",
                 "tile_bytes": "0", "late": "0", "agent_draw_ms": "20"},
                {"frame_ms": "50", "periphery_ms": "12", "periphery_bytes": "51200", "periphery_decode_ms": "4",
                 "tile_bytes": "0", "late": "1", "agent_draw_ms": "30"}]
        s = paper.swapped_summary([rows])
        self.assertAlmostEqual(s["mbps"], 2 * 51200 * 8 / 1e6 / 0.1)
        self.assertAlmostEqual(s["kib_per_frame"], 50.0)
        self.assertEqual((s["late"], s["frames"]), (1, 2))
        self.assertAlmostEqual(s["client_render"]["median"], 11.0)
        self.assertAlmostEqual(s["agent_draw"]["median"], 25.0)
        self.assertIsNone(paper.swapped_summary([[dict(rows[0], agent_draw_ms="0")]])["agent_draw"])
        self.assertIsNone(paper.swapped_summary(None))


class ThroughOpenXR(unittest.TestCase):
    def summary(self, xr=None):
        return {"path": "direct", "native": quartiles(200.0), "split": quartiles(100.0), "periphery": None,
                "variants": {}, "xr": xr}

    def test_the_openxr_runs_are_reported_as_their_own_split_over_native(self):
        xr = {"native": quartiles(400.0, 410.0), "split": quartiles(300.0, 328.0)}
        r = paper.path_ratios(self.summary(xr))
        self.assertAlmostEqual(r["split/native"], 0.5)
        self.assertAlmostEqual(r["xr split/native"], 0.75)
        self.assertAlmostEqual(r["xr split/native by means"], 0.8)

    def test_without_xr_no_xr_ratio_and_no_rows(self):
        self.assertNotIn("xr split/native", paper.path_ratios(self.summary()))
        self.assertEqual(paper.xr_rows_markdown({"config": {}}), [])

    def test_rows_under_the_end_to_end_table(self):
        res = {"config": {"eye_size": "1200x1080"},
               "xr": {"native": quartiles(400.0), "split": quartiles(300.0), "native_rounds": [399.0, 401.0],
                      "split_rounds": [300.0, 301.0], "stages": {"late": 0, "frames": 60}}}
        rows = paper.xr_rows_markdown(res)
        self.assertEqual(len(rows), 3)
        self.assertIn("1200x1080 per eye", rows[0])
        self.assertIn("0 of 60 eye images late", rows[1])
        self.assertIn("**0.750**", rows[2])

    def test_xr_runs_are_not_variants_of_the_split(self):
        self.assertEqual(paper.run_variants({"config": {"tls": False, "xr": True}}), [])

    def test_runs_without_xr_runs_summarize_to_none(self):
        self.assertIsNone(paper.xr_summary({"native": [[1.0]], "split": []}))
        self.assertIsNone(paper.xr_summary({"xr-native": [[1.0]], "xr-split": []}))

    def test_the_eye_size_defaults_to_one_eye_of_the_window(self):
        args = argparse.Namespace(eye_size=None, width=2400, height=1080)
        self.assertEqual(paper.xr_eye_size(args), (1200, 1080))
        args.eye_size = (640, 480)
        self.assertEqual(paper.xr_eye_size(args), (640, 480))


class LatencyAndPacing(unittest.TestCase):
    """frame_latency_ms of every mode beside its frame time, and the final lines made of them."""

    def test_p99_interpolates_between_neighbours(self):
        values = [float(v) for v in range(1, 101)]  # 1..100
        self.assertAlmostEqual(paper.common.percentile(values, 99), 99.01)
        self.assertAlmostEqual(paper.common.percentile(values, 50), 50.5)
        self.assertEqual(paper.common.percentile([7.0], 99), 7.0)
        self.assertAlmostEqual(paper.q3(values)["p99"], 99.01)

    def test_one_latency_per_frame_and_none_where_unmeasured(self):
        window = [{"frame_latency_ms": "10.5", "xr_frame": "-1"}, {"frame_latency_ms": "", "xr_frame": "-1"},
                  {"frame_latency_ms": "12", "xr_frame": "-1"}]
        self.assertEqual(paper.frame_latencies(window), [10.5, 12.0])
        # Under OpenXR both eye images' rows carry their frame's one value: counted once.
        eyes = [{"frame_latency_ms": "50", "xr_frame": "3"}, {"frame_latency_ms": "50", "xr_frame": "3"},
                {"frame_latency_ms": "60", "xr_frame": "4"}, {"frame_latency_ms": "60", "xr_frame": "4"},
                {"frame_latency_ms": "", "xr_frame": "5"}]
        self.assertEqual(paper.frame_latencies(eyes), [50.0, 60.0])
        # A stats file from before the column.
        self.assertEqual(paper.frame_latencies([{"frame_ms": "3"}]), [])

    def paced(self, median, p99, mean=None):
        return dict(quartiles(median, mean), p99=p99)

    def summary(self, swapped=True, xr=False):
        p = {"path": "direct", "native": self.paced(200.0, 220.0), "split": self.paced(100.0, 130.0),
             "periphery": None, "variants": {"split-swapped": self.paced(250.0, 450.0)} if swapped else {},
             "latency": {"native": self.paced(180.0, 200.0), "split": self.paced(150.0, 170.0)}}
        if swapped:
            p["latency"]["split-swapped"] = self.paced(360.0, 500.0)
        if xr:
            p["xr"] = {"native": self.paced(400.0, 500.0), "split": self.paced(300.0, 330.0)}
            p["latency"].update({"xr-native": self.paced(80.0, 90.0), "xr-split": self.paced(60.0, 70.0)})
        return p

    def test_latency_over_native_and_p99_over_median(self):
        r = paper.path_ratios(self.summary(xr=True))
        self.assertAlmostEqual(r["latency-split/native"], 150.0 / 180.0)
        self.assertAlmostEqual(r["latency-swapped/native"], 2.0)
        self.assertAlmostEqual(r["pacing-split"], 1.3)
        self.assertAlmostEqual(r["pacing-swapped"], 1.8)
        self.assertAlmostEqual(r["pacing-native"], 1.1)
        # Through OpenXR, over OpenXR's own native.
        self.assertAlmostEqual(r["latency-xr-split/native"], 0.75)
        self.assertAlmostEqual(r["pacing-xr-split"], 1.1)
        self.assertAlmostEqual(r["pacing-xr-native"], 1.25)

    def test_results_from_before_latency_get_no_latency_ratio(self):
        old = {"path": "direct", "native": quartiles(200.0), "split": quartiles(100.0), "periphery": None}
        r = paper.path_ratios(old)
        self.assertFalse([name for name in r if name.startswith(("latency-", "pacing-"))])

    def final_lines(self, p):
        stages = {"tile_wait": 10.0, "exposed_share": 0.05, "tile_bytes": 100, "raw_bytes": 400}
        res = {"native": p["native"], "split": p["split"], "stages": stages, "per_path": [p]}
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            paper.print_final_lines(res)
        return out.getvalue().splitlines()

    def test_the_bench_ends_with_the_latency_and_pacing_lines(self):
        lines = self.final_lines(self.summary())
        self.assertEqual([line.split(":")[0] for line in lines],
                         ["split/native", "tile-wait/frame", "exposed-wait/frame", "tile-bytes/raw", "swapped/native",
                          "latency-split/native", "latency-swapped/native", "pacing-split", "pacing-swapped"])
        self.assertEqual(lines[0], "split/native: 0.500")
        self.assertEqual(lines[4], "swapped/native: 1.250")
        self.assertEqual(lines[5:], ["latency-split/native: 0.833", "latency-swapped/native: 2.000",
                                     "pacing-split: 1.300", "pacing-swapped: 1.800"])

    def test_without_the_swapped_split_its_lines_are_left_out(self):
        lines = self.final_lines(self.summary(swapped=False))
        self.assertEqual(lines[-2:], ["latency-split/native: 0.833", "pacing-split: 1.300"])
        self.assertFalse([line for line in lines if "swapped" in line])

    def test_the_ratio_lines_before_them_leave_the_final_ones_out(self):
        res = {"per_path": [self.summary(xr=True)], "config": {}}
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            paper.print_ratio_lines(res)
        names = [line.split(":")[0] for line in out.getvalue().splitlines()]
        self.assertIn("latency-xr-split/native", names)
        self.assertIn("pacing-native", names)
        for name in paper.FINAL_LATENCY_LINES:
            self.assertNotIn(name, names)

    def test_every_mode_measured_gets_a_row(self):
        rows = paper.latency_table(self.summary(xr=True))
        self.assertEqual([label for label, _, _ in rows],
                         ["native (the layer, no agent)", "split", "swapped split", "native through OpenXR",
                          "split through OpenXR"])
        markdown = "\n".join(paper.latency_markdown({"per_path": [self.summary()]}))
        self.assertIn("| swapped split | 250.00 | 450.00 | 1.800 | 360.00 | 500.00 |", markdown)
        self.assertIn("`pacing-swapped: 1.800`", markdown)
        self.assertEqual(paper.latency_markdown({"per_path": [{"native": quartiles(1.0)}]}), [])


class Usage(unittest.TestCase):
    def test_agent_scissor_takes_guard_n_only(self):
        self.assertEqual(paper.guard_setting("guard:64"), "guard:64")
        self.assertEqual(paper.guard_setting("guard:0"), "guard:0")
        for bad in ("off", "guard", "guard:", "guard:-1", "guard:6x", "scissor:4"):
            with self.assertRaises(argparse.ArgumentTypeError, msg=bad):
                paper.guard_setting(bad)

    def test_eye_size_takes_w_x_h(self):
        self.assertEqual(paper.eye_size("1200x1080"), (1200, 1080))
        for bad in ("1200", "1200x", "x1080", "12x1080", "1200x1080x2", "-1x5", "axb", "20000x100"):
            with self.assertRaises(argparse.ArgumentTypeError, msg=bad):
                paper.eye_size(bad)

    def test_xr_takes_per_eye_render_paths_only(self):
        paper.check_xr_paths(["direct", "hdr", "deferred"])
        for bad in (["multiview"], ["direct", "compute"], ["secondary"]):
            with self.assertRaises(paper.common.BenchError, msg=bad):
                paper.check_xr_paths(bad)

    def test_the_command_line_takes_xr_and_eye_size(self):
        parser = argparse.ArgumentParser()
        paper.register(parser.add_subparsers(dest="command"))
        args = parser.parse_args(["paper", "--xr", "--eye-size", "640x480", "--quick"])
        self.assertTrue(args.xr)
        self.assertEqual(args.eye_size, (640, 480))
        args = parser.parse_args(["paper"])
        self.assertFalse(args.xr)
        self.assertIsNone(args.eye_size)

    def test_render_paths(self):
        self.assertEqual(paper.path_names("hdr,direct,hdr"), ["hdr", "direct"])
        self.assertEqual(paper.path_names("all"), list(paper.RENDER_PATHS))
        with self.assertRaises(argparse.ArgumentTypeError):
            paper.path_names("forward")



class Pictures(unittest.TestCase):
    def test_the_foveae_are_centred_in_each_eye(self):
        self.assertEqual(paper.stereo_foveae(2400, 1080, "512x360"), [(344, 360, 512, 360), (1544, 360, 512, 360)])

    def test_a_fovea_larger_than_the_eye_is_the_eye(self):
        self.assertEqual(paper.stereo_foveae(400, 200, "512x360"), [(0, 0, 200, 200), (200, 0, 200, 200)])

    def test_auto_compares_at_the_papers_fovea(self):
        self.assertEqual(paper.stereo_foveae(2400, 1080, "auto:0.6x0.6"), paper.stereo_foveae(2400, 1080, "512x360"))

    def test_the_periphery_carries_all_of_the_error(self):
        # Half the pixels are foveae painted alike: the error over the periphery is twice the frame's
        # (3 dB less PSNR), and its dissimilarity twice the frame's.
        ssim, psnr = paper.periphery_scores(0.98, 40.0, 0.5)
        self.assertAlmostEqual(ssim, 0.96)
        self.assertAlmostEqual(psnr, 40.0 + 10 * math.log10(0.5))
        self.assertEqual(paper.periphery_scores(1.0, float("inf"), 0.5), (1.0, float("inf")))

if __name__ == "__main__":
    unittest.main()
