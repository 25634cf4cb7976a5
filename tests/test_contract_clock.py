"""One Clock contract, run against the scripted fake, the simulator's clock, the wall clock the camera adapter
stamps frames with, the ``masonry fly`` zeroed clock, and the MAVLink adapter's autopilot clock on the SITL (UDP
loopback, the SITL at up to 4x real time, in lock-step as ``masonry fly`` flies ``masonry sitl --lockstep``).

What every Clock must do: read finite time that never runs backwards, and ``sleep(d)`` lets at least ``d`` of its
own time pass (exactly ``d`` for the clocks that advance only when told). The wall-time sleeps are tens of
milliseconds; no assertion bounds them from above. The autopilot's clock is checked in lock-step (issue 29):
free, its ``sleep(d)`` sleeps ``d`` over the rate it measured on the wall, and a SITL that a loaded machine
leaves unrun meanwhile moves less (``sleep(0.04)`` once read 0.015 s at x4 beside a busy loop): the SITL's
pace, not the clock's contract.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import pytest

from masonry.ports import Clock


@dataclass
class Rig:
    clock: Clock
    exact: bool  # advances only when told: sleep(d) moves it by exactly d
    slack: float = 0.0  # the fraction of d a sleep(d) may read short (a clock on a measured rate)


def _fake() -> Iterator[Rig]:
    from masonry.fakes import FakeClock

    yield Rig(FakeClock(3.0), exact=True)


def _sim() -> Iterator[Rig]:
    from masonry.sim.clock import SimClock

    yield Rig(SimClock(3.0), exact=True)


def _zeroed() -> Iterator[Rig]:
    from masonry.adapters.wiring import ZeroedClock
    from masonry.fakes import FakeClock

    clock = ZeroedClock(FakeClock(7.0))
    assert clock.now_s() == 0.0
    yield Rig(clock, exact=True)


def _wall() -> Iterator[Rig]:
    from masonry.adapters.camera import _WallClock

    yield Rig(_WallClock(), exact=False)


def _link() -> Iterator[Rig]:
    from masonry.adapters.lockstep import LockstepClock
    from masonry.adapters.mavlink import MavlinkFlightController
    from masonry.adapters.sitl import MavlinkSitl, SitlConfig, free_udp_port
    from waiting import wait_until

    port = free_udp_port()
    # held between grants however long the wall takes (the lock-step tests' setting: it never runs free here)
    sitl = MavlinkSitl(port, time_scale=4.0, config=SitlConfig(heartbeat_hz=4.0), lockstep_wait_s=60.0)
    sitl.start()
    fc = MavlinkFlightController(f"udpin:127.0.0.1:{port}", connect_timeout_s=10.0)
    clock = LockstepClock(fc)  # before connecting, as masonry fly makes it
    try:
        fc.connect()
        wait_until(lambda: clock.sleep(0.0) or clock.lockstep, 10.0, "the SITL's lock-step announcement")
        clock.sleep(0.2)
        yield Rig(clock, exact=False)
    finally:
        fc.close()
        sitl.stop()


RIGS = {"fake": _fake, "sim": _sim, "zeroed": _zeroed, "wall": _wall, "mavlink-sitl": _link}


@pytest.fixture(params=sorted(RIGS))
def rig(request) -> Iterator[Rig]:
    yield from RIGS[request.param]()


def test_time_is_finite_and_never_runs_backwards(rig: Rig) -> None:
    assert isinstance(rig.clock, Clock)
    readings = [rig.clock.now_s() for _ in range(200)]
    assert all(math.isfinite(t) for t in readings)
    assert readings == sorted(readings)
    if rig.exact:
        assert len(set(readings)) == 1  # nothing passes unless told


@pytest.mark.parametrize("duration_s", [0.0, 0.04, 0.2])
def test_sleep_lets_its_duration_pass(rig: Rig, duration_s: float) -> None:
    before = rig.clock.now_s()
    rig.clock.sleep(duration_s)
    elapsed = rig.clock.now_s() - before
    if rig.exact:
        assert elapsed == pytest.approx(duration_s, abs=1e-12)
    else:
        assert elapsed >= duration_s * (1.0 - rig.slack) - 1e-9
