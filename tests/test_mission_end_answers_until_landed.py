"""Mission control answers on after its MissionEnd until every UAV has landed (issue 29).

`masonry mission-control` left 2 s after the mission's end. A brick UAV whose flight home it had not granted by then
(its last task ends at the wall, its way home needs the site's column) hovered where it stopped for
``LAST_RESORT_S`` (30 s) before flying home on its fallback layer, and its `masonry fly --mission` ran on meanwhile
(seen on ArduCopter SITL: 30 s over the wall, then a flight home at 2.2 m). Now mission control may leave only once
each UAV is on its pad, out of the mission, or was never heard (``MissionControl.may_leave``), at most
``LANDING_GRACE_S`` after the end; and a UAV whose run ends says it has landed at once (``UavHandler.say_finished``).
Messages fed by hand over the in-process bus, on simulated time.
"""

from __future__ import annotations

from dataclasses import dataclass

from hypothesis import given
from hypothesis import strategies as st

from masonry.blueprint import UavSpec
from masonry.errors import LinkLost
from masonry.fakes import FakeClock
from masonry.mission.control import LANDING_GRACE_S, MissionControl
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus
from masonry.mission.messages import (
    MISSION_CONTROL,
    Assign,
    Clearance,
    ClearanceRequest,
    Heartbeat,
    MissionEnd,
    Result,
    decode,
    encode,
)
from masonry.mission.remote import _fly_until_done
from masonry.planner.tasks import BrickTask, Plan
from masonry.ports import TaskResult

HOME = (0.0, -6.0, 0.0)
SITE = (0.0, -3.0, 0.05)
#: mission control's least wait after its end (cli.mission.END_HEARD_S at x1)
HEARD_S = 2.0


def _one_brick() -> tuple[MissionControl, InprocBus]:
    bus = InprocBus()
    plan = Plan((BrickTask("B0", 0, False, (0.0, -3.0, 0.15), 0.0, (3.0, -3.0, 0.05)),), (), ())
    mc = MissionControl(
        plan, (UavSpec("a", "brick", HOME),), bus.endpoint(MISSION_CONTROL), layer_base_m=1.35
    )
    return mc, bus


def _beat(ep, t: float, state: str, pos) -> None:
    ep.send(MISSION_CONTROL, encode(Heartbeat("a", t, state, None, pos, on_pad=state == "idle")))


def _ended(mc: MissionControl, bus: InprocBus) -> tuple[object, float, list[object]]:
    """UAV ``a`` takes B0 and reports it done at the wall: mission control ends the mission. Its endpoint, the end's
    time, and what it has heard since (the MissionEnd)."""
    a = bus.endpoint("a")
    heard: list[object] = []
    t = 0.0
    while mc.ended_at_s is None and t < 60.0:
        heard += [decode(raw) for raw in a.receive()]
        attempt = next((m.attempt for m in heard if isinstance(m, Assign)), None)
        if attempt is None:
            _beat(a, t, "idle", HOME)
        elif t >= 10.0:
            result = TaskResult("B0", "done", 10.0, placement_error_m=0.005)
            a.send(MISSION_CONTROL, encode(Result("a", result, t, (0.0, -3.0, 1.2), "place_ascend", attempt)))
        else:
            _beat(a, t, "place_descend", (0.0, -3.0, 0.6))
        mc.step(t)
        t = round(t + 0.5, 3)
    assert mc.ended_at_s is not None and mc.finished
    return a, mc.ended_at_s, [decode(raw) for raw in a.receive()]


def test_mission_control_answers_a_late_flight_home_and_leaves_once_the_uav_has_landed() -> None:
    mc, bus = _one_brick()
    a, end_s, heard = _ended(mc, bus)
    assert any(isinstance(m, MissionEnd) and m.completed for m in heard)
    t = end_s
    answers: list[Clearance] = []
    landed_s = None
    while t < end_s + 60.0:
        t = round(t + 0.5, 3)
        flown_s = t - end_s
        # it hovers at the wall, asks for its way home only 5 s after the end (a slow link), then lands
        if flown_s < 20.0:
            _beat(a, t, "home", (0.0, -3.0, 1.2) if flown_s < 8.0 else (0.0, -5.0, 1.2))
            if flown_s >= 5.0 and flown_s % 1.0 == 0.0 and not answers:
                a.send(MISSION_CONTROL, encode(ClearanceRequest("a", HOME, t, (0.0, -3.0, 1.2))))
        else:
            _beat(a, t, "idle", HOME)
            landed_s = landed_s or t
        mc.step(t)
        answers += [m for m in map(decode, a.receive()) if isinstance(m, Clearance) and m.granted]
        if mc.may_leave(t, HEARD_S):
            break
        assert landed_s is None or t < landed_s + 1.0, (
            "mission control stayed after the UAV said it had landed"
        )
    # its way home was granted 5 s after the end (mission control left after 2 s before: 30 s of hovering)
    assert answers and answers[0].time_s >= end_s + 5.0
    assert landed_s is not None and t == landed_s  # it left at the heartbeat that said so, not before


