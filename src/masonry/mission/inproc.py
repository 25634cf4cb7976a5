"""In-process transport: endpoints on one :class:`InprocBus`, each with its own inbox (used by ``masonry sim``)."""

from __future__ import annotations

from collections import deque

from masonry.errors import MissionError


class InprocBus:
    """A set of named inboxes in one process; :meth:`endpoint` gives a transport bound to one of them."""

    def __init__(self) -> None:
        self._inboxes: dict[str, deque[bytes]] = {}
        self._cut: set[str] = set()
        self.sent = 0

    def endpoint(self, name: str) -> InprocTransport:
        """Open the endpoint ``name`` (one per name)."""
        if name in self._inboxes:
            raise MissionError(f"in-process endpoint {name!r} is already open")
        self._inboxes[name] = deque()
        return InprocTransport(self, name)

    def cut(self, name: str) -> None:
        """Simulate a dead link: from now on nothing reaches ``name`` and nothing it sends is delivered."""
        self._cut.add(name)

    def restore(self, name: str) -> None:
        """The link of ``name`` works again (after :meth:`cut`): a radio that dropped out for a while."""
        self._cut.discard(name)

    def _deliver(self, sender: str, to: str, payload: bytes) -> None:
        if sender in self._cut or to in self._cut:
            return
        inbox = self._inboxes.get(to)
        if inbox is not None:  # like a network: a message to nobody is lost, not an error
            inbox.append(payload)
            self.sent += 1

    def _drain(self, name: str) -> list[bytes]:
        inbox = self._inboxes.get(name)
        if not inbox:
            return []
        out = list(inbox)
        inbox.clear()
        return out

    def _close(self, name: str) -> None:
        self._inboxes.pop(name, None)


class InprocTransport:
    """One endpoint of an :class:`InprocBus` (implements :class:`~masonry.mission.transport.Transport`)."""

    def __init__(self, bus: InprocBus, name: str) -> None:
        self._bus = bus
        self._name = name

    @property
    def name(self) -> str:
        return self._name

    def send(self, to: str, payload: bytes) -> None:
        self._bus._deliver(self._name, to, payload)

    def receive(self) -> list[bytes]:
        inbox = self._bus._inboxes.get(self._name)  # InprocBus._drain, inline: every tick of every endpoint
        if not inbox:
            return []
        out = list(inbox)
        inbox.clear()
        return out

    def close(self) -> None:
        self._bus._close(self._name)
