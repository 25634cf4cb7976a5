"""`masonry fly --mission` ends when its autopilot is gone for good (issue 29).

A PX4 SITL whose process died (killed 60 s into the case study on two PX4s, glue-1's) left glue-1 halted out of
service, waiting for mission control's silence (``wait_s``, 60 s), then exiting 1 with no word of why, 70 s after
the kill. The run now ends once the UAV is halted out of service with its flight controller's link down for
``autopilot_gone_s`` of wall time, and ``masonry fly`` says so in one line (measured against the real PX4:
docs/performance/autopilots.md). Here on a simulated clock: a fake handler, machine and flight controller.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from hypothesis import given
from hypothesis import strategies as st

from masonry.errors import LinkLost
from masonry.fakes import FakeClock
from masonry.mission.remote import _fly_until_done, _link_down

GONE_S = 5.0


@dataclass
class _Tel:
    link_ok: bool


@dataclass
class _Fc:
    link_ok: bool = True

    def telemetry(self) -> _Tel:
        return _Tel(self.link_ok)


@dataclass
class _Handler:
    """Mission control heard at the start and never again; the mission never ends."""

    finished: bool = False
    mission_control_heard_s: float | None = 0.0
    refused: list[str] = field(default_factory=list)
    executions: list[object] = field(default_factory=list)

    def step(self, now_s: float) -> None:
        pass


@dataclass
class _Model:
    state: str = "halted"
    finished: bool = True  # (idle on the ground, or halted: masonry.fsm.model.UavModel.finished)


def _loop(clock: FakeClock, fc: _Fc, model: _Model, max_time_s: float = 60.0) -> bool:
    def not_heard() -> LinkLost:
        raise AssertionError("mission control was heard")

    return _fly_until_done(
        _Handler(), model, clock, clock.advance, dt_s=0.05, start=(0.0, 0.0), wait_s=1e9, max_time_s=max_time_s,
        echo=None, not_heard=not_heard, autopilot_down=_link_down(fc, GONE_S, monotonic=clock.now_s),
    )  # fmt: skip


def test_a_halted_uav_whose_autopilot_stays_silent_ends_its_run() -> None:
    clock = FakeClock()
    assert _loop(clock, _Fc(link_ok=False), _Model("halted"))
    assert GONE_S <= clock.now_s() < GONE_S + 0.1


def test_a_uav_with_its_autopilot_answering_or_still_flying_goes_on() -> None:
    # idle on the ground with the link down: the machine retires it (link_watch), then the rule counts
    cases = ((_Fc(link_ok=True), _Model("halted")), (_Fc(link_ok=False), _Model("emergency", finished=False)),
             (_Fc(link_ok=False), _Model("idle")))  # fmt: skip
    for fc, model in cases:
        clock = FakeClock()
        assert not _loop(clock, fc, model, max_time_s=30.0)  # (ran to max_time_s)
        assert clock.now_s() >= 30.0


@given(st.lists(st.tuples(st.booleans(), st.booleans()), min_size=1, max_size=40))
def test_gone_only_after_gone_s_of_the_uav_down_with_its_link_down(samples: list[tuple[bool, bool]]) -> None:
    """One sample a second (the UAV halted, its link up): gone exactly when the trailing run of (halted, link down)
    samples spans ``GONE_S`` seconds."""
    clock = FakeClock()
    fc = _Fc()
    gone = _link_down(fc, GONE_S, monotonic=clock.now_s)
    run = 0
    for halted, link_ok in samples:
        fc.link_ok = link_ok
        run = run + 1 if halted and not link_ok else 0
        assert gone(halted) == (run - 1 >= GONE_S)
        clock.advance(1.0)
