"""Restart checkpoints on the runner side: the run identity each manifest stores, the solvers' environment, and the
checks before a run resumes. The manifest rules themselves (completeness, protocol version, sizes and CRC-32) are
the bridge's, applied by its tool railcosim_checkpoint; docs/protocol.md section 12 describes the folder."""
import hashlib
import json
import math
import os
import subprocess

from railcosim.case import CaseError

FOLDER = "checkpoints"  # inside the results folder
# Parameters that say where a run is, not what it computes: they may differ between the run and its resumption.
LOCATION_KEYS = ("case_dir",)
ENVIRONMENT = ("RAILCOSIM_CHECKPOINT_DIR", "RAILCOSIM_CHECKPOINT_EVERY", "RAILCOSIM_CHECKPOINT_RUN", "RAILCOSIM_RESUME")


class ResumeRefused(CaseError):
    """A checkpoint or results folder a run cannot resume from; the message is one line."""


def _computed(params):
    return {key: value for key, value in params.items() if key not in LOCATION_KEYS}


def run_identity(name, params):
    """What identifies a run in its checkpoints' manifests: the case's name and a digest of its parameters."""
    text = json.dumps(_computed(params), sort_keys=True, separators=(",", ":"))
    return f"case={name} parameters=sha256:{hashlib.sha256(text.encode()).hexdigest()}"


def solver_environment(run_folder, identity, every_s=None, resume_from=None):
    """The variables both solvers read (FemCouplingEngine through railcosim.dem, the FreeFEM plugin directly)."""
    if every_s is None and resume_from is None:
        return {}
    environment = {"RAILCOSIM_CHECKPOINT_DIR": os.path.join(run_folder, FOLDER), "RAILCOSIM_CHECKPOINT_RUN": identity}
    if every_s is not None:
        environment["RAILCOSIM_CHECKPOINT_EVERY"] = repr(float(every_s))
    if resume_from is not None:
        environment["RAILCOSIM_RESUME"] = resume_from
    return environment


def tool():
    """The bridge's checkpoint tool: RAILCOSIM_CHECKPOINT_TOOL (a machine without the build, e.g. the GPU machine's
    runtime archive), else the build's."""
    return os.environ.get("RAILCOSIM_CHECKPOINT_TOOL") or os.path.join(
        os.environ.get("RAILCOSIM_BUILD", "build"), "bridge", "dummies", "railcosim_checkpoint")


def latest(run_folder):
    """The newest complete checkpoint folder of a results folder, or None."""
    found = subprocess.run([tool(), "latest", os.path.join(run_folder, FOLDER)], capture_output=True, text=True)
    return found.stdout.strip() if found.returncode == 0 and found.stdout.strip() else None


def verify(folder):
    """The manifest of a checkpoint folder ({name, window, time, scheme, run, ...}), checked by the bridge's rules."""
    checked = subprocess.run([tool(), "verify", folder], capture_output=True, text=True)
    if checked.returncode != 0:
        lines = [line for line in checked.stderr.splitlines() if line.strip()]
        raise ResumeRefused(lines[-1] if lines else f"{tool()} failed on {folder} (exit {checked.returncode})")
    return json.loads(checked.stdout)


def _differences(saved, current):
    keys = sorted(set(saved) | set(current))
    differing = [key for key in keys if key not in LOCATION_KEYS and key != "resolved"
                 and not _same(saved.get(key, "(absent)"), current.get(key, "(absent)"))]
    return [(key, saved.get(key, "(absent)"), current.get(key, "(absent)")) for key in differing]


def _same(a, b):
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    return a == b


def resume_checkpoint(folder, name, params):
    """(checkpoint folder, manifest) to resume the run in results folder `folder` from, after every check: a results
    folder of this case and these parameters, a complete checkpoint, its files intact, the same protocol version
    and run. Raises ResumeRefused (one line) otherwise; nothing is written."""
    if not os.path.isdir(folder):
        raise ResumeRefused(f"--resume {folder}: no such results folder")
    parameters_path = os.path.join(folder, "parameters.json")
    if not os.path.isfile(parameters_path):
        raise ResumeRefused(f"--resume {folder}: not a results folder of a run (no parameters.json)")
    summary_path = os.path.join(folder, "summary.json")
    if os.path.isfile(summary_path):
        with open(summary_path) as f:
            try:
                status = json.load(f).get("status")
            except ValueError:
                status = None
        if status == "ok":
            raise ResumeRefused(f"--resume {folder}: that run finished (status ok); there is nothing to resume")
    with open(parameters_path) as f:
        saved = json.load(f)
    saved_case = os.path.basename(str(saved.get("case_dir", "")))
    if saved_case and saved_case != os.path.basename(params.get("case_dir", "")):
        raise ResumeRefused(f"--resume {folder}: the interrupted run was of case {saved_case}, not of "
                            f"{os.path.basename(params.get('case_dir', ''))}; resume it with ./railcosim run "
                            f"cases/{saved_case} --resume {folder}")
    differences = _differences(saved, params)
    if differences:
        shown = "; ".join(f"{key} = {old!r} there, {new!r} here" for key, old, new in differences[:3])
        more = f" (and {len(differences) - 3} more)" if len(differences) > 3 else ""
        raise ResumeRefused(f"--resume {folder}: the interrupted run had other parameters: {shown}{more}; "
                            "resume with its case, --smoke and --set values")
    checkpoint = latest(folder)
    if checkpoint is None:
        raise ResumeRefused(f"--resume {folder}: no complete checkpoint in {os.path.join(folder, FOLDER)} "
                            "(the run stopped before its first checkpoint was complete, or ran without --checkpoint-every)")
    manifest = verify(checkpoint)
    identity = run_identity(name, params)
    if manifest["run"] != identity:
        raise ResumeRefused(f"checkpoint {checkpoint} belongs to another run ({manifest['run'] or 'unnamed'}), "
                            f"not to this one ({identity})")
    return checkpoint, manifest
