"""The Transport port: how mission control and UAV handlers exchange encoded messages.

A transport is one endpoint, named after its owner (a UAV name or ``"mission-control"``). It moves opaque
bytes (the JSON of :mod:`masonry.mission.messages`); encoding and validation happen above it, so every
transport carries exactly the same protocol. Delivery is per message, unordered between senders, ordered
from one sender to one receiver.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable


@runtime_checkable
class Transport(Protocol):
    """One named endpoint: send bytes to a peer by name, drain what arrived, close."""

    @property
    def name(self) -> str: ...

    def send(self, to: str, payload: bytes) -> None: ...

    def receive(self) -> list[bytes]: ...

    def close(self) -> None: ...
