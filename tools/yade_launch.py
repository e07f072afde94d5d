#!/usr/bin/python3
"""Runs YADE's main script headless (-n -x) with its remote servers off: the one way railcosim starts YADE.

Usage: /usr/bin/python3 tools/yade_launch.py [YADE OPTIONS] SCRIPT.py [ARGS]   (RAILCOSIM_YADE_EXE set by
`railcosim`'s launcher_env; `./railcosim yade SCRIPT.py` is the usual way in)

Every start of YADE's main script calls yade.remote.runServers(), which opens a Python prompt on 0.0.0.0:9000
guarded by a 6-letter cookie drawn from "yadesucks" and printed to the log, and an unauthenticated XMLRPC
server on 0.0.0.0:21000. A coupled run needs neither, so this launcher imports nothing of YADE itself: it
hooks the import of yade.remote so that runServers() does nothing, then runs the unmodified main script
(the cached install is shared by every checkout and stays as YADE built it).

RAILCOSIM_YADE_SERVERS=localhost brings the two servers back for interactive debugging of a running
simulation, bound to 127.0.0.1 only, with a 128-bit cookie written to a 0600 file instead of the log.
Anyone on the machine can still call the XMLRPC server (read-only figures, and stop() pauses the run).
"""
import atexit
import builtins
import importlib.abc
import importlib.machinery
import os
import runpy
import sys

SERVERS_VARIABLE = "RAILCOSIM_YADE_SERVERS"
LOCALHOST = "127.0.0.1"
# YADE's own first ports; the next free one is taken when another YADE holds them.
PROMPT_PORT, INFO_PORT, PORTS_TRIED = 9000, 21000, 100


class LaunchError(Exception):
    """A launch that cannot start (no YADE, bad setting), reported in one line with what to do."""


def no_servers():
    """Replaces yade.remote.runServers: a headless coupled run is driven by its script, not over a socket."""


def localhost_servers():
    """yade.remote.runServers bound to 127.0.0.1, the cookie in a private file rather than in the log."""
    import secrets
    import socketserver
    from xmlrpc.server import SimpleXMLRPCServer

    import yade.remote
    import yade.runtime

    prompt, prompt_port = bind_first_free(
        lambda port: socketserver.ThreadingTCPServer((LOCALHOST, port), yade.remote.PythonConsoleSocketEmulator),
        PROMPT_PORT)
    prompt.cookie = secrets.token_hex(16)
    prompt.authenticated = []
    yade.runtime.cookie = prompt.cookie
    cookie_path = write_private_file(f"yade-{os.getpid()}.cookie", prompt.cookie + "\n")
    info, info_port = bind_first_free(
        lambda port: SimpleXMLRPCServer((LOCALHOST, port), logRequests=False, allow_none=True), INFO_PORT)
    info.register_instance(yade.remote.InfoProvider())
    yade.remote._runInBackground(prompt.serve_forever)
    yade.remote._runInBackground(info.serve_forever)
    sys.stderr.write(f"YADE Python prompt on {LOCALHOST}:{prompt_port} (auth cookie in {cookie_path}); "
                     f"XMLRPC info provider on http://{LOCALHOST}:{info_port}\n")


def bind_first_free(make_server, first_port):
    for port in range(first_port, first_port + PORTS_TRIED):
        try:
            return make_server(port), port
        except OSError:
            continue
    raise LaunchError(f"no free port on {LOCALHOST} in {first_port}-{first_port + PORTS_TRIED - 1} for YADE's "
                      f"servers; unset {SERVERS_VARIABLE} to run without them")


def write_private_file(name, text):
    """A file only this user can read, in a 0700 folder under the railcosim cache; removed at exit."""
    folder = os.path.join(os.environ.get("RAILCOSIM_CACHE") or os.path.expanduser("~/.cache/railcosim"), "yade-remote")
    os.makedirs(folder, mode=0o700, exist_ok=True)
    os.chmod(folder, 0o700)
    path = os.path.join(folder, name)
    if os.path.lexists(path):
        os.unlink(path)  # left by an earlier process with this PID that was killed
    with os.fdopen(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600), "w") as f:
        f.write(text)
    atexit.register(lambda: os.path.lexists(path) and os.unlink(path))
    return path


def servers_replacement():
    setting = os.environ.get(SERVERS_VARIABLE, "").strip().lower()
    if setting in ("", "0", "off", "no", "none"):
        return no_servers
    if setting in ("localhost", LOCALHOST):
        return localhost_servers
    raise LaunchError(f"{SERVERS_VARIABLE}={setting!r}: expected 'off' (the default) or 'localhost'")


class PatchedLoader(importlib.abc.Loader):
    """Delegates to the module's own loader, then applies `patch` to the fresh module."""

    def __init__(self, loader, patch):
        self.loader, self.patch = loader, patch

    def create_module(self, spec):
        return self.loader.create_module(spec)

    def exec_module(self, module):
        self.loader.exec_module(module)
        self.patch(module)

    def __getattr__(self, name):  # get_source and friends, for tracebacks through the module
        return getattr(self.loader, name)


class RemoteServersHook(importlib.abc.MetaPathFinder):
    """Import hook for yade.remote: the module is YADE's own, only its runServers is replaced."""

    def __init__(self, run_servers):
        self.run_servers = run_servers

    def find_spec(self, name, path, target=None):
        if name != "yade.remote":
            return None
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is not None and spec.loader is not None:
            spec.loader = PatchedLoader(spec.loader, self.patch)
        return spec

    def patch(self, module):
        module.runServers = self.run_servers


def main(arguments):
    exe = os.environ.get("RAILCOSIM_YADE_EXE", "")
    if not os.path.isfile(exe):
        raise LaunchError(f"RAILCOSIM_YADE_EXE={exe!r} is not YADE's main script; start YADE with "
                          "`./railcosim yade SCRIPT.py`, which sets it (run `./railcosim setup` first)")
    if not arguments:
        raise LaunchError("usage: yade_launch.py [YADE OPTIONS] SCRIPT.py [ARGS]")
    sys.meta_path.insert(0, RemoteServersHook(servers_replacement()))
    # What `python3 EXE -n -x ...` would see: argv, the script's folder first on sys.path, a __main__ module
    # whose __builtins__ is the module (exec alone would give the dict, unlike a script run by python).
    sys.argv = [exe, "-n", "-x", *arguments]
    sys.path[0] = os.path.dirname(os.path.realpath(exe))
    runpy.run_path(exe, init_globals={"__builtins__": builtins}, run_name="__main__")


if __name__ == "__main__":
    try:
        main(sys.argv[1:])
    except LaunchError as e:
        print(f"railcosim yade: {e}", file=sys.stderr)
        sys.exit(2)
