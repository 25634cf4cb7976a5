"""In a wind the brick UAV aligns on the wall's markers (issue 30, masonry.fsm.wind_lean): its tilt in the
pickup's hovers, averaged, says whether it places in a wind; calm air keeps the preset's placement."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from masonry.blueprint_gen import pyramid
from masonry.fsm.brick import BrickUav
from masonry.fsm.config import UavConfig
from masonry.fsm.tuning import PRESETS, uav_settings
from masonry.fsm.wind_lean import LEAN_TAU_S, WindLean, place_gains
from masonry.mission.simulate import SimulatedMission
from masonry.motion import PIDGains
from masonry.ports import Telemetry
from masonry.sim import Faults
from masonry.sim.wind import WindConfig


def _tel(roll_rad: float, pitch_rad: float, yaw_rad: float = 0.0) -> Telemetry:
    return Telemetry(
        time_s=0.0,
        position_m=(0.0, 0.0, 1.0),
        velocity_mps=(0.0, 0.0, 0.0),
        attitude_rad=(roll_rad, pitch_rad, yaw_rad),
        armed=True,
        mode="GUIDED",
        battery_fraction=1.0,
        link_ok=True,
        position_ok=True,
        on_ground=False,
    )


def test_the_tilt_averaged_over_the_hovers_says_wind() -> None:
    lean = WindLean()
    assert not lean.windy(0.02)  # nothing seen yet: calm
    for _ in range(
        int(3 * LEAN_TAU_S / 0.1)
    ):  # a 3-degree lean, in gusts swinging about the wind's direction
        lean.follow(_tel(math.radians(3.0), 0.0), 0.1)
        lean.follow(_tel(0.0, -math.radians(3.0)), 0.1)
    assert lean.tilt_rad == pytest.approx(math.radians(3.0), rel=0.1)
    assert lean.windy(0.02)
    assert not lean.windy(0.0)  # a threshold of 0: never
    assert not lean.windy(0.1)
    one_gust = WindLean()
    one_gust.follow(_tel(0.3, 0.0), 0.1)  # one tick's 17 degrees in calm air is a manoeuvre, not a wind
    assert not one_gust.windy(0.02)


def test_a_swing_about_the_vertical_is_not_a_wind_where_a_held_lean_is_asked() -> None:
    """The real PX4's calm hover (issues 29/30, branch px441): it swings 0.1-0.13 rad either way at a ~1.3 s period, its
    tilt averaged over 0.07 rad; held one way, averaged as a direction, it leans near 0. A wind leans it one way,
    whatever way the UAV faces."""
    swing = WindLean()
    for i in range(int(3 * LEAN_TAU_S / 0.1)):
        phase = 2.0 * math.pi * i * 0.1 / 1.3
        swing.follow(_tel(0.12 * math.sin(phase), 0.03 * math.cos(phase)), 0.1)
    assert swing.tilt_rad > 0.07 and swing.held_rad < 0.01
    assert swing.windy(0.07)  # the magnitude alone says wind
    assert not swing.windy(0.07, 0.05)
    wind = WindLean()
    for i in range(int(3 * LEAN_TAU_S / 0.1)):
        # turning: the lean held toward -y in the world is a roll at yaw 0, a pitch at pi/2
        yaw = 0.5 * i * 0.1
        wind.follow(_tel(0.08 * math.cos(yaw), -0.08 * math.sin(yaw), yaw), 0.1)
    assert wind.held_rad == pytest.approx(0.08, rel=0.1)
    assert wind.windy(0.07, 0.05) and not wind.windy(0.07, 0.1)


def test_the_real_px4s_calm_pickup_that_read_as_a_wind_is_calm_by_3_mrad() -> None:
    """Brick-1's first pickup on a real PX4 in calm air (tests/data/px4_calm_pickup.json, 14.6 s of hovers; issues
    29/30, branch px441's base-2): its tilt averaged to 0.071 rad, over the ``px4`` preset's 0.07 (on main before
    px441 it flew as in a wind: B0 let go at the tick, 20.2 mm off), and its lean held one way to 0.047, 3 mrad under
    the preset's 0.05. The real PX4's reported attitude holds EKF2's tilt error (branch px442: held 0.069 and 0.076
    rad at most in two of three 40 s calm holds, SIH's truth 0.014-0.016), so this margin is thin by what the lean can
    tell; averaged over 8 s it was 0.037 (tried, not kept: the px4 model's 2 m/s bricks a little farther apart,
    docs/performance/autopilots.md)."""
    record = json.loads((Path(__file__).parent / "data" / "px4_calm_pickup.json").read_text())
    lean = WindLean()
    for roll, pitch, yaw in record["attitude_rad"]:
        lean.follow(_tel(roll, pitch, yaw), record["tick_s"])
    assert lean.tilt_rad == pytest.approx(0.071, abs=0.001)
    assert lean.held_rad == pytest.approx(0.047, abs=0.001)
    assert lean.windy(PRESETS["px4"]["wall_in_wind_rad"])  # the magnitude alone: a wind
    assert not lean.windy(PRESETS["px4"]["wall_in_wind_rad"], PRESETS["px4"]["wind_held_rad"])


def test_only_the_arducopter_and_px4_presets_turn_it_on() -> None:
    assert UavConfig("b", "brick", (0.0, 0.0, 0.0)).wall_in_wind_rad == 0.0
    assert PRESETS["arducopter"]["wall_in_wind_rad"] > 0.0
    # px4 aligns on the wall in any air: its lean says only which gain a placement flies (over its calm 0.05 rad)
    assert PRESETS["px4"]["wall_in_wind_rad"] > 0.055 and PRESETS["px4"]["wind_xy_kp_per_s"] == 2.0
    assert UavConfig("b", "brick", (0.0, 0.0, 0.0)).wind_xy_kp_per_s == 0.0
    # the held lean: px4 only (its real hover's swing); arducopter and ideal judge the magnitude alone
    assert PRESETS["px4"]["wind_held_rad"] == 0.05
    assert UavConfig("b", "brick", (0.0, 0.0, 0.0)).wind_held_rad == 0.0
    assert "wind_held_rad" not in PRESETS["arducopter"] and "wind_held_rad" not in PRESETS["ideal"]
    assert "wind_xy_kp_per_s" not in PRESETS["arducopter"] and "wind_xy_kp_per_s" not in PRESETS["ideal"]


def test_place_gains_swap_the_horizontal_kp_in_a_wind_only() -> None:
    configured = uav_settings("px4")["pid_gains"]
    assert place_gains(configured, 2.0, False) is configured
    assert place_gains(configured, 0.0, True) is configured
    windy = place_gains(configured, 2.0, True)
    assert windy.x.kp == windy.y.kp == 2.0 and configured.x.kp == 1.5
    assert (windy.x.ki, windy.z, windy.yaw) == (configured.x.ki, configured.z, configured.yaw)
    assert place_gains(None, 2.0, True).z == PIDGains().z


def _px4_kp(monkeypatch: pytest.MonkeyPatch, wind: Faults | None) -> list[float]:
    """The px4 preset's pyramid of two: the horizontal kp each place alignment flies."""
    kps: list[float] = []
    align = BrickUav.enter_place_align

    def record(self: BrickUav, *args: object, **kwargs: object) -> None:
        align(self, *args, **kwargs)
        kps.append(self.nav.pid.gains.x.kp)

    monkeypatch.setattr(BrickUav, "enter_place_align", record)
    bp = pyramid(2, yaw_rad=math.radians(30.0), clearance_m=1.0)
    assert SimulatedMission.from_blueprint(bp, seed=0, vehicle="px4", faults=wind).run().completed
    return kps


