#!/usr/bin/python3
"""Tests of `./railcosim bench`: records go where they are asked to go, never silently into the tracked
benchmarks/results/. Needs the bridge benchmark of the build (RAILCOSIM_BUILD); run: ctest -R launcher_Bench.
"""
import hashlib
import json
import os
import subprocess
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
CLI = os.path.join(ROOT, "railcosim")
TRACKED = os.path.join(ROOT, "benchmarks", "results")
# A tiny bridge benchmark: one small interface over ipc, the minimum of 20 windows.
SMALL_BRIDGE = ["--nodes", "64", "--transports", "ipc", "--total-bytes", "1"]


def snapshot(folder):
    """{name: content digest} of every file under folder."""
    digests = {}
    for base, _, names in os.walk(folder):
        for name in names:
            path = os.path.join(base, name)
            with open(path, "rb") as f:
                digests[os.path.relpath(path, folder)] = hashlib.sha256(f.read()).hexdigest()
    return digests


def bench(*args):
    return subprocess.run([CLI, "bench", *args], capture_output=True, text=True, timeout=300)


class BenchTest(unittest.TestCase):
    def test_out_folder_gets_the_record_and_tracked_records_stay(self):
        before = snapshot(TRACKED)
        with tempfile.TemporaryDirectory() as out:
            done = bench("bridge", "--out", out, *SMALL_BRIDGE)
            self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
            with open(os.path.join(out, "bridge_cost.json")) as f:
                record = json.load(f)
            self.assertEqual(record["rows"][0]["nodes"], 64)
            self.assertIn(f"records written to {os.path.realpath(out)}", done.stdout)
            self.assertIn("--save", done.stdout)  # says how to write the tracked records
        self.assertEqual(snapshot(TRACKED), before)

    def test_out_and_save_exclude_each_other(self):
        with tempfile.TemporaryDirectory() as out:
            done = bench("bridge", "--save", "--out", out)
            self.assertEqual(done.returncode, 2)
            self.assertIn("exclude each other", done.stderr)
            self.assertEqual(os.listdir(out), [])

    def test_unknown_benchmark_is_refused_before_anything_runs(self):
        done = bench("nonsense", "--save")
        self.assertEqual(done.returncode, 2)
        self.assertIn("usage: ./railcosim bench", done.stderr)


if __name__ == "__main__":
    unittest.main()
