"""The fly loop's tick on a real autopilot's clock is due ``dt_s`` after the last one woke (issue 29).

Against the real PX4 the 20 Hz loop ticked at 8-9 Hz: it waited a whole ``dt_s`` after the machine's own work,
which runs on the autopilot's clock too. In lock-step the clock stands while the tick works and the wait stays
``dt_s`` exactly.
"""

from __future__ import annotations

import itertools
import random
from dataclasses import dataclass, field

import numpy as np
import pytest

from fsm_rig import Rig
from masonry.adapters.wiring import _advance_on
from masonry.fsm.tuning import uav_settings


@dataclass
class WorkClock:
    """A clock that runs on while the machine works (``work``) and records what it was asked to sleep."""

    t_s: float = 0.0
    slept_s: list[float] = field(default_factory=list)

    def now_s(self) -> float:
        return self.t_s

    def sleep(self, duration_s: float) -> None:
        self.slept_s.append(duration_s)
        self.t_s += duration_s


@dataclass
class Paced:
    lockstep: bool
    gone: bool = False


def _fly(clock: WorkClock, advance: object, work_s: float, ticks: int) -> float:
    start_s = clock.now_s()
    for _ in range(ticks):
        clock.t_s += work_s  # the machine's step
        advance(0.05)  # type: ignore[operator]
    return ticks / (clock.now_s() - start_s)


def test_off_lockstep_the_tick_keeps_its_rate_whatever_the_work() -> None:
    clock = WorkClock()
    rate_hz = _fly(clock, _advance_on(clock, None, Paced(lockstep=False)), work_s=0.03, ticks=100)
    assert rate_hz == pytest.approx(20.0, rel=0.01)  # was 12.5 Hz: 0.05 s of sleep after 0.03 s of work
    assert clock.slept_s[1:] == pytest.approx([0.02] * 99)


def test_a_tick_that_overran_waits_nothing_and_does_not_catch_up() -> None:
    clock = WorkClock()
    advance = _advance_on(clock, None, Paced(lockstep=False))
    _fly(clock, advance, work_s=0.01, ticks=3)
    _fly(clock, advance, work_s=0.2, ticks=1)  # a stall
    assert clock.slept_s[-1] == 0.0
    _fly(clock, advance, work_s=0.01, ticks=2)
    assert clock.slept_s[-2:] == pytest.approx([0.04, 0.04])  # back on its period, no burst of short ticks


def test_in_lockstep_each_wait_is_dt_exactly() -> None:
    clock = WorkClock()
    _fly(clock, _advance_on(clock, None, Paced(lockstep=True)), work_s=0.0, ticks=50)
    assert clock.slept_s == [0.05] * 50


def test_a_lockstep_sitl_gone_is_paced_as_any_link() -> None:
    clock = WorkClock()
    _fly(clock, _advance_on(clock, None, Paced(lockstep=True, gone=True)), work_s=0.03, ticks=10)
    assert clock.slept_s[1:] == pytest.approx([0.02] * 9)


def _machine_ticks(call_times_s: list[float]) -> list[float]:
    """The times a brick UAV's machine (control period 0.1 s) ticked, stepped at ``call_times_s``."""
    rig = Rig("brick")
    ticks: list[float] = []
    for t_s in call_times_s:
        rig.clock.advance(t_s - rig.clock.now_s())
        before = rig.uav._last_step_s
        rig.uav.step(t_s)
        if rig.uav._last_step_s != before:
            ticks.append(t_s)
    return ticks


@pytest.mark.parametrize("jitter_s", [0.0, 0.002, 0.01])
def test_the_machine_ticks_its_period_on_average_when_the_loop_comes_a_hair_early_or_late(
    jitter_s: float,
) -> None:
    """A 20 Hz fly loop whose calls come ``jitter_s`` early or late (a real autopilot's clock) ticks the machine's
    0.1 s period ten times a second: each tick due on the grid of the last one's due time. Due a period after the
    last tick came, every other one waited a third call (0.15 s): 7.8 Hz on the real PX4 (issue 29)."""
    rng = random.Random(3)
    calls = [0.05 * k + rng.uniform(-jitter_s, jitter_s) for k in range(1, 401)]
    ticks = _machine_ticks(calls)
    gaps = [b - a for a, b in itertools.pairwise(ticks)]
    assert 198 <= len(ticks) <= 201
    assert max(gaps) <= 0.15 + 2 * jitter_s + 1e-9


def test_after_a_stall_the_machine_ticks_once_then_a_period_later() -> None:
    """A loop left unrun for 2 s: one tick when it runs again, the next a period after it (no burst to catch up)."""
    calls = [0.05 * k for k in range(1, 21)] + [3.0 + 0.05 * k for k in range(10)]
    ticks = _machine_ticks(calls)
    assert [round(t, 2) for t in ticks if t >= 3.0] == [3.0, 3.1, 3.2, 3.3, 3.4]


def test_the_side_looks_pass_ticks_at_last_leg_period_s_where_the_loop_calls_that_often() -> None:
    """On the side look's last leg's pass (``place_descend``, the leg flown, no look back up) a brick UAV with
    ``last_leg_period_s`` ticks at that period: on the real PX4 the pass crossed the 1.5 cm disc at 0.2-0.35 m/s,
    2-3.5 cm a 0.1 s tick, and went through it between two ticks (docs/performance/autopilots.md, branch px4leg37).
    Anywhere else, and without the setting, the control period."""
    assert uav_settings("px4")["last_leg_period_s"] == 0.05
    assert "last_leg_period_s" not in uav_settings("arducopter")
    rig = Rig("brick", config={"last_leg_period_s": 0.05})
    uav = rig.uav
    assert uav._control_period_s() == 0.1  # idle
    uav._side.offset_m = np.array([-0.15, 0.0, 0.0])
    uav._side.final = True
    uav.state = "place_descend"
    assert uav._control_period_s() == 0.05
    uav._gate.looking = True  # a look back up: the control period
    assert uav._control_period_s() == 0.1
    uav._gate.looking = False
    plain = Rig("brick").uav
    plain._side.offset_m, plain._side.final, plain.state = np.array([-0.15, 0.0, 0.0]), True, "place_descend"
    assert plain._control_period_s() == 0.1  # the setting off (the default)
    # the tick's grid at the shorter period: a 20 Hz loop ticks it 20 times a second
    rig = Rig("brick")
    rig.uav._control_period_s = lambda: 0.05
    ticks = []
    for k in range(1, 41):
        t_s = 0.05 * k
        rig.clock.advance(t_s - rig.clock.now_s())
        before = rig.uav._last_step_s
        rig.uav.step(t_s)
        if rig.uav._last_step_s != before:
            ticks.append(t_s)
    assert len(ticks) == 40
