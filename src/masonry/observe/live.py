"""The mission live in Foxglove (``--foxglove [HOST:]PORT``): the log's channels on the Foxglove SDK's WebSocket
server, and the operator's commands as its services.

:class:`FoxgloveLive` is an :class:`~masonry.mission.events.EventSink` that writes the same messages as the MCAP
log (:class:`~masonry.observe.scene.MissionScene`) to channels of its own SDK context, served by
``foxglove.start_server`` to the Foxglove app ("Open connection", ``ws://HOST:PORT``). With ``commands`` (the
same callable as the live page's buttons: :meth:`masonry.mission.operator.Operator.ask`), each operator command
is a service (``/mission/pause``, ...): journaled and acknowledged as ``masonry ctl``'s, refused with its reason.
:func:`serve_recorded` plays a log back on such a server (``masonry replay --foxglove``).
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from typing import Any

import foxglove
from foxglove import (
    Capability,
    Channel,
    Context,
    MessageSchema,
    Schema,
    Service,
    ServiceRequest,
    ServiceSchema,
)
from foxglove.messages import SceneUpdate
from foxglove.websocket import ChannelView, Client, ServerListener

from masonry.errors import InputError
from masonry.observe.scene import Message, MissionScene, channel_schema, encoded, ns
from masonry.planner.tasks import Plan

#: The operator's commands served as Foxglove services: service name -> (command, its request's fields).
SERVICES: dict[str, tuple[str, dict[str, Any]]] = {
    "/mission/pause": ("pause", {}),
    "/mission/resume": ("resume", {}),
    "/mission/recall": ("recall", {"uav": {"type": "string"}}),
    "/mission/return-all": ("return-all", {}),
    "/mission/abort": ("abort", {}),
    "/mission/limit": ("limit", {"role": {"type": "string"}, "limit": {"type": "integer", "minimum": -1}}),
}

_RESPONSE = {
    "title": "masonry.CommandOutcome",
    "type": "object",
    "properties": {"accepted": {"type": "boolean"}, "reason": {"type": "string"}},
    "required": ["accepted", "reason"],
}

Commands = Callable[[Mapping[str, Any]], Mapping[str, Any]]


def _json_schema(name: str, body: Mapping[str, Any]) -> MessageSchema:
    return MessageSchema(
        encoding="json", schema=Schema(name=name, encoding="jsonschema", data=json.dumps(body).encode())
    )


def operator_services(commands: Commands) -> list[Service]:
    """The operator's commands as Foxglove services; each calls ``commands`` and answers its outcome (JSON)."""
    services = []
    for name, (command, fields) in SERVICES.items():
        request = {
            "title": f"masonry.{command.title().replace('-', '')}Request",
            "type": "object",
            "properties": fields,
            "required": sorted(fields),
        }

        def handler(req: ServiceRequest, command: str = command, fields: Any = fields) -> bytes:
            return json.dumps(dict(answer(commands, command, fields, req.payload))).encode()

        schema = ServiceSchema(
            f"masonry.{command}",
            request=_json_schema(str(request["title"]), request),
            response=_json_schema("masonry.CommandOutcome", _RESPONSE),
        )
        services.append(Service(name, schema=schema, handler=handler))
    return services


def answer(commands: Commands, command: str, fields: Mapping[str, Any], payload: bytes) -> Mapping[str, Any]:
    """One service call: its request (a JSON object with ``fields``; empty for none) as an operator command, and
    the outcome; a malformed request is refused with what is wrong."""
    try:
        body = json.loads(payload) if payload.strip() else {}
    except ValueError as exc:
        return {"accepted": False, "reason": f"the request is not JSON: {exc}"}
    if not isinstance(body, dict):
        return {"accepted": False, "reason": "the request must be a JSON object"}
    missing = [f for f in sorted(fields) if f not in body]
    if missing:
        return {"accepted": False, "reason": f"{command} needs {', '.join(missing)}"}
    return commands({"command": command, **{k: body[k] for k in fields}})


