#!/usr/bin/python3
"""Tests of `railcosim campaign` (tools/campaign.py, python/railcosim/campaign.py).

PlanTest (label launcher): the plan of a campaign file (points, seeds, folders, refusals), the statistics and
the sbatch script, without solvers. LocalPoolTest (label case): a 2 x 2 campaign of the template case's smoke
run in the local pool: index and aggregates, a re-run skips every run, a removed run is redone, SIGINT mid-run
leaves no unfinished run counted as done. SlurmTest (label slurm): the same campaign through sbatch on the
one-node cluster of tools/local_slurm.sh gives the local pool's index (the runs are deterministic).
Run: ctest -R campaign, or /usr/bin/python3 -m unittest -v test_campaign from this folder under `railcosim env`.
"""
import csv
import json
import os
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
RAILCOSIM = os.path.join(ROOT, "railcosim")
sys.path[:0] = [os.path.join(ROOT, "python"), os.path.join(ROOT, "tools")]
from railcosim import campaign  # noqa: E402  (needs the path above)
from railcosim.parameters import ParameterError  # noqa: E402

TEMPLATE = os.path.join(ROOT, "cases", "_template")
# Columns that differ between two executions of the same deterministic runs.
TIMING_COLUMNS = ("wall_time_s",)
SLOW_S = 120.0  # a smoke run of the template takes 2-10 s on a loaded 2-core machine


def write_campaign(folder, out, extra=""):
    path = os.path.join(folder, "campaign.toml")
    with open(path, "w") as f:
        f.write(f'case = "{TEMPLATE}"\nsmoke = true\nrepetitions = 2\nseed = 5\nout = "{out}"\n'
                f'[set]\nscheme = "predictive"\n[grid]\nfem_dt = [5.0e-4, 1.0e-3]\n{extra}')
    return path


