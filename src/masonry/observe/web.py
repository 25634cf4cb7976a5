"""The live web view: a small HTTP server (the standard library's, in a thread) for one mission's page.

Why the standard library (docs/observe.md): the page needs four GET routes, one server-sent-event stream and
one POST; ``http.server.ThreadingHTTPServer`` serves that with no dependency, on every machine the mission
control runs on, and a site with no internet needs nothing installed. The page's HTML, script and style ship
in the package (``masonry/observe/static``); nothing comes from a CDN.

Routes:

- ``GET /``: the page; ``GET /static/NAME``: its script and style.
- ``GET /layout.json``: the wall and the fleet (:func:`masonry.mission.view.wall_layout`).
- ``GET /state.json``: the mission now (:meth:`MissionView.snapshot`), or at ``?at=T`` for a replayed log.
- ``GET /events``: server-sent events, one ``state`` snapshot whenever it changed, at most :data:`PUSH_HZ` a
  second.
- ``POST /command``: an operator's command (``{"command": "pause"}``), handed to the ``commands`` callable;
  answered with its acknowledgement or refusal (JSON). Only when the server was given one.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable, Mapping
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Any
from urllib.parse import parse_qs, urlparse

from masonry.errors import InputError

#: Snapshots pushed per second at most (server-sent events).
PUSH_HZ = 4.0
#: The host ``--serve PORT`` binds to.
DEFAULT_HOST = "127.0.0.1"

_TYPES = {".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8", ".css": "text/css"}
_STATIC = ("index.html", "app.js", "app.css")


def parse_serve(text: str, option: str = "serve") -> tuple[str, int]:
    """``[HOST:]PORT`` (``--serve``, or the flag ``option`` names) as (host, port); the host defaults to
    :data:`DEFAULT_HOST`.

    Raises:
        InputError: not ``[HOST:]PORT`` with a port in 0..65535 (0: any free port).
    """
    host, _, port = text.rpartition(":")
    host = host.strip("[]") or DEFAULT_HOST
    try:
        n = int(port)
    except ValueError:
        raise InputError(
            f"`{option}` {text!r}: give [HOST:]PORT, e.g. 8080 or 127.0.0.1:8080", options=(option,)
        ) from None
    if not 0 <= n <= 65535:
        raise InputError(f"`{option}` {text!r}: the port must be in 0..65535", options=(option,))
    return host, n


def static_file(name: str) -> bytes:
    """One of the page's files, from the package."""
    return resources.files("masonry.observe").joinpath("static").joinpath(name).read_bytes()