class _Subscribed(ServerListener):
    """The server's listener: calls ``on_subscribe(topic)`` when a viewer subscribes to a channel."""

    def __init__(self, on_subscribe: Callable[[str], None]) -> None:
        self.on_subscribe_topic = on_subscribe

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        self.on_subscribe_topic(channel.topic)


class FoxgloveServer:
    """A Foxglove WebSocket server on its own SDK context: :meth:`start`, :meth:`publish`, :meth:`stop`.

    Args:
        host, port: where it listens (port 0: any free port).
        name: the server's name in the app.
        commands: the operator's commands (None: no services).
        tls: ``(certificate PEM, private key PEM)``: serve ``wss://`` only.
        on_subscribe: called with the topic whenever a viewer subscribes to a channel (from the server's thread).
    """

    def __init__(
        self,
        host: str,
        port: int,
        *,
        name: str = "masonry",
        commands: Commands | None = None,
        tls: tuple[bytes, bytes] | None = None,
        on_subscribe: Callable[[str], None] | None = None,
    ) -> None:
        self.host = host
        self.port = port
        self.name = name
        self.commands = commands
        self.tls = tls
        self.listener = _Subscribed(on_subscribe) if on_subscribe is not None else None
        self.context = Context()
        self.channels: dict[str, Channel] = {}
        self._lock = threading.Lock()
        self.server: Any = None

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"{'wss' if self.tls else 'ws'}://{host}:{self.server.port if self.server else self.port}"

    def start(self) -> FoxgloveServer:
        """Listen.

        Raises:
            InputError: it cannot listen there (the port is taken, the address is not this machine's).
        """
        try:
            self.server = foxglove.start_server(
                name=self.name,
                host=self.host,
                port=self.port,
                context=self.context,
                capabilities=[Capability.Services] if self.commands is not None else [],
                supported_encodings=["json"],
                services=operator_services(self.commands) if self.commands is not None else None,
                server_listener=self.listener,
                tls_cert=self.tls[0] if self.tls else None,
                tls_key=self.tls[1] if self.tls else None,
            )
        except Exception as exc:  # the SDK raises RuntimeError/ValueError with the OS's reason
            raise InputError(
                f"`foxglove` {self.host}:{self.port}: cannot listen: {exc}", options=("foxglove",)
            ) from None
        self.port = self.server.port
        return self

    def channel(self, topic: str, schema: tuple[str, str, bytes, str]) -> Channel:
        """``topic``'s channel (advertised to every viewer), created with ``schema`` the first time."""
        with self._lock:
            channel = self.channels.get(topic)
            if channel is None:
                name, schema_encoding, data, encoding = schema
                channel = Channel(
                    topic,
                    schema=Schema(name=name, encoding=schema_encoding, data=data),
                    message_encoding=encoding,
                    context=self.context,
                )
                self.channels[topic] = channel
            return channel

    def publish(self, topic: str, schema: tuple[str, str, bytes, str], log_time_ns: int, data: bytes) -> None:
        self.channel(topic, schema).log(data, log_time=log_time_ns)

    def stop(self) -> None:
        if self.server is not None:
            self.server.stop()
            self.server = None


