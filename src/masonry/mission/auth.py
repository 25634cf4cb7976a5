"""Authenticated mission messages: an HMAC-SHA256 layer over any Transport, keyed by a per-mission secret.

:class:`AuthenticatedTransport` wraps a :class:`~masonry.mission.transport.Transport` (Zenoh, in-process) and
turns each payload into a frame that only a holder of the mission's 32-byte key can produce::

    b"MSN1" | len(sender) (1 byte) | sender (UTF-8) | counter (8 bytes, big-endian) | payload | HMAC (32 bytes)

The HMAC covers the mission name, the addressee and every byte before it, so a frame cannot be replayed to
another UAV or into another mission, and no field can be changed. The counter is the sender's wall clock in
nanoseconds when it sent the frame (strictly increasing within a process, and across restarts as long as the
clock does not go back), so a receiver accepts from each sender only counters higher than the last it accepted
(against replay) and none older than ``max_age_s`` (against replaying a frame recorded in an earlier run with
the same key before the real sender speaks). The sender in the frame must be the ``sender`` of the message
inside. A frame that fails any check is dropped and counted by reason (:attr:`AuthenticatedTransport.dropped`),
never handed up; the first drop of each reason, and then each tenth, hundredth, ... is logged.

The key protects integrity and authenticity, not confidentiality: the payload travels in clear (Zenoh's TLS
encrypts the links, docs/security.md).

Key file (``masonry keygen -o FILE``, ``--key-file FILE``): one line of 64 hexadecimal digits (32 random bytes),
written with mode 0600. A key file that group or others can read is refused, as ssh refuses such a private key.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import logging
import os
import secrets
import stat
import time
from collections import Counter
from collections.abc import Iterable
from pathlib import Path

from masonry.errors import InputError
from masonry.mission.transport import Transport

log = logging.getLogger(__name__)

KEY_BYTES = 32
MAGIC = b"MSN1"
_MAC_BYTES = 32
_COUNTER_BYTES = 8
#: Frames older than this (by the sender's clock against the receiver's) are dropped as stale.
DEFAULT_MAX_AGE_S = 120.0
#: The reasons a frame is dropped, as counted in :attr:`AuthenticatedTransport.dropped`.
DROP_REASONS = ("malformed", "bad-mac", "sender-mismatch", "stale", "replay")


class AuthenticatedTransport:
    """A Transport whose frames carry an HMAC-SHA256 under the mission key (see the module docstring).

    Args:
        inner: the transport that carries the frames (its name is this endpoint's name).
        key: the mission's 32-byte secret.
        mission: the mission name (part of what the HMAC covers).
        max_age_s: frames whose counter is older than this by the receiver's clock are dropped (None: no age
            check; the counters still have to increase).
    """

    def __init__(
        self,
        inner: Transport,
        key: bytes,
        *,
        mission: str = "default",
        max_age_s: float | None = DEFAULT_MAX_AGE_S,
    ) -> None:
        if len(key) != KEY_BYTES:
            raise InputError(f"a mission key is {KEY_BYTES} bytes, got {len(key)}")
        self._inner = inner
        self._key = bytes(key)
        self._mission = mission.encode()
        self._max_age_ns = None if max_age_s is None else int(max_age_s * 1e9)
        sender = inner.name.encode()
        if not 0 < len(sender) < 256:
            raise InputError(f"endpoint name {inner.name!r} must be 1 to 255 bytes long")
        self._head = MAGIC + bytes([len(sender)]) + sender
        self._counter = 0
        self._last: dict[str, int] = {}  # sender -> highest counter accepted
        self.dropped: Counter[str] = Counter()
        self.accepted = 0

    @property
    def name(self) -> str:
        return self._inner.name

    @property
    def dropped_total(self) -> int:
        """Frames dropped so far, for every reason."""
        return sum(self.dropped.values())

    def _mac(self, to: bytes, body: bytes) -> bytes:
        h = hmac.new(self._key, digestmod=hashlib.sha256)
        h.update(len(self._mission).to_bytes(2, "big") + self._mission + len(to).to_bytes(2, "big") + to)
        h.update(body)
        return h.digest()

    def send(self, to: str, payload: bytes) -> None:
        self._counter = max(self._counter + 1, time.time_ns())
        body = self._head + self._counter.to_bytes(_COUNTER_BYTES, "big") + payload
        self._inner.send(to, body + self._mac(to.encode(), body))

    def receive(self) -> list[bytes]:
        out = []
        for frame in self._inner.receive():
            payload = self._open(frame)
            if payload is not None:
                out.append(payload)
        return out

    def close(self) -> None:
        self._inner.close()

    def _drop(self, reason: str, detail: str) -> None:
        self.dropped[reason] += 1
        n = self.dropped[reason]
        if n == 1 or (
            n >= 10 and str(n).strip("0") == "1"
        ):  # 1, 10, 100, ...: a flood does not flood the log
            log.warning("%s dropped a frame (%s, %d so far): %s", self.name, reason, n, detail)

    def _open(self, frame: bytes) -> bytes | None:
        """The payload of a frame that passes every check, or None (the frame is counted as dropped)."""
        if len(frame) < len(MAGIC) + 1 + _COUNTER_BYTES + _MAC_BYTES or frame[:4] != MAGIC:
            self._drop("malformed", "not an authenticated frame (no key, or another protocol)")
            return None
        n = frame[4]
        start = 5 + n + _COUNTER_BYTES
        if len(frame) < start + _MAC_BYTES:
            self._drop("malformed", "frame too short")
            return None
        body, mac = frame[:-_MAC_BYTES], frame[-_MAC_BYTES:]
        if not hmac.compare_digest(mac, self._mac(self.name.encode(), body)):
            self._drop("bad-mac", "wrong key, altered, or meant for another endpoint or mission")
            return None
        sender = body[5 : 5 + n].decode("utf-8", "replace")
        counter = int.from_bytes(body[5 + n : start], "big")
        payload = body[start:]
        try:
            inner = json.loads(payload).get("sender")
        except (ValueError, UnicodeDecodeError, AttributeError):
            inner = None
        if inner != sender:
            self._drop("sender-mismatch", f"frame from {sender!r} carries a message from {inner!r}")
            return None
        if self._max_age_ns is not None and counter < time.time_ns() - self._max_age_ns:
            self._drop("stale", f"frame from {sender!r} is {(time.time_ns() - counter) / 1e9:.0f} s old")
            return None
        if counter <= self._last.get(sender, 0):
            self._drop("replay", f"frame from {sender!r} with counter {counter} already seen")
            return None
        self._last[sender] = counter
        self.accepted += 1
        return payload


def generate_key() -> bytes:
    """A fresh random mission key (32 bytes from the operating system's CSPRNG)."""
    return secrets.token_bytes(KEY_BYTES)


def write_key_file(path: str | Path, *, force: bool = False) -> Path:
    """Write a new mission key to ``path`` (64 hex digits and a newline, mode 0600); refuse an existing file.

    Raises:
        InputError: ``path`` exists (and not ``force``) or cannot be written.
    """
    p = Path(path)
    flags = os.O_WRONLY | os.O_CREAT | (os.O_TRUNC if force else os.O_EXCL)
    try:
        fd = os.open(p, flags, 0o600)
    except FileExistsError:
        raise InputError(
            f"{p} already exists: pass `force` to replace it (every peer then needs the new key)",
            options=("force",),
        ) from None
    except OSError as exc:
        raise InputError(f"{p}: cannot write the key file: {exc.strerror}") from exc
    try:
        os.fchmod(fd, 0o600)  # O_TRUNC keeps an existing file's mode
        os.write(fd, (generate_key().hex() + "\n").encode())
    finally:
        os.close(fd)
    return p


def load_key(path: str | Path) -> bytes:
    """Read a mission key file (64 hex digits; see the module docstring).

    Raises:
        InputError: missing or unreadable file, readable by group or others, or not 64 hex digits.
    """
    p = Path(path)
    try:
        st = p.stat()
    except OSError as exc:
        raise InputError(f"`key_file` {p}: {exc.strerror}", options=("key_file",)) from exc
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"`key_file` {p}: not a regular file", options=("key_file",))
    if os.name == "posix" and st.st_mode & 0o077:
        raise InputError(
            f"`key_file` {p}: readable by group or others (mode {stat.S_IMODE(st.st_mode):04o}); "
            f"run chmod 600 {p}",
            options=("key_file",),
        )
    try:
        with p.open("rb") as f:
            raw = f.read(1024)
    except OSError as exc:
        raise InputError(f"`key_file` {p}: {exc.strerror}", options=("key_file",)) from exc
    text = raw.strip()
    try:
        key = bytes.fromhex(text.decode("ascii"))
    except (UnicodeDecodeError, ValueError):
        key = b""
    if len(key) != KEY_BYTES or len(text) != 2 * KEY_BYTES:
        raise InputError(
            f"`key_file` {p}: a key file holds {2 * KEY_BYTES} hexadecimal digits "
            f"(make one with masonry keygen -o FILE)",
            options=("key_file",),
        )
    return key


