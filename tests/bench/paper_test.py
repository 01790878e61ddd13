"""The parts of scripts/bench paper that decide what is reported: the variants table, the ratios
and the usage errors. Timings themselves are never tested; these are the pure functions around them."""
import argparse
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


class Usage(unittest.TestCase):
    def test_agent_scissor_takes_guard_n_only(self):
        self.assertEqual(paper.guard_setting("guard:64"), "guard:64")
        self.assertEqual(paper.guard_setting("guard:0"), "guard:0")
        for bad in ("off", "guard", "guard:", "guard:-1", "guard:6x", "scissor:4"):
            with self.assertRaises(argparse.ArgumentTypeError, msg=bad):
                paper.guard_setting(bad)

    def test_render_paths(self):
        self.assertEqual(paper.path_names("hdr,direct,hdr"), ["hdr", "direct"])
        self.assertEqual(paper.path_names("all"), list(paper.RENDER_PATHS))
        with self.assertRaises(argparse.ArgumentTypeError):
            paper.path_names("forward")


if __name__ == "__main__":
    unittest.main()