class FoxgloveLive(MissionScene):
    """A mission served live to Foxglove: :meth:`start`, hand it events (:meth:`emit`), :meth:`finish`, :meth:`stop`.

    Args:
        host, port: where the server listens.
        plan, blueprint_yaml, title, command: as :class:`~masonry.observe.mcap_log.McapLog`'s.
        uavs: the fleet's names (their pose and state channels are advertised from the start).
        commands: the operator's commands (None: no services).
        tls: ``(certificate PEM, private key PEM)``, or None.
    """

    def __init__(
        self,
        host: str,
        port: int,
        plan: Plan,
        blueprint_yaml: str,
        *,
        title: str = "",
        command: str = "",
        uavs: Iterable[str] = (),
        commands: Commands | None = None,
        tls: tuple[bytes, bytes] | None = None,
    ) -> None:
        super().__init__(plan, blueprint_yaml, title=title, command=command)
        self.server = FoxgloveServer(
            host, port, name=title or "masonry", commands=commands, tls=tls, on_subscribe=self.resend
        )
        self.uavs = list(uavs)
        self._schemas: dict[str, tuple[str, str, bytes, str]] = {}
        self._opening: dict[str, Message] = {}

    @property
    def url(self) -> str:
        return self.server.url

    def start(self) -> FoxgloveLive:
        """Listen, advertise the channels, and publish the blueprint and the wall (see :meth:`FoxgloveServer.start`)."""
        self.server.start()
        topics = ["/mission/blueprint", "/mission/events", "/log", "/wall", "/airspace", "/tf", "/paths"]
        for topic in topics + [f"/uav/{u}/{what}" for u in self.uavs for what in ("pose", "state")]:
            self.server.channel(topic, self._schema(topic))
        self.write_opening()
        return self

    def _schema(self, topic: str) -> tuple[str, str, bytes, str]:
        schema = self._schemas.get(topic)
        if schema is None:
            schema = self._schemas[topic] = channel_schema(topic)
        return schema

    def wants(self, topic: str) -> bool:
        """A viewer is subscribed to ``topic`` (no one: its messages are not built, nor encoded)."""
        return bool(self.server.channel(topic, self._schema(topic)).base.has_sinks())

    def write(self, topic: str, time_s: float, message: Message) -> None:
        """Publish one message; the wall and the airspace go whole each time (a viewer may have joined late)."""
        if topic == "/mission/blueprint":
            self._opening[topic] = message
        if topic in ("/wall", "/airspace"):
            message = self._whole(topic) or message
        self.server.publish(topic, self._schema(topic), ns(time_s), encoded(message))

    def _whole(self, topic: str) -> SceneUpdate | None:
        with self.scene_lock:
            entities = list((self.wall if topic == "/wall" else self.airspace).values())
        return SceneUpdate(entities=entities) if entities else None

    def resend(self, topic: str) -> None:
        """The blueprint, or the wall or the airspace whole, again (a viewer subscribed to it)."""
        if topic == "/mission/blueprint" and topic in self._opening:
            self.server.publish(topic, self._schema(topic), 0, encoded(self._opening[topic]))
        elif topic in ("/wall", "/airspace"):
            whole = self._whole(topic)
            if whole is not None:
                self.server.publish(topic, self._schema(topic), ns(self.last_s), whole.encode())

    def stop(self) -> None:
        self.server.stop()


def serve_recorded(
    server: FoxgloveServer,
    messages: Iterable[tuple[str, tuple[str, str, bytes, str], int, bytes]],
    *,
    time_scale: float = 1.0,
    stop: threading.Event | None = None,
    monotonic: Callable[[], float] = time.monotonic,
) -> int:
    """Publish a log's messages (``(topic, schema, log_time_ns, data)``, in log time order) on ``server`` at
    ``time_scale`` log seconds per wall second; returns how many (fewer when ``stop`` is set)."""
    wall0: float | None = None
    t0 = 0
    n = 0
    done = stop or threading.Event()
    for topic, schema, log_time_ns, data in messages:
        if wall0 is None:
            wall0, t0 = monotonic(), log_time_ns
        lag = wall0 + (log_time_ns - t0) / 1e9 / time_scale - monotonic()
        if lag > 0 and done.wait(lag):
            break
        if done.is_set():
            break
        server.publish(topic, schema, log_time_ns, data)
        n += 1
    return n


__all__ = ["SERVICES", "FoxgloveLive", "FoxgloveServer", "answer", "operator_services", "serve_recorded"]
