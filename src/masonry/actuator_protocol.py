"""The actuator line protocol between the onboard computer and the Arduino (pure encode/decode, no I/O).

One ASCII line per message, ``\\n``-terminated, with an NMEA-style checksum (XOR of every byte before ``*``, two
upper-case hex digits)::

    host -> device   <seq> <COMMAND> [ARG ...]*<CS>
    device -> host   <seq> OK [FIELD ...]*<CS>
                     <seq> ERR <CODE> <message words>*<CS>
                     HELLO masonry-actuators <version>*<CS>        (unsolicited, after a reset)

``seq`` is 0..255 and wraps; a retry re-sends the same ``seq``, and the device answers a repeated ``seq`` from its
cache without acting twice. Commands and their OK fields:

=========================  ==================================================================
``PING``                   ``masonry-actuators <version>`` (identifies the device)
``MAG ON|OFF``             electromagnet
``JOINT LOCK|UNLOCK``      ball-joint lock servo
``VALVE OPEN|CLOSE``       adhesive valve servo
``STATUS``                 ``mag=0|1 joint=LOCK|UNLOCK valve=OPEN|CLOSE attached=0|1``
=========================  ==================================================================

Error codes: ``BADCHK`` (checksum), ``BADLINE`` (unparsable; sent with seq ``0``), ``UNKNOWN`` (command),
``BADARG`` (argument), ``FAULT`` (the device could not do it, e.g. a driver fault). The Arduino sketch
``firmware/masonry_actuators`` implements the device side; :class:`DeviceLogic` is the same logic in Python for
the pseudo-terminal fake.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from masonry.errors import InvalidArgument

PROTOCOL_NAME = "masonry-actuators"
PROTOCOL_VERSION = 1
MAX_LINE_BYTES = 96

COMMANDS: dict[str, tuple[str, ...]] = {
    "PING": (),
    "MAG": ("ON", "OFF"),
    "JOINT": ("LOCK", "UNLOCK"),
    "VALVE": ("OPEN", "CLOSE"),
    "STATUS": (),
}
ERROR_CODES = ("BADCHK", "BADLINE", "UNKNOWN", "BADARG", "FAULT")


class FrameError(ValueError):
    """A line is not a well-formed protocol message; ``code`` is BADCHK (checksum mismatch) or BADLINE."""

    def __init__(self, message: str, code: str = "BADLINE") -> None:
        super().__init__(message)
        self.code = code


@dataclass(frozen=True)
class Request:
    """A command from the host."""

    seq: int
    command: str
    args: tuple[str, ...] = ()


@dataclass(frozen=True)
class Reply:
    """A device answer: ``ok`` with fields, or an error ``code`` and ``message``; ``seq`` None for HELLO."""

    seq: int | None
    ok: bool
    fields: tuple[str, ...] = ()
    code: str | None = None
    message: str = ""
    hello: bool = False


@dataclass(frozen=True)
class ActuatorStatus:
    """The device's state as STATUS reports it."""

    magnet_on: bool = False
    joint_locked: bool = True
    valve_open: bool = False
    attached: bool = False


def checksum(body: str) -> str:
    """Two hex digits: XOR of the ASCII bytes of ``body``."""
    value = 0
    for byte in body.encode("ascii"):
        value ^= byte
    return f"{value:02X}"


def _frame(body: str) -> bytes:
    return f"{body}*{checksum(body)}\n".encode("ascii")


def _unframe(line: bytes | str) -> str:
    """The body of a line after checking its checksum."""
    if isinstance(line, bytes):
        try:
            text = line.decode("ascii")
        except UnicodeDecodeError as exc:
            raise FrameError("not ASCII") from exc
    else:
        text = line
    text = text.strip("\r\n")
    if len(text) > MAX_LINE_BYTES:
        raise FrameError(f"line longer than {MAX_LINE_BYTES} bytes")
    body, star, cs = text.rpartition("*")
    if not star or len(cs) != 2:
        raise FrameError("no checksum")
    if checksum(body) != cs.upper():
        raise FrameError(f"checksum {cs} does not match {checksum(body)}", "BADCHK")
    if not body or any(not (32 <= ord(c) < 127) for c in body):
        raise FrameError("empty or non-printable body")
    return body


def _seq(token: str) -> int:
    if not token.isdigit() or not 0 <= int(token) <= 255:
        raise FrameError(f"bad sequence number {token!r}")
    return int(token)


def encode_request(request: Request) -> bytes:
    """``Request`` -> one framed line."""
    if not 0 <= request.seq <= 255:
        raise InvalidArgument(f"seq must be 0..255, not {request.seq}")
    return _frame(" ".join((str(request.seq), request.command, *request.args)))


def decode_request(line: bytes | str) -> Request:
    """One line -> ``Request`` (raises FrameError; unknown commands decode: the device answers UNKNOWN)."""
    tokens = _unframe(line).split()
    if len(tokens) < 2:
        raise FrameError("expected '<seq> <COMMAND> [ARG ...]'")
    return Request(_seq(tokens[0]), tokens[1].upper(), tuple(t.upper() for t in tokens[2:]))


