"""meshcat's server, listening on 127.0.0.1 only: ``python -m stewart_pin.viz._meshcat_server``.

meshcat 0.3.2 binds its ZMQ socket to 127.0.0.1 but starts its HTTP / websocket file
server with tornado's ``Application.listen(port)``, which listens on every interface
(0.0.0.0 and ::). This module runs meshcat's own server (``meshcat.servers.zmqserver``)
unchanged except that ``listen`` is given the address 127.0.0.1. It prints the same two
lines (``zmq_url=...``, ``web_url=...``) as ``meshcat-server``.
"""

from __future__ import annotations

import sys
from typing import Any

#: The one address the server may listen on.
HOST = "127.0.0.1"


def main() -> None:
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
