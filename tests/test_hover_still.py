"""The adhesion UAV's hover over a segment's start on a noisy position source (issue 29, masonry.fsm.hover_still)."""

from __future__ import annotations

import dataclasses
import math

from fsm_rig import Rig
from masonry.fakes import FakeFlightController
from masonry.fsm.hover_still import HoverStill
from masonry.fsm.tuning import uav_settings
from masonry.ports import Telemetry

ORBIT_M = 0.10  # the scripted hover's swing about its centre (m)
ORBIT_PERIOD_S = 1.7  # ... and its period (s)
CENTRE_M = (0.015, 0.0, 0.0)  # the scripted hover's centre, off the point (m)


def _orbit(t_s: float) -> tuple[float, float, float]:
    """PX4 v1.16 SITL's hover over A0's start beside busy processes, scripted: 4-6 cm rms off the point with a ~2 s
    oscillation and a mean offset of 1-2 cm (docs/performance/autopilots.md), here wider: a 10 cm orbit of 1.7 s
    about a point 1.5 cm off, the height swinging by 2 cm. The body is never within 8.5 cm of the point, and the
    speed that orbit implies is 0.37 m/s: above the px4 preset's swing gate (0.35 m/s rms)."""
    w = 2.0 * math.pi * t_s / ORBIT_PERIOD_S
    return (CENTRE_M[0] + ORBIT_M * math.cos(w), ORBIT_M * math.sin(w), 0.02 * math.sin(1.3 * w))


class _OrbitingFc(FakeFlightController):
    """The fake autopilot, its reported position orbiting as :func:`_orbit` says while ``orbiting``."""

    orbiting = False

    def telemetry(self) -> Telemetry:
        tel = super().telemetry()
        if not self.orbiting:
            return tel
        dx, dy, dz = _orbit(tel.time_s)
        x, y, z = tel.position_m
        return dataclasses.replace(tel, position_m=(x + dx, y + dy, z + dz))


def _glue_orbiting_in_its_hover(preset: str) -> Rig:
    """Task A0 on the fake autopilot, its position orbiting in the hover over the start (only there)."""
    rig = Rig("adhesion", config=dict(uav_settings(preset)))
    fc = _OrbitingFc(rig.clock, position_m=rig.fc.position_m)
    rig.fc = rig.uav.fc = fc

    def orbit(r: Rig) -> None:
        fc.orbiting = r.uav.state == "hover"

    return rig.run(max_s=300.0, on_tick=orbit)


def test_the_px4_preset_hovers_still_over_a_swinging_start_and_sprays_a0() -> None:
    # the px4 preset's gates read the velocity consistent with the position (0.37 m/s round the orbit): the
    # swing gate would fail the hover 8 s after the leg's end, as it did on PX4 beside a busy loop
    rig = _glue_orbiting_in_its_hover("px4")
    result = rig.link.results[0]
    assert result.status == "done", result
    assert result.coverage >= 0.9
    assert rig.followed("hover", "descend")


def test_the_ticks_gate_never_sees_the_same_hover_still() -> None:
    # the default preset (motion capture: no window) keeps the run of ticks within 3 cm (6 cm after the patience)
    rig = _glue_orbiting_in_its_hover("ideal")
    result = rig.link.results[0]
    assert result.status == "failed" and "could not hover still over the start" in (result.reason or ""), (
        result
    )


def _hovered(still: HoverStill, centre_m: tuple[float, float, float], until_s: float) -> float | None:
    """10 Hz ticks of an orbit about ``centre_m`` (velocity its own); the first time the 3 cm / 0.12 m/s gate
    passes (6 cm / 0.24 m/s after 4 s), or None."""
    for i in range(int(until_s * 10) + 1):
        t = i * 0.1
        w = 2.0 * math.pi * t / 2.0
        error = (centre_m[0] + ORBIT_M * math.cos(w), centre_m[1] + ORBIT_M * math.sin(w), centre_m[2])
        speed = ORBIT_M * 2.0 * math.pi / 2.0
        still.add(t, error, (-speed * math.sin(w), speed * math.cos(w), 0.0))
        scale = 2.0 if t > 4.0 else 1.0
        if still.still(0.03 * scale, 0.12 * scale):
            return t
    return None


def test_the_window_passes_a_hover_centred_on_the_point_and_not_one_centred_off_it() -> None:
    at = _hovered(HoverStill(3.0), (0.005, 0.0, 0.0), 8.0)
    assert at is not None and 3.0 <= at < 8.0  # a window first; before the swing gate's patience
    assert (
        _hovered(HoverStill(3.0), (0.05, 0.0, 0.02), 30.0) is None
    )  # centred 5.4 cm off: the tolerance is 6
    still = HoverStill(3.0)
    _hovered(still, (0.0, 0.0, 0.0), 8.0)
    still.reset()  # a new hover: a window first
    still.add(0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert not still.still(1.0, 1.0)
