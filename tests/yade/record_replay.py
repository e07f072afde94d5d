"""Record and replay with the real solvers: the template case run with --record, then each side played back
from the recording into a fresh run of the other solver (./railcosim run --replay-fem / --replay-dem).

Oracle: YADE (one thread) and FreeFEM are deterministic, so a live solver fed the recorded messages must
send back exactly its recorded answers: the replay compares every value and must find a largest relative
difference of 0 (bit for bit; its pass tolerance is 1e-12)."""
import json
import os
import subprocess
import sys
import tempfile

railcosim = sys.argv[1]
case = os.path.join(os.path.dirname(railcosim), "cases", "_template")
failures = []


def run(*arguments):
    result = subprocess.run([railcosim, "run", case, "--smoke", "--force", *arguments], capture_output=True, text=True)
    print(result.stdout[-2000:], result.stderr[-2000:])
    return result.returncode


with tempfile.TemporaryDirectory(prefix="railcosim-replay-") as folder:
    recorded = os.path.join(folder, "recorded")
    if run("--record", "--out", recorded) != 0:
        sys.exit("FAIL: the recording run failed")
    recording = os.path.join(recorded, "interface.rec")
    if not os.path.getsize(recording) > 0:
        sys.exit("FAIL: no recording written")
    for side in ("fem", "dem"):
        out = os.path.join(folder, f"replay-{side}")
        code = run(f"--replay-{side}", recording, "--out", out)
        with open(os.path.join(out, "summary.json")) as f:
            result = json.load(f)["replay"]["result"] or ""
        ok = code == 0 and "railcosim_replay: OK" in result and "largest relative difference 0.000e+00" in result
        print(f"{'ok  ' if ok else 'FAIL'} replaying the {side} side: exit {code}; {result}")
        if not ok:
            failures.append(side)
    # A recording that is not one is refused before anything runs, in one line, with exit 2.
    bogus = os.path.join(folder, "bogus.rec")
    with open(bogus, "w") as f:
        f.write("not a recording\n")
    code = run("--replay-fem", bogus, "--out", os.path.join(folder, "bogus"))
    print(f"{'ok  ' if code == 1 else 'FAIL'} a file that is not a recording fails the run (exit {code})")
    if code != 1:
        failures.append("bogus")
sys.exit(f"FAIL: {failures}" if failures else 0)