def test_px4_places_in_a_wind_on_kp_2_and_in_calm_air_on_its_own_loops_kp(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The refitted px4 model (issue 29) in 4 m/s wind did not hold the alignment gates with kp 1.5
    (docs/performance/as-built.md "The px4 placement on the refitted model"); calm air keeps kp 1.5."""
    assert set(_px4_kp(monkeypatch, None)) == {1.5}
    windy = _px4_kp(monkeypatch, Faults(wind=WindConfig(speed_mps=4.0, turbulence="light")))
    assert windy and set(windy) == {2.0}


def _on_wall(monkeypatch: pytest.MonkeyPatch, wind: Faults | None) -> list[tuple[bool, int]]:
    """The arducopter preset's default pyramid of three: per descent, whether it aligned on the wall and how many
    of the wall's bricks it had seen."""
    seen: list[tuple[bool, int]] = []
    descend = BrickUav.enter_place_descend

    def record(self: BrickUav, *args: object, **kwargs: object) -> None:
        descend(self, *args, **kwargs)
        seen.append((self.on_wall, len(self._wall.estimates)))

    monkeypatch.setattr(BrickUav, "enter_place_descend", record)
    bp = pyramid(2, yaw_rad=math.radians(30.0), clearance_m=1.0)
    mission = SimulatedMission.from_blueprint(bp, seed=0, vehicle="arducopter", faults=wind)
    assert mission.run().completed
    return seen


def test_in_4_m_s_wind_the_arducopter_brick_uav_aligns_on_the_wall(monkeypatch: pytest.MonkeyPatch) -> None:
    """4 m/s, light turbulence: every descent aligns on the wall, and the top brick's saw a brick under it
    (without masonry.fsm.wind_lean: none, the bricks 14-16 mm mean from their neighbours against 9-11 aligned,
    docs/performance/as-built.md)."""
    seen = _on_wall(monkeypatch, Faults(wind=WindConfig(speed_mps=4.0, turbulence="light")))
    assert seen and all(on for on, _ in seen)
    assert seen[-1][1] >= 1


def test_in_calm_air_it_places_as_before(monkeypatch: pytest.MonkeyPatch) -> None:
    seen = _on_wall(monkeypatch, None)
    assert seen and not any(on for on, _ in seen)