def encode_reply(reply: Reply) -> bytes:
    """``Reply`` -> one framed line."""
    if reply.hello:
        return _frame(" ".join(("HELLO", *reply.fields)))
    seq = str(reply.seq if reply.seq is not None else 0)
    if reply.ok:
        return _frame(" ".join((seq, "OK", *reply.fields)))
    return _frame(" ".join(p for p in (seq, "ERR", reply.code or "FAULT", reply.message) if p))


def decode_reply(line: bytes | str) -> Reply:
    """One line -> ``Reply`` (raises FrameError)."""
    tokens = _unframe(line).split()
    if tokens[0] == "HELLO":
        return Reply(None, True, tuple(tokens[1:]), hello=True)
    if len(tokens) < 2:
        raise FrameError("expected '<seq> OK|ERR ...'")
    seq = _seq(tokens[0])
    if tokens[1] == "OK":
        return Reply(seq, True, tuple(tokens[2:]))
    if tokens[1] == "ERR" and len(tokens) >= 3:
        return Reply(seq, False, code=tokens[2], message=" ".join(tokens[3:]))
    raise FrameError(f"expected OK or ERR after the sequence number, got {tokens[1]!r}")


def format_status(status: ActuatorStatus) -> tuple[str, ...]:
    return (
        f"mag={int(status.magnet_on)}",
        f"joint={'LOCK' if status.joint_locked else 'UNLOCK'}",
        f"valve={'OPEN' if status.valve_open else 'CLOSE'}",
        f"attached={int(status.attached)}",
    )


def parse_status(fields: tuple[str, ...]) -> ActuatorStatus:
    """STATUS fields -> ``ActuatorStatus`` (raises FrameError naming the bad field)."""
    values: dict[str, str] = {}
    for field in fields:
        key, eq, value = field.partition("=")
        if not eq:
            raise FrameError(f"status field {field!r} is not key=value")
        values[key.lower()] = value.upper()
    allowed = {
        "mag": ("0", "1"),
        "joint": ("LOCK", "UNLOCK"),
        "valve": ("OPEN", "CLOSE"),
        "attached": ("0", "1"),
    }
    for key, options in allowed.items():
        if values.get(key) not in options:
            raise FrameError(f"status field {key}={values.get(key)!r} not one of {'/'.join(options)}")
    return ActuatorStatus(
        magnet_on=values["mag"] == "1",
        joint_locked=values["joint"] == "LOCK",
        valve_open=values["valve"] == "OPEN",
        attached=values["attached"] == "1",
    )


class DeviceLogic:
    """The device side of the protocol (what the firmware does), on a plain state: line in, line out.

    ``attached`` is the brick sensor (a switch in the conical guide): set it from outside (``set_attached``), or
    let it follow the magnet with ``attach_follows_magnet`` for a bench demo. ``release_drops_brick`` models the
    physics around the sensor (switching the magnet off lets the brick fall, so the sensor opens); the firmware
    only reads its pin. ``faults`` maps a command to an error message the device answers with (FAULT).
    """

    def __init__(self, *, attach_follows_magnet: bool = False, release_drops_brick: bool = True) -> None:
        self.status = ActuatorStatus()
        self.attach_follows_magnet = attach_follows_magnet
        self.release_drops_brick = release_drops_brick
        self.faults: dict[str, str] = {}
        self.executed: list[Request] = []
        self._last: tuple[int, str, tuple[str, ...], bytes] | None = None

    def hello(self) -> bytes:
        return encode_reply(Reply(None, True, (PROTOCOL_NAME, str(PROTOCOL_VERSION)), hello=True))

    def set_attached(self, attached: bool) -> None:
        self.status = replace(self.status, attached=attached)

    def handle(self, line: bytes) -> bytes:
        """Answer one received line."""
        try:
            request = decode_request(line)
        except FrameError as exc:
            return encode_reply(Reply(0, False, code=exc.code, message=str(exc).replace("*", "")[:40]))
        key = (request.seq, request.command, request.args)
        if self._last is not None and self._last[:3] == key:
            return self._last[3]  # a retry: answer again, act once
        reply = encode_reply(self._execute(request))
        self._last = (*key, reply)
        return reply

    def _execute(self, request: Request) -> Reply:
        seq, command, args = request.seq, request.command, request.args
        if command not in COMMANDS:
            return Reply(seq, False, code="UNKNOWN", message=f"unknown command {command}")
        options = COMMANDS[command]
        if (options and (len(args) != 1 or args[0] not in options)) or (not options and args):
            expected = "|".join(options) if options else "no argument"
            return Reply(seq, False, code="BADARG", message=f"{command} takes {expected}")
        if command in self.faults:
            return Reply(seq, False, code="FAULT", message=self.faults[command])
        self.executed.append(request)
        status = self.status
        if command == "PING":
            return Reply(seq, True, (PROTOCOL_NAME, str(PROTOCOL_VERSION)))
        if command == "MAG":
            on = args[0] == "ON"
            status = replace(status, magnet_on=on)
            if self.attach_follows_magnet:
                status = replace(status, attached=on)
            elif not on and self.release_drops_brick:
                status = replace(status, attached=False)  # the brick falls off
        elif command == "JOINT":
            status = replace(status, joint_locked=args[0] == "LOCK")
        elif command == "VALVE":
            status = replace(status, valve_open=args[0] == "OPEN")
        self.status = status
        if command == "STATUS":
            return Reply(seq, True, format_status(status))
        return Reply(seq, True)
