"""meshcat's server, listening on 127.0.0.1 only: ``python -m stewart_pin.viz._meshcat_server``.

meshcat 0.3.2 binds its ZMQ socket to 127.0.0.1 but starts its HTTP / websocket file
server with tornado's ``Application.listen(port)``, which listens on every interface
(0.0.0.0 and ::). This module runs meshcat's own server (``meshcat.servers.zmqserver``)
unchanged except that ``listen`` is given the address 127.0.0.1. It prints the same two
lines (``zmq_url=...``, ``web_url=...``) as ``meshcat-server``.

The server dies with the process that started it, whatever kills that process (SIGTERM,
SIGHUP, SIGKILL...): the parent passes its pid in ``STEWART_PIN_VIEWER_PARENT``; on
Linux the server asks the kernel for SIGKILL when its parent dies
(``prctl(PR_SET_PDEATHSIG)``, only when ``STEWART_PIN_VIEWER_PDEATHSIG=1``: the kernel
ties it to the parent *thread*, so the viewer sets it only when started from the main
thread), and on every system a watchdog thread exits as soon as the server's parent is no
longer that pid (re-parented: the parent is gone), within :data:`WATCHDOG_PERIOD`.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading
import time
from typing import Any

#: The one address the server may listen on.
HOST = "127.0.0.1"
#: Environment variable holding the parent's pid.
PARENT_ENV = "STEWART_PIN_VIEWER_PARENT"
#: Environment variable: "1" to ask for SIGKILL at the parent thread's death (Linux).
PDEATHSIG_ENV = "STEWART_PIN_VIEWER_PDEATHSIG"
#: Seconds between two checks of the watchdog on the parent.
WATCHDOG_PERIOD = 0.25
#: prctl option (linux/prctl.h).
_PR_SET_PDEATHSIG = 1


def _parent_death_signal() -> bool:
    """Ask the Linux kernel to SIGKILL this process when its parent (thread) dies."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):  # pragma: no cover - no prctl in this libc
        return False


def _watchdog(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(WATCHDOG_PERIOD)
    os._exit(0)


def die_with_parent() -> None:
    """Exit when the parent named in :data:`PARENT_ENV` is gone (see the module doc)."""
    try:
        parent = int(os.environ.get(PARENT_ENV, ""))
    except ValueError:
        parent = os.getppid()  # run by hand: watch whoever started us
    if os.environ.get(PDEATHSIG_ENV) == "1":
        _parent_death_signal()
    if os.getppid() != parent:  # the parent died before the signal was set up
        os._exit(0)
    threading.Thread(target=_watchdog, args=(parent,), daemon=True, name="watchdog").start()


def main() -> None:
    die_with_parent()
    try:
        import tornado.web
        from meshcat.servers import zmqserver
    except ImportError as e:  # pragma: no cover - checked by the viewer before starting us
        raise ImportError(
            "the viewer needs meshcat (and its tornado / pyzmq): pip install stewart-pin[viz]"
        ) from e

    listen = tornado.web.Application.listen

    def listen_local(self: Any, port: int, address: str | None = None, **kwargs: Any) -> Any:
        return listen(self, port, HOST, **kwargs)

    tornado.web.Application.listen = listen_local  # type: ignore[method-assign]
    sys.argv = sys.argv[:1]
    zmqserver.main()


if __name__ == "__main__":
    main()