def is_loopback(endpoint: str) -> bool:
    """True if a Zenoh locator (``tcp/HOST:PORT``) names a loopback address (127.0.0.0/8, ::1, localhost)."""
    import ipaddress

    _, _, rest = endpoint.partition("/")
    host = rest.rpartition(":")[0].strip("[]")
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False  # a host name other than localhost may resolve to anything


def require_key_or_loopback(key: bytes | None, insecure: bool, endpoints: Iterable[str], what: str) -> None:
    """Without a key, refuse every endpoint that is not loopback unless ``insecure`` (docs/security.md).

    Raises:
        InputError: one line naming the first such endpoint and the ways out.
    """
    if key is not None or insecure:
        return
    for e in endpoints:
        if not is_loopback(e):
            raise InputError(
                f"{what} {e} is not loopback: give `key_file` FILE (masonry keygen -o FILE) to "
                "authenticate the mission, or `insecure` to run it unauthenticated",
                options=("key_file", "insecure"),
            )


def wrap(transport: Transport, key: bytes | None, mission: str) -> Transport:
    """``transport`` authenticated with ``key``, or as it is without a key."""
    return transport if key is None else AuthenticatedTransport(transport, key, mission=mission)


__all__ = [
    "DEFAULT_MAX_AGE_S",
    "DROP_REASONS",
    "KEY_BYTES",
    "AuthenticatedTransport",
    "generate_key",
    "is_loopback",
    "load_key",
    "require_key_or_loopback",
    "wrap",
    "write_key_file",
]
