"""masonry.adapters.arming: an arming refused as temporary is asked again, for a bounded time (issue 29); the
autopilot's refusal text whole (PX4 sends long ones in chunks)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from masonry.adapters.arming import ARM_RETRY_INTERVAL_S, arm_retrying
from masonry.adapters.link_values import StatusText, add_status_text
from masonry.errors import CommandRejected


class Autopilot:
    """Answers arming with the refusals given, then accepts; time passes only in ``wait``."""

    def __init__(self, refusals: list[CommandRejected]) -> None:
        self.refusals = list(refusals)
        self.now_s = 100.0
        self.asked = 0
        self.waits: list[float] = []

    def arm(self) -> None:
        self.asked += 1
        if self.refusals:
            raise self.refusals.pop(0)

    def wait(self, seconds: float) -> bool:
        self.waits.append(seconds)
        self.now_s += seconds
        return False

    def monotonic(self) -> float:
        return self.now_s


def temporary() -> CommandRejected:
    return CommandRejected("arm", "temporarily rejected", temporary=True)


def test_accepted_at_once_asks_once() -> None:
    ap = Autopilot([])
    assert arm_retrying(ap.arm, ap.monotonic, ap.wait, 30.0) == 0
    assert ap.asked == 1 and ap.waits == []


def test_temporary_refusals_are_asked_through() -> None:
    ap = Autopilot([temporary() for _ in range(6)])  # PX4 v1.16 SITL: 3 s of refusals
    assert arm_retrying(ap.arm, ap.monotonic, ap.wait, 30.0) == 6
    assert ap.asked == 7
    assert ap.waits == [ARM_RETRY_INTERVAL_S] * 6


def test_a_refusal_that_is_not_temporary_is_raised_at_once() -> None:
    ap = Autopilot([temporary(), CommandRejected("arm", "failed: PreArm: Compass not calibrated")])
    with pytest.raises(CommandRejected, match="Compass not calibrated") as info:
        arm_retrying(ap.arm, ap.monotonic, ap.wait, 30.0)
    assert not info.value.temporary
    assert ap.asked == 2


def test_offboard_refused_for_want_of_setpoints_is_asked_again_and_other_mode_refusals_are_not() -> None:
    """Issue 29: a switch to OFFBOARD refused because the zero burst went stale (a client starved under load),
    as FAILED (the project's SITL before issue 29), is asked again; a mode refusal for another reason is not."""
    starved = CommandRejected(
        "set mode OFFBOARD", "failed: Switching to Offboard is not possible: no setpoints"
    )
    ap = Autopilot([starved])
    assert arm_retrying(ap.arm, ap.monotonic, ap.wait, 30.0) == 1
    assert ap.asked == 2 and ap.waits == [ARM_RETRY_INTERVAL_S]
    for other in (
        CommandRejected("set mode OFFBOARD", "failed: Mode change to OFFBOARD failed: requires position"),
        CommandRejected("set mode GUIDED", "failed: no setpoints"),  # ArduPilot: as before
    ):
        ap = Autopilot([other])
        with pytest.raises(CommandRejected) as info:
            arm_retrying(ap.arm, ap.monotonic, ap.wait, 30.0)
        assert info.value is other and ap.asked == 1


def test_temporary_refusals_end_after_the_bound_with_how_long() -> None:
    ap = Autopilot([temporary() for _ in range(1000)])
    with pytest.raises(CommandRejected) as info:
        arm_retrying(ap.arm, ap.monotonic, ap.wait, 5.0)
    assert info.value.temporary and info.value.command == "arm"
    assert info.value.reason == "temporarily rejected for 5.0 s (asked 11 times, for at most 5 s)"
    assert sum(ap.waits) <= 5.0
    assert isinstance(info.value.__cause__, CommandRejected)


def test_no_bound_raises_the_first_refusal() -> None:
    ap = Autopilot([temporary()])
    with pytest.raises(
        CommandRejected, match=r"temporarily rejected for 0\.0 s \(asked 1 times, for at most 0 s\)$"
    ):
        arm_retrying(ap.arm, ap.monotonic, ap.wait, 0.0)
    assert ap.asked == 1


def test_a_closing_link_stops_the_asking() -> None:
    ap = Autopilot([temporary() for _ in range(3)])
    ap.wait = lambda seconds: True  # type: ignore[method-assign]  # the link's stop event is set
    with pytest.raises(CommandRejected, match=r"^arm rejected: temporarily rejected$"):
        arm_retrying(ap.arm, ap.monotonic, ap.wait, 30.0)
    assert ap.asked == 1


def test_px4s_long_status_text_is_joined_from_its_chunks() -> None:
    # PX4 v1.16 SITL's refusal came as two STATUSTEXT chunks of one id: the reason read "t\t" without the join
    texts: list[StatusText] = []
    add_status_text(texts, SimpleNamespace(severity=4, text="Ready", id=0, chunk_seq=0), 1.0)
    first = "Arming denied: Resolve system health failures firs"
    add_status_text(texts, SimpleNamespace(severity=4, text=first, id=7, chunk_seq=0), 2.0)
    add_status_text(texts, SimpleNamespace(severity=4, text="t\t", id=7, chunk_seq=1), 2.01)
    add_status_text(texts, SimpleNamespace(severity=6, text="other", id=8, chunk_seq=0), 3.0)
    add_status_text(
        texts, SimpleNamespace(severity=6, text="stray", id=9, chunk_seq=1), 3.5
    )  # its start lost
    assert [t[2] for t in texts] == ["Ready", first + "t\t", "other", "stray"]
    assert texts[1][:2] == (2.0, 4)


def test_the_status_text_log_keeps_the_last_twenty() -> None:
    texts: list[StatusText] = []
    for i in range(25):
        add_status_text(texts, SimpleNamespace(severity=6, text=f"t{i}\x00\x00", id=0, chunk_seq=0), float(i))
    assert [t[2] for t in texts] == [f"t{i}" for i in range(5, 25)]
