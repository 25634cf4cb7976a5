"""One Transport contract (``masonry.mission.transport``), run against the in-process bus, the authenticated
transport over it, and Zenoh on loopback (two peer sessions in this process).

The payloads are encoded mission messages (:mod:`masonry.mission.messages`), what every transport carries (the
authenticated one checks that a frame's sender is the message's). What every transport must do: name its
endpoint, deliver the bytes unchanged to the named peer, drain on
``receive``, keep one sender's order, lose a message to nobody without an error, work both ways. Deliveries
over Zenoh take time: every wait is bounded (:func:`contract_waits.wait_for`).
"""

from __future__ import annotations

import socket
from collections.abc import Iterator
from contextlib import ExitStack

import pytest

from contract_waits import wait_for
from masonry.mission.messages import Heartbeat, encode
from masonry.mission.transport import Transport


def _msg(sender: str, i: float, state: str = "") -> bytes:
    return encode(Heartbeat(sender, float(i), state=state))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _inproc() -> Iterator[tuple[Transport, Transport]]:
    from masonry.mission.inproc import InprocBus

    bus = InprocBus()
    a, b = bus.endpoint("mission-control"), bus.endpoint("brick-1")
    yield a, b
    a.close()
    b.close()


def _authenticated() -> Iterator[tuple[Transport, Transport]]:
    from masonry.mission.auth import AuthenticatedTransport

    key = bytes(range(32))
    for a, b in _inproc():
        yield (
            AuthenticatedTransport(a, key, mission="contract"),
            AuthenticatedTransport(b, key, mission="contract"),
        )


def _zenoh() -> Iterator[tuple[Transport, Transport]]:
    from masonry.mission.zenoh_transport import ZenohTransport

    port = _free_port()
    with ExitStack() as stack:
        a = stack.enter_context(
            ZenohTransport("mission-control", listen=[f"tcp/127.0.0.1:{port}"], mission="contract")
        )
        b = stack.enter_context(
            ZenohTransport(
                "brick-1",
                listen=[f"tcp/127.0.0.1:{_free_port()}"],
                connect=[f"tcp/127.0.0.1:{port}"],
                mission="contract",
            )
        )
        # the sessions find each other asynchronously: ping each way until heard, then a last message; once that
        # one is in (one sender's order), no ping is left on the way and the tests start clean
        for src, dst in ((b, a), (a, b)):
            wait_for(
                lambda s=src, d=dst: (s.send(d.name, _msg(s.name, 0.0)), d.receive())[1], what="peers connect"
            )
            src.send(dst.name, _msg(src.name, -1.0))
            wait_for(lambda s=src, d=dst: _msg(s.name, -1.0) in d.receive(), what="pings drained")
        yield a, b


RIGS = {"inproc": _inproc, "authenticated": _authenticated, "zenoh": _zenoh}


@pytest.fixture(params=sorted(RIGS))
def pair(request) -> Iterator[tuple[Transport, Transport]]:
    yield from RIGS[request.param]()


def _collect(t: Transport, n: int) -> list[bytes]:
    got: list[bytes] = []

    def more() -> bool:
        got.extend(t.receive())
        return len(got) >= n

    wait_for(more, what=f"{n} messages on {t.name}")
    return got


def test_endpoints_are_transports_with_their_names(pair: tuple[Transport, Transport]) -> None:
    a, b = pair
    assert isinstance(a, Transport) and isinstance(b, Transport)
    assert (a.name, b.name) == ("mission-control", "brick-1")


def test_bytes_arrive_unchanged_and_receive_drains(pair: tuple[Transport, Transport]) -> None:
    a, b = pair
    payload = _msg("mission-control", 1.5, state="n\u00e9e \u2713 " + "x" * 4000)
    a.send("brick-1", payload)
    assert _collect(b, 1) == [payload]
    assert b.receive() == []
    assert a.receive() == []  # nothing came back to the sender


def test_one_senders_messages_keep_their_order(pair: tuple[Transport, Transport]) -> None:
    a, b = pair
    sent = [_msg("brick-1", i) for i in range(20)]
    for payload in sent:
        b.send("mission-control", payload)
    assert _collect(a, len(sent)) == sent


def test_both_ways(pair: tuple[Transport, Transport]) -> None:
    a, b = pair
    a.send("brick-1", _msg("mission-control", 1.0))
    assert _collect(b, 1) == [_msg("mission-control", 1.0)]
    b.send("mission-control", _msg("brick-1", 2.0))
    assert _collect(a, 1) == [_msg("brick-1", 2.0)]


def test_a_message_to_nobody_is_lost_not_an_error(pair: tuple[Transport, Transport]) -> None:
    a, b = pair
    a.send("nobody", _msg("mission-control", 1.0))
    a.send("brick-1", _msg("mission-control", 2.0))
    assert _collect(b, 1) == [_msg("mission-control", 2.0)]
