"""The meshcat server dies with the process that started it, whatever the signal.

A child Python process starts the viewer's server through the library (``_Server``), prints
the server's pid and port, then waits; the test kills that child and checks that the
server process is gone and its port closed within a few seconds. Linux: the kernel's
parent-death signal (the child started it from its main thread); a server started from a
worker thread relies on the watchdog on the parent's pid instead.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from urllib.parse import urlparse

import pytest

pytest.importorskip("meshcat")

#: Seconds the server may take to die after its parent (the watchdog polls every 0.25 s).
DEADLINE = 5.0

_CHILD = """
import sys, threading, time
from stewart_pin.viz.viewer import _Server

def start():
    global server
    server = _Server(quiet=True)

if sys.argv[1] == "thread":
    worker = threading.Thread(target=start)
    worker.start()
    worker.join()
    # keep the worker thread's creator alive: only the watchdog may end the server
    threading.Thread(target=time.sleep, args=(120,)).start()
else:
    start()
print(server.process.pid, server.web_url, flush=True)
time.sleep(120)
"""


def _gone(pid: int) -> bool:
    """The process no longer runs (absent, or a zombie waiting for its reaper)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except FileNotFoundError:
        return True
    except OSError:  # pragma: no cover - no /proc: ask the kernel
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return True
        return False
    return state in ("Z", "X")


def _port_open(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.settimeout(1.0)
        return s.connect_ex(("127.0.0.1", port)) == 0


def _socket_inodes(pid: int) -> set[str]:
    """Inodes of the sockets process ``pid`` holds open."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            link = os.readlink(fd)
        except FileNotFoundError:  # closed since the listing (the child runs on)
            continue
        if link.startswith("socket:["):
            inodes.add(link[8:-1])
    return inodes


def _listening(inodes: set[str]) -> set[str]:
    """Those of ``inodes`` still listening on a TCP port (another process may take the
    same port number once it is free: the test follows the server's own sockets)."""
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        with open(table) as f:
            for row in f.readlines()[1:]:
                fields = row.split()
                if fields[3] == "0A" and fields[9] in inodes:  # 0A: LISTEN
                    found.add(fields[9])
    return found


def _start_child(mode: str) -> tuple[subprocess.Popen, int, int]:
    env = dict(os.environ)
    src = str(Path(__file__).resolve().parents[1] / "src")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [src, env.get("PYTHONPATH")]))
    child = subprocess.Popen(
        [sys.executable, "-c", _CHILD, mode],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        stdin=subprocess.DEVNULL,
        env=env,
        text=True,
    )
    line = child.stdout.readline().split()
    if len(line) != 2:
        child.kill()
        child.wait()
        pytest.fail(f"the child did not start a server (printed {line})")
    pid, port = int(line[0]), urlparse(line[1]).port
    return child, pid, port


def _wait_gone(pid: int, sockets: set[str]) -> tuple[bool, set[str]]:
    """Wait until the process is gone and its sockets closed (a dying process's leader
    shows as a zombie while its other threads still close their files)."""
    deadline = time.monotonic() + DEADLINE
    while time.monotonic() < deadline and not (_gone(pid) and not _listening(sockets)):
        time.sleep(0.05)
    return _gone(pid), _listening(sockets)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux process model")
@pytest.mark.parametrize(
    ("mode", "sig"),
    [
        ("main", signal.SIGKILL),
        ("main", signal.SIGTERM),
        ("main", signal.SIGHUP),
        ("thread", signal.SIGKILL),
    ],
)
def test_viewer_server_dies_with_its_parent(mode, sig):
    child, pid, port = _start_child(mode)
    try:
        assert not _gone(pid) and _port_open(port)  # running and listening
        sockets = _socket_inodes(pid)
        assert _listening(sockets)  # the HTTP and ZMQ ports
        child.send_signal(sig)
        child.wait(timeout=10)
        dead, still = _wait_gone(pid, sockets)
    finally:
        if not _gone(pid):
            os.kill(pid, signal.SIGKILL)  # the server this test started: leave nothing
        if child.poll() is None:
            child.kill()
            child.wait()
    assert dead, f"the meshcat server (pid {pid}) outlived its parent killed by {sig.name}"
    assert not still, f"the server's ports still listen after the parent's {sig.name}"