def test_mission_control_leaves_without_a_uav_that_fell_silent_or_after_the_grace() -> None:
    mc, bus = _one_brick()
    a, end_s, _ = _ended(mc, bus)
    t = end_s
    while not mc.may_leave(t, HEARD_S):  # silent from the end: declared lost after its heartbeat timeout
        t = round(t + 0.5, 3)
        mc.step(t)
    assert end_s + mc.liveness.timeouts.heartbeat_s <= t < end_s + mc.liveness.timeouts.heartbeat_s + 1.0
    mc, bus = _one_brick()
    a, end_s, _ = _ended(mc, bus)
    t = end_s
    while not mc.may_leave(t, HEARD_S):  # hovering for ever, heartbeating: the grace's end
        t = round(t + 0.5, 3)
        _beat(a, t, "home", (0.0, -3.0, 1.2))
        mc.step(t)
    assert t == end_s + LANDING_GRACE_S


def test_a_uav_that_landed_and_left_after_the_end_is_not_lost() -> None:
    """Its `masonry fly --mission` ends once it is on its pad after the end; mission control, answering on for the
    others, does not declare it lost for the silence that follows (its report said so before: it left 2 s after
    the end, before any timeout)."""
    mc, bus = _one_brick()
    a, end_s, _ = _ended(mc, bus)
    _beat(a, end_s, "home", (0.0, -3.0, 1.2))
    mc.step(end_s)
    _beat(a, end_s + 20.0, "idle", HOME)  # landed: its last word
    t = end_s + 20.0
    while t < end_s + 60.0:
        mc.step(t)
        t = round(t + 0.5, 3)
    assert mc.may_leave(t, HEARD_S) and mc.uavs["a"].status == "ok" and not mc.uavs["a"].lost


@given(st.floats(0.0, 400.0), st.booleans())
def test_never_before_every_handler_had_time_to_hear_the_end(since_s: float, landed: bool) -> None:
    mc, bus = _one_brick()
    a, end_s, _ = _ended(mc, bus)
    _beat(a, end_s, "idle" if landed else "home", HOME if landed else (0.0, -3.0, 1.2))
    mc.step(end_s)
    leaves = mc.may_leave(end_s + since_s, HEARD_S)
    assert leaves == (since_s >= HEARD_S and (landed or since_s >= LANDING_GRACE_S))
    assert not mc.may_leave(0.0, HEARD_S) or mc.ended_at_s is not None


@dataclass
class _Landed:
    """The machine, landed on its pad with no task."""

    state: str = "idle"
    finished: bool = True

    def step(self, now_s: float) -> None:
        pass


def test_a_uav_whose_run_ends_says_it_has_landed_at_once() -> None:
    bus = InprocBus()
    mc = bus.endpoint(MISSION_CONTROL)
    handler = UavHandler("a", bus.endpoint("a"), position=lambda: HOME)
    handler.attach(_Landed())
    clock = FakeClock()
    handler.step(0.0)  # its heartbeat of the second
    mc.send("a", encode(MissionEnd(MISSION_CONTROL, 0.2, True)))
    clock.advance(0.2)

    def not_heard() -> LinkLost:
        raise AssertionError("mission control was heard")

    lost = _fly_until_done(handler, handler.model, clock, clock.advance, dt_s=0.05, start=(0.0, 0.0), wait_s=60.0,
                           max_time_s=60.0, echo=None, not_heard=not_heard)  # fmt: skip
    assert not lost and clock.now_s() < 0.3  # (the loop ends at the tick that heard the end)
    beats = [m for m in map(decode, mc.receive()) if isinstance(m, Heartbeat)]
    assert [(b.time_s, b.on_pad) for b in beats] == [(0.0, True), (0.2, True)]  # the last one off its period
