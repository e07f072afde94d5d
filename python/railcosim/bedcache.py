"""Prepared beds and samples kept between runs: one file per set of defining parameters, under
$RAILCOSIM_CACHE/beds/CASE/, prepared by one run at a time (parallel runs of a campaign wait for the first one's file
instead of packing the same bed side by side).

    path = bedcache.path("lateral_resistance", {k: p[k] for k in KEYS}, fallback=os.path.join(out, "cache"))
    with bedcache.exclusive(path) as found:
        if not found:
            ... prepare, write path (whole or not at all: a temporary name, then os.replace)
    ... read path
"""
import contextlib
import fcntl
import hashlib
import json
import os


def key(values):
    """16 hex digits of a hash of `values`, the parameters (a JSON-able dict) that define the bed."""
    return hashlib.sha256(json.dumps(values, sort_keys=True).encode()).hexdigest()[:16]


def path(case, values, name="bed", suffix=".npz", folder=None, fallback=None):
    """Where the bed of `values` is kept: FOLDER/NAME-KEY.SUFFIX, FOLDER defaulting to $RAILCOSIM_CACHE/beds/CASE
    ($RAILCOSIM_CACHE: `fallback`, else ~/.cache/railcosim, when unset)."""
    if not folder:
        root = os.environ.get("RAILCOSIM_CACHE", fallback or os.path.expanduser("~/.cache/railcosim"))
        folder = os.path.join(root, "beds", case)
    return os.path.join(folder, f"{name}-{key(values)}{suffix}")


@contextlib.contextmanager
def exclusive(bed_path):
    """Holds the bed's lock (BED_PATH.lock) while the caller looks for the file and prepares it if missing; yields
    whether the file was there."""
    os.makedirs(os.path.dirname(bed_path), exist_ok=True)
    with open(bed_path + ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        yield os.path.isfile(bed_path)
