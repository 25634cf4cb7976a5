"""Eclipse Zenoh transport: peer mode on explicit endpoints, no router, no multicast scouting.

The only module of masonry that imports ``zenoh``. Each endpoint subscribes to
``masonry/<mission>/to/<its name>`` and sends by putting on the addressee's key. Mission control listens
(``listen=["tcp/127.0.0.1:7447"]`` by default; a site network needs a real interface and a mission key,
docs/security.md); a UAV handler connects to it (``connect=["tcp/HOST:7447"]``) and listens only on loopback
(an ephemeral port) unless told otherwise, so it is not reachable from the network by accident.

``config_file``: a Zenoh configuration file (JSON5) read first, for what masonry does not set itself: TLS
certificates (``transport/link/tls``), access control (``access_control``), ... The endpoints, the mode and
scouting given here are then set over it.
"""

from __future__ import annotations

import json
import re
import threading
from collections import deque
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from typing_extensions import Self

from masonry.errors import DeviceNotFound, InputError, MissionError

DEFAULT_PORT = 7447
_HANDLER_LISTEN = ("tcp/127.0.0.1:0",)


def check_endpoint(endpoint: str) -> str:
    """Validate a Zenoh locator like ``tcp/HOST:PORT`` (raises MissionError naming it)."""
    proto, sep, rest = endpoint.partition("/")
    host, colon, port = rest.rpartition(":")
    if not sep or proto not in ("tcp", "udp", "tls", "quic") or not colon or not host or not port.isdigit():
        raise MissionError(f"endpoint {endpoint!r} is not of the form tcp/HOST:PORT")
    if not 0 <= int(port) <= 65535:
        raise MissionError(f"endpoint {endpoint!r}: port {port} out of range")
    return endpoint


_ERROR_CHARS = 160


def _one_line(exc: Exception) -> str:
    """Zenoh's multi-line configuration error (a JSON5 parser's caret diagram) as one line, without Rust paths."""
    text = re.sub(r" at /\S+\.rs:\d+\.?", "", str(exc)).strip()
    where = re.search(r"--> (\d+):(\d+)", text)
    what = re.search(r"^\s*= (.+)$", text, re.MULTILINE)
    if where and what:
        line = f"line {where.group(1)}, column {where.group(2)}: {what.group(1).strip()}"
    else:
        line = text.splitlines()[0] if text else type(exc).__name__
    # an unknown key makes zenoh list every key it knows: keep the line short
    return line if len(line) <= _ERROR_CHARS else line[:_ERROR_CHARS] + "..."


class ZenohTransport:
    """A named endpoint on a Zenoh peer session (implements :class:`~masonry.mission.transport.Transport`).

    Construct, then :meth:`connect` (or use it as a context manager).

    Args:
        name: this endpoint's name (a UAV name or ``"mission-control"``).
        listen: locators to listen on (default: loopback, ephemeral port).
        connect: locators of peers to connect to (retried until they appear).
        mission: key-space prefix, so several missions can share a network.
        config_file: a Zenoh configuration file read before the settings above (TLS, access control).
    """

    def __init__(
        self,
        name: str,
        *,
        listen: Sequence[str] = _HANDLER_LISTEN,
        connect: Sequence[str] = (),
        mission: str = "default",
        config_file: str | Path | None = None,
    ) -> None:
        self._name = name
        self._config_file = None if config_file is None else Path(config_file)
        self._listen = [check_endpoint(e) for e in listen]
        self._connect = [check_endpoint(e) for e in connect]
        self._prefix = f"masonry/{mission}/to"
        self._inbox: deque[bytes] = deque()
        self._lock = threading.Lock()
        self._session: Any = None
        self._subscriber: Any = None

    @property
    def name(self) -> str:
        return self._name

    def config_json(self) -> dict[str, Any]:
        """The Zenoh configuration this endpoint opens with (peer, explicit endpoints, no multicast)."""
        return {
            "mode": "peer",
            "listen/endpoints": self._listen,
            "connect/endpoints": self._connect,
            "scouting/multicast/enabled": False,
        }

    def connect(self) -> None:
        """Open the Zenoh session and subscribe to this endpoint's key."""
        import zenoh

        config = self._base_config(zenoh)
        try:
            for key, value in self.config_json().items():
                config.insert_json5(key, json.dumps(value))
            self._session = zenoh.open(config)
        except Exception as exc:  # zenoh raises ZError for a busy port or a bad locator
            raise DeviceNotFound(
                f"zenoh: cannot open a peer session on {self._listen or self._connect}: {exc}"
            ) from exc

        def on_sample(sample: Any) -> None:
            data = sample.payload.to_bytes()
            with self._lock:
                self._inbox.append(data)

        self._subscriber = self._session.declare_subscriber(f"{self._prefix}/{self._name}", on_sample)

    def _base_config(self, zenoh: Any) -> Any:
        path = self._config_file
        if path is None:
            return zenoh.Config()
        if not path.is_file():
            raise InputError(f"`zenoh_config` {path}: no such file", options=("zenoh_config",))
        try:
            return zenoh.Config.from_file(str(path))
        except Exception as exc:  # zenoh raises ZError for a syntax error or an unknown key
            raise InputError(
                f"`zenoh_config` {path}: not a valid Zenoh configuration: {_one_line(exc)}",
                options=("zenoh_config",),
            ) from exc

    def send(self, to: str, payload: bytes) -> None:
        if self._session is None:
            raise MissionError(f"zenoh endpoint {self._name!r} is not connected")
        self._session.put(f"{self._prefix}/{to}", payload)

    def receive(self) -> list[bytes]:
        with self._lock:
            out = list(self._inbox)
            self._inbox.clear()
        return out

    def close(self) -> None:
        if self._subscriber is not None:
            self._subscriber.undeclare()
            self._subscriber = None
        if self._session is not None:
            self._session.close()
            self._session = None

    def __enter__(self) -> Self:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
