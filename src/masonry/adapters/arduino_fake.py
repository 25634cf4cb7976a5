"""A fake actuator Arduino on a pseudo-terminal: a real serial device path speaking the line protocol.

For tests and for a bench demo without the board::

    python -m masonry.adapters.arduino_fake          # prints the device path, e.g. /dev/pts/7
    masonry fly ... --actuators /dev/pts/7

Knobs for tests: ``silent`` (answers nothing), ``drop_requests`` (ignore the next n lines, to exercise retries),
``wrong_device`` (answers like some other firmware), ``logic.faults`` (FAULT replies), ``inject(bytes)``
(garbage on the line), ``unplug()`` (the device disappears), ``reset()`` (reboot banner, state cleared).
"""

from __future__ import annotations

import os
import select
import sys
import threading

from typing_extensions import Self

from masonry.actuator_protocol import DeviceLogic


class FakeArduino:
    """The protocol's device side behind a pty (construct, then ``start``; ``port`` is the device path)."""

    def __init__(self, *, attach_follows_magnet: bool = False, banner: bool = True) -> None:
        self.logic = DeviceLogic(attach_follows_magnet=attach_follows_magnet)
        self.banner = banner
        self.silent = False
        self.wrong_device = False
        self.drop_requests = 0
        self.received: list[bytes] = []
        self.port = ""
        self._master: int | None = None
        self._slave: int | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._lock = threading.Lock()

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def start(self) -> None:
        import tty  # POSIX only: the fake board needs a pseudo-terminal

        master, slave = os.openpty()
        tty.setraw(slave)  # no echo, no line editing: a serial line, as a USB CDC device looks
        self._master, self._slave = master, slave
        self.port = os.ttyname(slave)
        self._stop.clear()
        if self.banner:
            self._write(self.logic.hello())
        self._thread = threading.Thread(target=self._run, name="fake-arduino", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        self._close_fds()

    def _close_fds(self) -> None:
        with self._lock:
            for fd in (self._master, self._slave):
                if fd is not None:
                    try:
                        os.close(fd)
                    except OSError:
                        pass
            self._master = self._slave = None

    def unplug(self) -> None:
        """The USB cable is pulled: the device path stops working."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        self._close_fds()

    def reset(self) -> None:
        """The board reboots: state back to defaults, HELLO banner."""
        self.logic.status = type(self.logic.status)()
        self._write(self.logic.hello())

    def inject(self, data: bytes) -> None:
        """Put raw bytes on the line toward the host (noise, a half line, another device's chatter)."""
        self._write(data)

    def _write(self, data: bytes) -> None:
        with self._lock:
            if self._master is not None:
                os.write(self._master, data)

    def _run(self) -> None:
        buffer = b""
        while not self._stop.is_set():
            master = self._master
            if master is None:
                return
            try:
                ready, _, _ = select.select([master], [], [], 0.05)
                if not ready:
                    continue
                chunk = os.read(master, 1024)
            except OSError:
                return
            buffer += chunk
            while b"\n" in buffer:
                line, buffer = buffer.split(b"\n", 1)
                self._line(line + b"\n")
            if len(buffer) > 512:  # a line that never ends: drop it, as the firmware's buffer would
                buffer = b""

    def _line(self, line: bytes) -> None:
        self.received.append(line)
        if self.silent:
            return
        if self.drop_requests > 0:
            self.drop_requests -= 1
            return
        if self.wrong_device:
            self._write(b"ok\r\nGrbl 1.1h ['$' for help]\r\n")
            return
        self._write(self.logic.handle(line))


def main() -> None:
    """Run a fake board until Ctrl-C (the brick sensor follows the magnet)."""
    fake = FakeArduino(attach_follows_magnet=True)
    fake.start()
    print(f"fake masonry-actuators device on {fake.port} (Ctrl-C to stop)", flush=True)
    try:
        while True:
            fake._stop.wait(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        fake.stop()
    sys.exit(0)


if __name__ == "__main__":
    main()
