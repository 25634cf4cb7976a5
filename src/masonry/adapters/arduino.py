"""Gripper and Sprayer on the actuator Arduino over a serial line (pyserial; protocol: masonry.actuator_protocol).

::

    with ArduinoActuators("/dev/ttyACM0") as act:   # opens, waits out the reset, PINGs the device
        act.set_joint_locked(False)
        act.set_magnet(True)
        act.is_attached()

Each command waits ``timeout_s`` for its reply and is re-sent (same sequence number, so the device acts once)
up to ``retries`` times. Errors name the port: DeviceNotFound (no such port, or not a masonry-actuators device),
CommandRejected (the device answered ERR), CommandTimeout (no answer), LinkLost (unplugged while in use).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from typing_extensions import Self

from masonry.actuator_protocol import (
    PROTOCOL_NAME,
    PROTOCOL_VERSION,
    ActuatorStatus,
    FrameError,
    Reply,
    Request,
    decode_reply,
    encode_request,
    parse_status,
)
from masonry.errors import CommandRejected, CommandTimeout, DeviceNotFound, LinkLost


class ArduinoActuators:
    """The electromagnet, ball-joint lock and valve on one Arduino: implements Gripper and Sprayer.

    Args:
        port: serial device (``/dev/ttyACM0``, ``/dev/ttyUSB0``, ``COM3``) or a pyserial URL (``loop://``).
        baud: line speed (the sketch uses 115200).
        timeout_s: wait for each reply.
        retries: re-sends of an unanswered command.
        boot_wait_s: how long to wait for the board after opening (an Uno/Nano resets when the port opens and
            its bootloader takes ~1.5 s; the HELLO banner ends the wait early).
        monotonic: the clock (s) the boot wait and the reply timeouts are measured on (a test injects one it
            steps; the reads themselves stay bounded polls of the port).
    """

    def __init__(
        self,
        port: str,
        *,
        baud: int = 115200,
        timeout_s: float = 0.3,
        retries: int = 2,
        boot_wait_s: float = 2.0,
        monotonic: Callable[[], float] = time.monotonic,
    ) -> None:
        self.port = port
        self._monotonic = monotonic
        self.baud = baud
        self.timeout_s = timeout_s
        self.retries = retries
        self.boot_wait_s = boot_wait_s
        self.version: int | None = None
        self.garbage_lines = 0
        self.resets_seen = 0
        self._serial: Any = None
        self._seq = 0
        self._lock = threading.Lock()
        self._buffer = b""
        self._status: ActuatorStatus | None = None

    def __enter__(self) -> Self:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def connected(self) -> bool:
        return self._serial is not None

    def connect(self) -> None:
        """Open the port and identify the device.

        Raises:
            DeviceNotFound: the port does not exist or cannot be opened, or the device does not answer PING as a
                masonry-actuators board.
        """
        if self._serial is not None:
            return
        import serial

        try:
            self._serial = serial.serial_for_url(
                self.port, baudrate=self.baud, timeout=0.02, write_timeout=1.0
            )
        except (serial.SerialException, OSError, ValueError) as exc:
            raise DeviceNotFound(f"{self.port}: cannot open the actuator board's serial port: {exc}") from exc
        try:
            self._await_boot()
            reply = self._transact("PING", (), retries=max(self.retries, 2), identify=True)
        except (CommandTimeout, CommandRejected, LinkLost) as exc:
            self.close()
            raise DeviceNotFound(
                f"{self.port}: no {PROTOCOL_NAME} device answered (wrong port or firmware?): {exc}"
            ) from exc
        if len(reply.fields) < 2 or reply.fields[0] != PROTOCOL_NAME:
            self.close()
            raise DeviceNotFound(
                f"{self.port}: the device is not a {PROTOCOL_NAME} board (PING: {reply.fields})"
            )
        self.version = int(reply.fields[1]) if reply.fields[1].isdigit() else None
        if self.version != PROTOCOL_VERSION:
            self.close()
            raise DeviceNotFound(
                f"{self.port}: firmware speaks protocol version {reply.fields[1]}, this masonry speaks "
                f"{PROTOCOL_VERSION}; flash firmware/masonry_actuators"
            )

    def close(self) -> None:
        if self._serial is not None:
            try:
                self._serial.close()
            except OSError:
                pass
            self._serial = None

    def _await_boot(self) -> None:
        deadline = self._monotonic() + self.boot_wait_s
        while self._monotonic() < deadline:
            line = self._read_line(max(0.0, min(0.1, deadline - self._monotonic())))
            if line is None:
                continue  # still in the bootloader, or a board that does not reset on open: wait it out
            try:
                if decode_reply(line).hello:
                    self.resets_seen += 1
                    return
            except FrameError:
                self.garbage_lines += 1

    # -------------------------------------------------------------------------------------------- transport

    def _read_line(self, timeout_s: float) -> bytes | None:
        import serial

        deadline = self._monotonic() + timeout_s
        while b"\n" not in self._buffer:
            remaining = deadline - self._monotonic()
            if remaining <= 0:
                return None
            try:
                chunk = self._serial.read(max(1, self._serial.in_waiting))
            except (serial.SerialException, OSError) as exc:
                self.close()
                raise LinkLost(f"{self.port}: actuator board unplugged or unreadable: {exc}") from exc
            self._buffer += chunk
            if len(self._buffer) > 4096:  # a never-ending line is noise
                self._buffer = b""
                self.garbage_lines += 1
        line, self._buffer = self._buffer.split(b"\n", 1)
        return line + b"\n"

    def _write(self, data: bytes) -> None:
        import serial

        try:
            self._serial.write(data)
            self._serial.flush()
        except (serial.SerialException, OSError) as exc:
            self.close()
            raise LinkLost(f"{self.port}: actuator board unplugged or not writable: {exc}") from exc

    def _transact(
        self, command: str, args: tuple[str, ...], *, retries: int | None = None, identify: bool = False
    ) -> Reply:
        """Send one command and return its OK reply (re-sent with the same seq on timeout)."""
        with self._lock:
            if self._serial is None:
                raise LinkLost(f"{self.port}: actuator board not connected")
            self._seq = (self._seq + 1) % 256
            request = Request(self._seq, command, args)
            line = encode_request(request)
            text = " ".join((command, *args))
            tries = (self.retries if retries is None else retries) + 1
            for _ in range(tries):
                self._write(line)
                deadline = self._monotonic() + self.timeout_s
                while (remaining := deadline - self._monotonic()) > 0:
                    raw = self._read_line(remaining)
                    if raw is None:
                        break
                    try:
                        reply = decode_reply(raw)
                    except FrameError:
                        self.garbage_lines += 1
                        continue
                    if reply.hello:  # the board rebooted: its outputs are back to their defaults
                        self.resets_seen += 1
                        self._status = None
                        if identify:
                            continue
                        break  # re-send at once
                    if reply.seq != request.seq:
                        continue  # a late answer to an earlier try, or an error about garbage (seq 0)
                    if not reply.ok:
                        raise CommandRejected(
                            f"{text} on {self.port}", f"{reply.code} {reply.message}".strip()
                        )
                    return reply
            raise CommandTimeout(
                f"{self.port}: actuator board did not answer {text} ({tries} tries of {self.timeout_s:.2f} s)"
            )

    # ------------------------------------------------------------------------------------------ the ports

    def ping(self) -> tuple[str, ...]:
        return self._transact("PING", ()).fields

    def status(self) -> ActuatorStatus:
        """Query the board: magnet, joint, valve and the brick sensor."""
        reply = self._transact("STATUS", ())
        try:
            self._status = parse_status(reply.fields)
        except FrameError as exc:
            raise CommandRejected(f"STATUS on {self.port}", f"malformed answer: {exc}") from exc
        return self._status

    def set_magnet(self, on: bool) -> None:
        self._transact("MAG", ("ON" if on else "OFF",))

    def set_joint_locked(self, locked: bool) -> None:
        self._transact("JOINT", ("LOCK" if locked else "UNLOCK",))

    def is_attached(self) -> bool:
        return self.status().attached

    def release_at(self, at_s: float) -> bool:
        """The firmware has no timed release (masonry.actuator_protocol: MAG ON/OFF only) and the board does not
        share the UAV's clock: the magnet is switched off now, and False says so (``Gripper.release_at``)."""
        self.set_magnet(False)
        return False

    def can_time_release(self) -> bool:
        """No: the firmware lets go at once (:meth:`release_at`)."""
        return False

    def set_valve(self, open_: bool) -> None:
        self._transact("VALVE", ("OPEN" if open_ else "CLOSE",))

    def is_valve_open(self) -> bool:
        return self.status().valve_open

    def safe_state(self) -> None:
        """Valve closed, best effort (for shutdown paths; the magnet is left as is so a carried brick stays)."""
        try:
            self.set_valve(False)
        except (CommandRejected, CommandTimeout, LinkLost):
            pass