class ViewServer:
    """Serves one mission's page: :meth:`start` (a thread), :meth:`stop`.

    Args:
        host, port: where to listen (port 0: a free one; :attr:`port` says which once started).
        layout: the wall and fleet (``wall_layout``).
        state: returns the mission's snapshot, at a time (a replay) or now (``None``).
        version: returns a number that changes when the state does (what the event stream watches).
        commands: takes an operator's command (a JSON object) and returns its answer (``accepted``,
            ``reason``); None: the page shows no buttons and ``POST /command`` is refused.
        replay: the page shows a time slider over ``[0, replay]`` mission seconds (a log played back).
    """

    def __init__(
        self,
        host: str,
        port: int,
        *,
        layout: Mapping[str, Any],
        state: Callable[[float | None], Mapping[str, Any]],
        version: Callable[[], int],
        commands: Callable[[Mapping[str, Any]], Mapping[str, Any]] | None = None,
        replay: float | None = None,
    ) -> None:
        self.host = host
        self.port = port
        self.layout = {**layout, "replay_s": replay, "commands": commands is not None}
        self.state = state
        self.version = version
        self.commands = commands
        self._server: ThreadingHTTPServer | None = None
        self._thread: threading.Thread | None = None
        self._stopping = threading.Event()

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}/"

    def start(self) -> ViewServer:
        """Listen and serve in a daemon thread.

        Raises:
            InputError: the address cannot be bound (in use, not this machine's).
        """
        handler = _handler_for(self)
        try:
            self._server = ThreadingHTTPServer((self.host, self.port), handler)
        except OSError as exc:
            raise InputError(
                f"`serve` {self.host}:{self.port}: cannot listen ({exc.strerror or exc})", options=("serve",)
            ) from None
        self._server.daemon_threads = True
        self.port = int(self._server.server_address[1])
        self._thread = threading.Thread(target=self._server.serve_forever, name="masonry-view", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop serving (event streams end within a push period)."""
        self._stopping.set()
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()
            self._server = None
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None

    def __enter__(self) -> ViewServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


def _handler_for(view: ViewServer) -> type[BaseHTTPRequestHandler]:
    return type("Handler", (_Handler,), {"view": view})


class _Handler(BaseHTTPRequestHandler):
    """One request to a :class:`ViewServer` (its ``view``)."""

    view: ViewServer
    server_version = "masonry-view"

    def log_message(self, format: str, *args: Any) -> None:
        return  # quiet: the mission's own output is on the terminal

    def _send(self, status: int, body: bytes, content_type: str) -> None:
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def _json(self, value: Any, status: int = HTTPStatus.OK) -> None:
        self._send(status, json.dumps(value).encode(), "application/json")

    def do_GET(self) -> None:
        url = urlparse(self.path)
        path = url.path
        if path in ("/", "/index.html"):
            self._send(HTTPStatus.OK, static_file("index.html"), _TYPES[".html"])
        elif path.startswith("/static/") and path[len("/static/") :] in _STATIC:
            name = path[len("/static/") :]
            self._send(HTTPStatus.OK, static_file(name), _TYPES["." + name.rsplit(".", 1)[-1]])
        elif path == "/layout.json":
            self._json(self.view.layout)
        elif path == "/state.json":
            at = parse_qs(url.query).get("at") or []
            try:
                t = float(at[0]) if at else None
            except ValueError:
                self._json({"error": f"at={at[0]!r} is not a time"}, HTTPStatus.BAD_REQUEST)
                return
            self._json(self.view.state(t))
        elif path == "/events":
            self._stream()
        elif path == "/favicon.ico":
            self._send(HTTPStatus.NO_CONTENT, b"", "image/x-icon")
        else:
            self._json({"error": f"no such page {path}"}, HTTPStatus.NOT_FOUND)

    def _stream(self) -> None:
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", "text/event-stream")
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        seen = None
        try:
            while not self.view._stopping.is_set():
                v = self.view.version()
                if v != seen:
                    seen = v
                    data = json.dumps(self.view.state(None))
                    self.wfile.write(f"event: state\ndata: {data}\n\n".encode())
                    self.wfile.flush()
                time.sleep(1.0 / PUSH_HZ)
        except (BrokenPipeError, ConnectionResetError):
            return  # the page was closed

    def do_POST(self) -> None:
        if urlparse(self.path).path != "/command":
            self._json({"error": "no such route"}, HTTPStatus.NOT_FOUND)
            return
        if self.view.commands is None:
            self._json({"accepted": False, "reason": "this view takes no commands"}, HTTPStatus.FORBIDDEN)
            return
        try:
            n = min(int(self.headers.get("Content-Length") or 0), 4096)
            body = json.loads(self.rfile.read(n) or b"{}")
        except ValueError as exc:
            self._json({"accepted": False, "reason": f"bad command: {exc}"}, HTTPStatus.BAD_REQUEST)
            return
        if not isinstance(body, dict):
            self._json({"accepted": False, "reason": "bad command: not an object"}, HTTPStatus.BAD_REQUEST)
            return
        self._json(dict(self.view.commands(body)))


class Pacer:
    """Slows a simulated mission to ``time_scale`` mission seconds per wall second (a ``tick_hooks`` entry).

    Args:
        time_scale: mission seconds per wall second (1.0: real time).
        monotonic, sleep: the wall clock and how to wait on it (injected in tests).
    """

    def __init__(
        self,
        time_scale: float = 1.0,
        *,
        monotonic: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        if not time_scale > 0:
            raise InputError(f"`time_scale` must be > 0, got {time_scale!r}", options=("time_scale",))
        self.time_scale = time_scale
        self._monotonic = monotonic
        self._sleep = sleep
        self._anchor: tuple[float, float] | None = None

    def __call__(self, now_s: float) -> None:
        if self._anchor is None:
            self._anchor = (self._monotonic(), now_s)
            return
        wall0, sim0 = self._anchor
        lag = wall0 + (now_s - sim0) / self.time_scale - self._monotonic()
        if lag > 0:
            self._sleep(lag)


__all__ = ["DEFAULT_HOST", "PUSH_HZ", "Pacer", "ViewServer", "parse_serve", "static_file"]
