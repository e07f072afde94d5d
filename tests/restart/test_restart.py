#!/usr/bin/python3
"""Restart checkpoints through the case runner, with the bridge's stand-in participants as solvers (dummy_case/):
a run killed with SIGKILL and resumed ends bit for bit as the uninterrupted one under every scheme; checkpoint
folders keep the newest two; a mismatched or incomplete checkpoint is refused in one line, with nothing written.

Run: /usr/bin/python3 -m unittest -v test_restart (from this folder, RAILCOSIM_BUILD set), or ctest -R restart_.
"""
import glob
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
RUNNER = os.path.join(ROOT, "tools", "run_case.py")
CASE = os.path.join(HERE, "dummy_case")
sys.path.insert(0, HERE)
from restart_case import COMPLETE, children, kill_groups  # noqa: E402  (a runner's solvers; a complete checkpoint folder)
# Waits for what takes well under a second on an idle machine, on a loaded 2-core one.
SLOW_S = 30.0


def environment():
    env = dict(os.environ, RAILCOSIM_ROOT=ROOT, PYTHONPATH=os.path.join(ROOT, "python"), PYTHONDONTWRITEBYTECODE="1")
    env.setdefault("RAILCOSIM_BUILD", os.path.join(ROOT, "build"))
    for variable in ("RAILCOSIM_CHECKPOINT_DIR", "RAILCOSIM_CHECKPOINT_EVERY", "RAILCOSIM_CHECKPOINT_RUN",
                     "RAILCOSIM_RESUME"):
        env.pop(variable, None)
    if "ASAN_OPTIONS" in env:
        # Under tools/sanitize.sh: the runner starts the solvers through stdbuf, whose preloaded library comes before
        # ASan's runtime; it only sets the output buffering, so ASan's check of the library order is waived.
        env["ASAN_OPTIONS"] += ":verify_asan_link_order=0"
    return env


def run(*arguments, case=CASE):
    """Runs the case runner to its end: (exit code, stdout, stderr)."""
    done = subprocess.run([sys.executable, RUNNER, case, *arguments], env=environment(), capture_output=True, text=True,
                          timeout=120)
    return done.returncode, done.stdout, done.stderr


def run_and_kill(out, *arguments):
    """Runs with checkpoints; once the first is complete, SIGKILL to both solvers' process groups. Returns the name
    of the checkpoint that had landed."""
    runner = subprocess.Popen([sys.executable, RUNNER, CASE, "--out", out, *arguments], env=environment(),
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.monotonic() + SLOW_S
    landed = []
    while not landed and time.monotonic() < deadline and runner.poll() is None:
        landed = glob.glob(os.path.join(out + ".partial-*", "checkpoints", COMPLETE))
        time.sleep(0.01)
    if not landed:
        runner.kill()
        raise AssertionError(f"no checkpoint was complete within {SLOW_S:.0f} s (runner exit {runner.poll()})")
    kill_groups(children(runner.pid))
    if runner.wait(timeout=SLOW_S) == 0:
        raise AssertionError("the run finished before its solvers could be killed; slow them down (compute_ms)")
    return os.path.basename(landed[0])


def tree(folder):
    """{relative path: (size, mtime, sha256)} of every file under folder."""
    files = {}
    for base, _, names in os.walk(folder):
        for name in names:
            path = os.path.join(base, name)
            with open(path, "rb") as f:
                digest = hashlib.sha256(f.read()).hexdigest()
            files[os.path.relpath(path, folder)] = (os.path.getsize(path), os.stat(path).st_mtime_ns, digest)
    return files


def read(path):
    with open(path) as f:
        return f.read()


class RestartTestCase(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="railcosim-restart-test-")

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)


class ResumeTest(RestartTestCase):
    def check_scheme(self, scheme, *settings):
        options = ["--set", f"scheme={scheme}", *settings]
        reference = os.path.join(self.tmp, f"{scheme}-uninterrupted")
        code, out, err = run("--out", reference, *options)
        self.assertEqual(code, 0, out + err)
        interrupted = os.path.join(self.tmp, f"{scheme}-interrupted")
        landed = run_and_kill(interrupted, "--checkpoint-every", "0.005", *options)
        summary = json.loads(read(os.path.join(interrupted, "summary.json")))
        self.assertEqual(summary["status"], "failed")
        code, out, err = run("--resume", interrupted, *options)
        self.assertEqual(code, 0, out + err)
        resumed = json.loads(read(os.path.join(interrupted, "summary.json")))
        self.assertGreaterEqual(resumed["resumed_from"]["checkpoint"], landed)
        for side in ("fem", "dem"):
            self.assertEqual(read(os.path.join(interrupted, f"{side}_result.txt")),
                             read(os.path.join(reference, f"{side}_result.txt")), f"{scheme}: {side} differs")
        self.assertEqual(resumed["metrics"], json.loads(read(os.path.join(reference, "summary.json")))["metrics"])
        # Each solver's log goes on in the interrupted run's log.
        self.assertIn("---- resumed from", read(os.path.join(interrupted, "dem.log")))

    def test_just_in_time(self):
        self.check_scheme("justInTime")

    def test_predictive(self):
        self.check_scheme("predictive")

    def test_implicit_with_aitken(self):
        # A stiff bed: several passes per window, Aitken's factor carried from window to window.
        self.check_scheme("implicit", "--set", "contact_stiffness=2.5e7")


