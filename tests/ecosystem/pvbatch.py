"""ParaView's pvbatch for the tests, on a virtual screen the tests start and stop themselves.

`xvfb-run -a` was not reliable enough on the busy 2-core CI machine: pvbatch aborted there
(exit 134) creating its render window, and xvfb-run then failed to remove its own temporary
folder (exit 5); the screen's log was gone with it. Here each run starts its own Xvfb, which picks
a free display number itself (`-displayfd`: no lock-file race between test workers), needs no
authority file (local connections only, `-nolisten tcp`), and keeps its log. A run that aborts
before ParaView reads the script (the X connection or its OpenGL) is run again on a fresh screen,
three times in all; what failed, with the screen's log, is in the returned record's stderr."""

from __future__ import annotations

import os
import select
import shutil
import subprocess
import tempfile
import time

ATTEMPTS = 3
SCREEN = "1280x1024x24"
START_S = 30.0  # the longest wait for a screen to accept clients


def pvbatch() -> str | None:
    """The pvbatch executable, or None where ParaView is not installed (or where there is no
    display and no Xvfb to make one)."""
    exe = shutil.which("pvbatch")
    if exe is None or not (os.environ.get("DISPLAY") or shutil.which("Xvfb")):
        return None
    return exe


def _start_screen(log) -> tuple[subprocess.Popen, str]:
    read, write = os.pipe()
    try:
        server = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", SCREEN, "-nolisten", "tcp",
                                   "-noreset"], pass_fds=(write,), stdin=subprocess.DEVNULL,
                                  stdout=log, stderr=log)
    finally:
        os.close(write)
    number = b""
    deadline = time.monotonic() + START_S
    with os.fdopen(read, "rb", buffering=0) as pipe:  # Xvfb writes the display number when it accepts clients
        while not number.endswith(b"\n") and time.monotonic() < deadline:
            if not select.select([pipe], [], [], max(deadline - time.monotonic(), 0.0))[0]:
                break
            chunk = pipe.read(16)
            if not chunk:
                break  # (the server closed it: it did not start)
            number += chunk
    if not number.strip():
        _stop_screen(server)
        return server, ""
    return server, ":" + number.decode().strip()


def _stop_screen(server: subprocess.Popen) -> None:
    if server.poll() is None:
        server.terminate()
        try:
            server.wait(timeout=30)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()


def _aborted_before_script(run: subprocess.CompletedProcess) -> bool:
    text = (run.stdout or "") + (run.stderr or "")
    return run.returncode in (134, -6) and any(
        mark in text for mark in ("RenderingCapabilities", "X server", "CreateAWindow", "GLX", "Could not find a decent"))


def run_pvbatch(args: list[str], *, cwd=None, env=None, timeout: float = 300) -> subprocess.CompletedProcess:
    """pvbatch with `args` (script and its options), output captured as text. On the caller's
    display when DISPLAY is set, else on a virtual screen of its own."""
    exe = pvbatch()
    assert exe is not None, "pvbatch not found"
    env = dict(os.environ if env is None else env)
    if env.get("DISPLAY"):
        return subprocess.run([exe] + args, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    notes = []
    for attempt in range(ATTEMPTS):
        with tempfile.TemporaryFile("w+") as log:
            server, display = _start_screen(log)
            try:
                if not display:
                    run = subprocess.CompletedProcess([exe] + args, 1, "", f"Xvfb gave no display within {START_S:g} s")
                else:
                    run = subprocess.run([exe] + args, cwd=cwd, env={**env, "DISPLAY": display},
                                         capture_output=True, text=True, timeout=timeout)
            finally:
                _stop_screen(server)
                log.seek(0)
                screen_log = log.read()
        if run.returncode == 0 or not (_aborted_before_script(run) or not display):
            break
        notes.append(f"attempt {attempt + 1}: exit {run.returncode} on display {display or '(none)'}; "
                     f"pvbatch said first: {(run.stderr or '')[:800]!r}; Xvfb log: {screen_log[-800:]!r}")
        print(f"pvbatch aborted before reading its script (exit {run.returncode}), run again on a fresh screen")
    if run.returncode != 0 and notes:
        run.stderr = (run.stderr or "") + "\n" + "\n".join(notes)
    return run


def failure(run: subprocess.CompletedProcess) -> str:
    """What a failed run printed: the start of its error output (where ParaView names the
    problem) and the end of both streams."""
    err = run.stderr or ""
    return f"exit {run.returncode}\n--- stderr, start:\n{err[:1500]}\n--- stdout, end:\n{(run.stdout or '')[-1500:]}" \
           f"\n--- stderr, end:\n{err[-2500:]}"
