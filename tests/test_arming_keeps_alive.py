"""Arming through an autopilot's refusals keeps the UAV's heartbeat going (issue 29's "uav lost").

PX4 answers an arming TEMPORARILY_REJECTED while its checks fail, and :meth:`MavlinkFlightController.arm` asks
again for up to 30 s: a call that blocks the UAV's tick, and with it the heartbeat to mission control, which
declares a UAV silent for 5 s lost (the case study on two PX4s lost glue-1 30 s in). The adapter's waits now call
its ``keep_alive`` (:class:`masonry.ports.WaitsAlive`), which ``masonry fly --mission`` points at the handler's
:meth:`~masonry.mission.handler.UavHandler.keep_alive`. Here mission control and the UAV's handler share an
in-process bus and one simulated clock, which the adapter's own wait advances (no sleep).
"""

from __future__ import annotations

from masonry.adapters.arming import ARM_RETRY_INTERVAL_S, arm_retrying
from masonry.adapters.mavlink import MavlinkFlightController
from masonry.blueprint_gen import running_bond
from masonry.errors import CommandRejected
from masonry.fakes import FakeClock
from masonry.mission.control import MissionControl
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus
from masonry.mission.messages import MISSION_CONTROL
from masonry.planner import plan
from masonry.ports import WaitsAlive

#: PX4 refused arming this long (s) before accepting it: less than the adapter's 30 s, far more than the 5 s
#: mission control waits for a heartbeat.
REFUSED_S = 20.0


class _SimulatedWait:
    """The adapter's stop event on the simulated clock: a wait moves the clock (mission control ticking along,
    as its own process would) and is never cut short."""

    def __init__(self, clock: FakeClock, mc: MissionControl, others: list[UavHandler]) -> None:
        self.clock, self.mc, self.others = clock, mc, others

    def wait(self, seconds: float) -> bool:
        end_s = self.clock.now_s() + seconds
        while self.clock.now_s() < end_s - 1e-9:
            self.clock.advance(min(0.05, end_s - self.clock.now_s()))
            for h in self.others:  # the fleet's other UAVs, in their own processes
                h.step(self.clock.now_s())
            self.mc.step(self.clock.now_s())
        return False

    def set(self) -> None:
        """(``close()`` sets it.)"""


def _arm_for_20_s(keep_alive: bool) -> tuple[MissionControl, str, int]:
    """Mission control and one UAV's handler heard each other; the UAV then arms through 20 s of refusals.

    Returns mission control, the UAV's name and how often the autopilot was asked."""
    bp = running_bond(1, 2, brick_uavs=1, adhesion_uavs=1)
    bus = InprocBus()
    clock = FakeClock()
    mc = MissionControl(plan(bp), bp.fleet, bus.endpoint(MISSION_CONTROL), startup_timeout_s=100.0)
    handlers = [
        UavHandler(u.name, bus.endpoint(u.name), position=lambda u=u: (u.home_m[0], u.home_m[1], 0.0))
        for u in bp.fleet
    ]
    for _ in range(40):  # two seconds: everybody heard everybody
        for h in handlers:
            h.step(clock.now_s())
        mc.step(clock.now_s())
        clock.advance(0.05)
    uav = handlers[0]
    assert not mc.uavs[uav.name].lost
    fc = MavlinkFlightController("udpin:127.0.0.1:0")  # never connected: only its wait is used
    fc._stop = _SimulatedWait(clock, mc, handlers[1:])  # type: ignore[assignment]
    assert isinstance(fc, WaitsAlive)
    if keep_alive:  # as masonry.mission.remote.run_remote_uav wires it
        fc.keep_alive = lambda: uav.keep_alive(clock.now_s())
    start_s = clock.now_s()
    asked = [0]

    def px4_arm() -> None:
        asked[0] += 1
        if clock.now_s() - start_s < REFUSED_S:
            raise CommandRejected("arm", "temporarily rejected", temporary=True)

    refusals = arm_retrying(px4_arm, clock.now_s, fc._pause)
    assert refusals == asked[0] - 1 and clock.now_s() - start_s >= REFUSED_S
    return mc, uav.name, asked[0]


def test_mission_control_hears_the_uav_all_through_a_20_s_arming() -> None:
    mc, name, asked = _arm_for_20_s(keep_alive=True)
    assert not mc.uavs[name].lost
    assert asked >= REFUSED_S / ARM_RETRY_INTERVAL_S  # asked every half second throughout


def test_without_the_keep_alive_mission_control_loses_it() -> None:
    """The model before: the same arming, the heartbeat silent for its 20 s."""
    mc, name, _ = _arm_for_20_s(keep_alive=False)
    assert mc.uavs[name].lost