def summary_of(out, row):
    with open(os.path.join(out, row["run"], "summary.json")) as f:
        return json.load(f)


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def run_campaign(*args):
    return subprocess.run([RAILCOSIM, "campaign", *args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, timeout=600)


def summary_times(out):
    return {row["run"]: os.stat(os.path.join(out, row["run"], "summary.json")).st_mtime_ns
            for row in read_csv(os.path.join(out, "campaign.csv"))}


class PlanTest(unittest.TestCase):
    def setUp(self):
        self.folder = tempfile.mkdtemp(prefix="campaign-plan-")
        self.addCleanup(shutil.rmtree, self.folder, ignore_errors=True)

    def plan(self, extra=""):
        return campaign.build_plan(campaign.load_spec(write_campaign(self.folder, "out", extra)))

    def test_grid_points_and_seeds(self):
        plan = self.plan('[[points]]\nfem_dt = 2.0e-3\nscheme = "implicit"\n')
        self.assertEqual([(r["point"], r["repetition"], r["seed"]) for r in plan["runs"]],
                         [("fem_dt-0.0005", 0, 5), ("fem_dt-0.0005", 1, 6), ("fem_dt-0.001", 0, 5),
                          ("fem_dt-0.001", 1, 6), ("fem_dt-0.002_scheme-implicit", 0, 5),
                          ("fem_dt-0.002_scheme-implicit", 1, 6)])
        self.assertEqual(plan["runs"][5]["settings"], {"scheme": "implicit", "fem_dt": "0.002", "seed": "6"})
        self.assertEqual(len({r["folder"] for r in plan["runs"]}), 6)
        self.assertEqual(plan["swept"], ["fem_dt", "scheme"])

    def test_refusals_before_any_run(self):
        with self.assertRaisesRegex(ParameterError, "fem_dt"):
            self.plan("[[points]]\nfem_dt = -1.0\n")
        with self.assertRaisesRegex(campaign.CampaignError, "base"):
            self.plan("[[points]]\nseed = 3\n")
        with self.assertRaisesRegex(campaign.CampaignError, "unknown entries"):
            self.plan("[slurmm]\npartition = 'x'\n")
        with self.assertRaisesRegex(ParameterError, "unknown parameter"):
            self.plan("[[points]]\nfem_dtt = 1.0e-3\n")

    def test_statistics_match_the_library(self):
        values = [1.0, 2.5, 4.0, 7.25]
        stats = campaign.statistics(values)
        self.assertAlmostEqual(stats["mean"], statistics.mean(values), places=14)
        self.assertAlmostEqual(stats["std"], statistics.stdev(values), places=14)
        self.assertEqual((stats["min"], stats["max"]), (1.0, 7.25))
        self.assertEqual(campaign.statistics([3.0])["std"], 0.0)

    def test_sbatch_script(self):
        plan = self.plan('[slurm]\npartition = "short"\naccount = "rail"\ntime = "01:00:00"\n'
                         'modules = ["freefem/4.13"]\nsetup = ["echo ready"]\nmax_parallel = 3\n'
                         'options = ["--qos=low"]\n')
        script = campaign.slurm_script(plan, "/scratch/c", [0, 1, 2, 5])
        for line in ("#SBATCH --array=0-2,5%3", "#SBATCH --partition=short", "#SBATCH --account=rail",
                     "#SBATCH --time=01:00:00", "#SBATCH --cpus-per-task=2", "#SBATCH --qos=low",
                     "module load freefem/4.13", "echo ready"):
            self.assertIn(line + "\n", script)
        self.assertIn(f"campaign --task /scratch/c \"$SLURM_ARRAY_TASK_ID\"", script)


class LocalPoolTest(unittest.TestCase):
    def setUp(self):
        self.folder = tempfile.mkdtemp(prefix="campaign-pool-")
        self.addCleanup(shutil.rmtree, self.folder, ignore_errors=True)
        self.out = os.path.join(self.folder, "out")
        self.file = write_campaign(self.folder, self.out)

    def test_runs_skips_and_redoes(self):
        result = run_campaign(self.file)
        self.assertEqual(result.returncode, 0, result.stdout)
        self.assertIn("1 run(s) at a time" if campaign.default_jobs()[0] == 1 else "run(s) at a time", result.stdout)
        rows = read_csv(os.path.join(self.out, "campaign.csv"))
        self.assertEqual(len(rows), 4)
        self.assertEqual([r["seed"] for r in rows], ["5", "6", "5", "6"])
        for row in rows:
            with open(os.path.join(self.out, row["run"], "summary.json")) as f:
                summary = json.load(f)
            self.assertEqual(summary["status"], "ok")
            self.assertEqual(summary["parameters"]["seed"], int(row["seed"]))
            self.assertEqual(summary["parameters"]["fem_dt"], float(row["fem_dt"]))
            self.assertEqual(float(row["metrics.carried_force_n"]), summary["metrics"]["carried_force_n"])
        aggregates = read_csv(os.path.join(self.out, "aggregates.csv"))
        self.assertEqual(len(aggregates), 2)
        for point in aggregates:
            values = [float(r["metrics.carried_force_n"]) for r in rows if r["point"] == point["point"]]
            self.assertAlmostEqual(float(point["metrics.carried_force_n.mean"]), statistics.mean(values), places=12)
            self.assertAlmostEqual(float(point["metrics.carried_force_n.std"]), statistics.stdev(values), places=12)
        self.assertTrue(os.path.isfile(os.path.join(self.out, "plots", "carried_force_n.png")))
        # The template reports its interface energy error against its reference: the speed-vs-error plot's y,
        # aggregated like the metrics.
        self.assertEqual(float(rows[0]["relative_error.interface_energy"]),
                         summary_of(self.out, rows[0])["relative_error"]["interface_energy"])
        self.assertIn("relative_error.interface_energy.mean", aggregates[0])
        self.assertTrue(os.path.isfile(os.path.join(self.out, "plots", "speed_vs_error_interface_energy.png")))

        before = summary_times(self.out)
        again = run_campaign(self.file)
        self.assertEqual(again.returncode, 0, again.stdout)
        self.assertIn("0 to run, 4 finished before", again.stdout)
        self.assertEqual(summary_times(self.out), before)

        removed = rows[1]["run"]
        shutil.rmtree(os.path.join(self.out, removed))
        redo = run_campaign(self.file)
        self.assertEqual(redo.returncode, 0, redo.stdout)
        self.assertIn("1 to run, 3 finished before", redo.stdout)
        after = summary_times(self.out)
        self.assertEqual([k for k in after if after[k] != before[k]], [removed])

    def test_unfinished_runs_are_indexed_not_aggregated(self):
        file = os.path.join(self.folder, "limited.toml")  # every run stopped by its time limit
        with open(self.file) as f, open(file, "w") as g:
            g.write("time_limit_s = 0.3\n" + f.read())
        result = run_campaign(file)
        self.assertEqual(result.returncode, 1, result.stdout)
        rows = read_csv(os.path.join(self.out, "campaign.csv"))
        self.assertEqual([(r["status"], r["checks_passed"]) for r in rows], [("time_limit", "")] * 4)
        aggregates = read_csv(os.path.join(self.out, "aggregates.csv"))
        self.assertEqual([(a["runs"], a["finished"], a["wall_time_s.mean"]) for a in aggregates], [("2", "0", "")] * 2)
        self.assertIn("4 failed", result.stdout)
        self.assertIn("4 to run, 0 finished before", run_campaign(file).stdout)  # none finished: all again

    def test_sigint_mid_run_counts_no_unfinished_run(self):
        campaign_process = subprocess.Popen([RAILCOSIM, "campaign", self.file, "--jobs", "1"], stdout=subprocess.PIPE,
                                            stderr=subprocess.STDOUT, text=True, start_new_session=True)
        self.addCleanup(lambda: campaign_process.poll() is None and os.killpg(campaign_process.pid, signal.SIGKILL))
        runs = os.path.join(self.out, "runs")
        deadline = time.monotonic() + SLOW_S
        # The second run in progress: one finished run before the signal, one interrupted by it.
        while time.monotonic() < deadline:
            partial = [d for d, _, _ in os.walk(runs) if ".partial-" in os.path.basename(d)]
            done = [d for d, _, files in os.walk(runs) if "summary.json" in files and ".partial-" not in d]
            if done and partial:
                break
            time.sleep(0.05)
        else:
            self.fail("no second run started within the time allowed")
        in_progress = os.path.relpath(partial[0].split(".partial-")[0], self.out)
        os.killpg(campaign_process.pid, signal.SIGINT)
        output, _ = campaign_process.communicate(timeout=SLOW_S)
        self.assertEqual(campaign_process.returncode, 128 + signal.SIGINT, output)
        self.assertIn("stopped by SIGINT", output)
        rows = {r["run"]: r for r in read_csv(os.path.join(self.out, "campaign.csv"))}
        self.assertNotEqual(rows[in_progress]["status"], "ok")
        counted = [run for run, row in rows.items() if row["status"] == "ok"]
        self.assertLess(len(counted), 4)
        for run in counted:  # counted as done: a complete, renamed run folder
            with open(os.path.join(self.out, run, "summary.json")) as f:
                self.assertEqual(json.load(f)["status"], "ok")
        leftovers = [d for d, _, _ in os.walk(runs) if ".partial-" in d]
        self.assertEqual(leftovers, [])
        resumed = run_campaign(self.file)
        self.assertEqual(resumed.returncode, 0, resumed.stdout)
        self.assertIn(f"{4 - len(counted)} to run, {len(counted)} finished before", resumed.stdout)
        self.assertEqual({r["status"] for r in read_csv(os.path.join(self.out, "campaign.csv"))}, {"ok"})


def slurm_available():
    return all(shutil.which(tool) for tool in ("sbatch", "squeue", "slurmctld", "slurmd", "munged"))


@unittest.skipUnless(slurm_available(), "slurm-wlm and munge are not installed")
class SlurmTest(unittest.TestCase):
    def setUp(self):
        self.folder = tempfile.mkdtemp(prefix="campaign-slurm-")
        self.addCleanup(shutil.rmtree, self.folder, ignore_errors=True)
        script = os.path.join(ROOT, "tools", "local_slurm.sh")
        was_running = subprocess.run([script, "status"], capture_output=True).returncode == 0
        started = subprocess.run([script, "start"], capture_output=True, text=True, timeout=180)
        self.assertEqual(started.returncode, 0, started.stdout + started.stderr)
        if not was_running:
            self.addCleanup(subprocess.run, [script, "stop"], capture_output=True)
        conf = subprocess.run([script, "env"], capture_output=True, text=True).stdout.strip().split("=", 1)[1]
        os.environ["SLURM_CONF"] = conf

    def test_slurm_index_equals_local_pool_index(self):
        local_out, slurm_out = os.path.join(self.folder, "local"), os.path.join(self.folder, "slurm")
        file = write_campaign(self.folder, "unused", '[slurm]\ncpus_per_task = 2\ntime = "00:10:00"\npoll_s = 1\n')
        local = run_campaign(file, "--out", local_out)
        self.assertEqual(local.returncode, 0, local.stdout)
        submitted = run_campaign(file, "--out", slurm_out, "--scheduler", "slurm")
        self.assertEqual(submitted.returncode, 0, submitted.stdout)
        self.assertIn("as Slurm job array", submitted.stdout)
        # Each run went through sbatch: one array-task log per run, from the run's own output.
        logs = os.listdir(os.path.join(slurm_out, "slurm"))
        self.assertEqual(len([f for f in logs if f.endswith(".out")]), 4)
        strip = lambda rows: [{k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in rows]
        local_rows = read_csv(os.path.join(local_out, "campaign.csv"))
        slurm_rows = read_csv(os.path.join(slurm_out, "campaign.csv"))
        self.assertEqual(len(slurm_rows), 4)
        self.assertEqual(strip(slurm_rows), strip(local_rows))
        again = run_campaign(file, "--out", slurm_out, "--scheduler", "slurm")
        self.assertIn("0 to run, 4 finished before", again.stdout)
        self.assertNotIn("submitted", again.stdout)

        # While a submitted array is queued or running, the campaign is not submitted a second time.
        fresh = run_campaign(file, "--out", slurm_out, "--scheduler", "slurm", "--fresh", "--no-wait")
        self.assertEqual(fresh.returncode, 0, fresh.stdout)
        with open(os.path.join(slurm_out, "slurm", "job.json")) as f:
            job = json.load(f)["job"]
        twice = run_campaign(file, "--out", slurm_out, "--scheduler", "slurm")
        subprocess.run(["scancel", job])
        self.assertEqual(twice.returncode, 2, twice.stdout)
        self.assertIn(f"job array {job} of this campaign is still queued or running", twice.stdout)
        deadline = time.monotonic() + SLOW_S
        while campaign.queued_states(job) and time.monotonic() < deadline:
            time.sleep(0.5)


if __name__ == "__main__":
    unittest.main()