class FolderTest(RestartTestCase):
    def test_newest_two_complete_checkpoints_are_kept(self):
        out = os.path.join(self.tmp, "run")
        code, stdout, stderr = run("--out", out, "--checkpoint-every", "0.005", "--set", "compute_ms=0")
        self.assertEqual(code, 0, stdout + stderr)
        self.assertEqual(sorted(os.listdir(os.path.join(out, "checkpoints"))), ["window-00000350", "window-00000400"])
        manifest = json.loads(read(os.path.join(out, "checkpoints", "window-00000400", "manifest.json")))
        self.assertEqual((manifest["window"], manifest["scheme"]), (400, "predictive"))
        self.assertEqual(sorted(f["side"] for f in manifest["files"]), ["dem", "fem"])
        summary = json.loads(read(os.path.join(out, "summary.json")))
        self.assertEqual(summary["checkpoints"], {"every_s": 0.005, "folder": "checkpoints", "latest": "window-00000400"})


class RefusalTest(RestartTestCase):
    """Each refusal: exit 2, one line on stderr saying what is wrong, the results folder untouched."""

    @classmethod
    def setUpClass(cls):
        cls.source = tempfile.mkdtemp(prefix="railcosim-restart-refusals-")
        cls.interrupted = os.path.join(cls.source, "interrupted")
        run_and_kill(cls.interrupted, "--checkpoint-every", "0.005")

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.source, ignore_errors=True)

    def setUp(self):
        super().setUp()
        self.folder = os.path.join(self.tmp, "interrupted")
        shutil.copytree(self.interrupted, self.folder)
        self.checkpoint = sorted(glob.glob(os.path.join(self.folder, "checkpoints", COMPLETE)))[-1]

    def assertRefused(self, *fragments, options=(), case=CASE):
        before = tree(self.folder)
        code, stdout, stderr = run("--resume", self.folder, *options, case=case)
        lines = [line for line in stderr.splitlines() if line.strip()]
        self.assertEqual(code, 2, stdout + stderr)
        self.assertEqual(len(lines), 1, stderr)
        self.assertTrue(lines[0].startswith("railcosim run: "), lines[0])
        for fragment in fragments:
            self.assertIn(fragment, lines[0])
        self.assertEqual(tree(self.folder), before, "the refused resume changed the results folder")

    def edit_manifest(self, change):
        path = os.path.join(self.checkpoint, "manifest.json")
        manifest = json.loads(read(path))
        change(manifest)
        with open(path, "w") as f:
            json.dump(manifest, f)

    def test_other_protocol_version(self):
        self.edit_manifest(lambda m: m.update(protocol_version=3))
        self.assertRefused("protocol version 3", "this build speaks version 4")

    def test_checksum_mismatch(self):
        path = os.path.join(self.checkpoint, "dem_state.bin")
        with open(path, "r+b") as f:
            f.seek(100)
            byte = f.read(1)
            f.seek(100)
            f.write(bytes([byte[0] ^ 1]))
        self.assertRefused("is damaged", "dem_state.bin", "CRC-32")

    def test_missing_file(self):
        os.remove(os.path.join(self.checkpoint, "fem_state.bin"))
        self.assertRefused("is incomplete", "fem_state.bin", "missing")

    def test_no_complete_checkpoint(self):
        # Only interrupted saves: folders without their manifest are never resumed from.
        for folder in glob.glob(os.path.join(self.folder, "checkpoints", COMPLETE)):
            os.remove(os.path.join(folder, "manifest.json"))
        self.assertRefused("no complete checkpoint")

    def test_parameter_mismatch(self):
        self.assertRefused("other parameters", "windows = 400 there, 500 here", options=("--set", "windows=500"))

    def test_other_case(self):
        self.assertRefused("the interrupted run was of case dummy_case, not of standin_case",
                           case=os.path.join(ROOT, "tests", "launcher", "standin_case"))

    def test_checkpoint_of_another_run(self):
        self.edit_manifest(lambda m: m.update(run="case=another parameters=sha256:0"))
        self.assertRefused("belongs to another run")

    def test_finished_run(self):
        path = os.path.join(self.folder, "summary.json")
        summary = json.loads(read(path))
        summary["status"] = "ok"
        with open(path, "w") as f:
            json.dump(summary, f)
        self.assertRefused("that run finished (status ok); there is nothing to resume")

    def test_not_a_results_folder(self):
        os.remove(os.path.join(self.folder, "parameters.json"))
        self.assertRefused("not a results folder")


if __name__ == "__main__":
    unittest.main()
