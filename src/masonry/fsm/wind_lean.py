"""Whether the brick UAV places in a wind (issue 30): its lean in the pickup's hovers, averaged.

In a wind a multirotor leans into it to hold its place, and the gusts swing the lean about; in calm air it leans
only to accelerate, and the pickup's hovers (the alignment above the brick, the descent onto it) accelerate little.
Measured on the simulated hexacopter (``masonry.sim.vehicle``, ``arducopter``), the tilt averaged as below at the
drop-off's alignment: 0 in calm air, 2-17 degrees in 4 m/s and 2-21 in 2 m/s (light turbulence). The brick UAV averages its tilt (the lean's angle from
the vertical, in whatever direction: turbulence swings the lean about the wind's) over those hovers, each tick,
over ``LEAN_TAU_S``; at its drop-off's alignment a mean tilt over
``UavConfig.wall_in_wind_rad`` says it places in a wind, and it then aligns on the wall's markers
(:mod:`masonry.fsm.wall_align`, as ``align_on_wall`` does, with the side look and the release gate) for that
placement. Why: on the ``arducopter`` preset (motion capture, no wall alignment) the bricks lay 14-16 mm mean,
30-42 mm at worst from their neighbours in 4 m/s wind against 5-6 / 13-19 mm in calm air: the effector lingers
1-4 cm off its drop-off in the gusts and is let go at the edge of r_pl, each brick where its own gust put it;
aligned on the wall, a brick keeps its designed offsets to the bricks it sees (docs/performance/as-built.md). In
calm air nothing changes: the wall alignment's looks and the side look's legs cost seconds a brick.

With ``UavConfig.wind_xy_kp_per_s`` (the ``px4`` preset's 2 /s, over masonry's own velocity loop's 1.5) such a
placement also aligns and descends on that horizontal position gain (:func:`place_gains`), and the UAV flies it on,
the next pickups too, until a placement in calm air: the refitted ``px4`` model (0.25 s of dead time, issue 29) in 4 m/s wind did not hold the
alignment gates' 3 s means with kp 1.5 (no mission of nine completed), and did with kp 2 (all nine); in calm air kp 2
placed a pyramid's first course farther apart, so there it stays 1.5. Its tilt averaged so is 0.05-0.055 rad in calm
air (its airframe's wander), 0.08-0.27 rad in 4 m/s: the ``px4`` preset's ``wall_in_wind_rad`` is 0.07
(docs/performance/as-built.md "The px4 placement on the refitted model").

On the real PX4 (v1.16 SIH, calm air, issues 29/30, branch ``px441``) the hover swings 4-6 cm at a 1.1-1.5 s
period and tilts up to 0.1-0.13 rad either way: its tilt so averaged came to 0.040-0.085 rad, over 0.07 in 4 of 22
placements (each the first pickup), which then flew as in a wind (kp 2, no timed release, no 1 cm rule) and were
let go anywhere within r_pl. A wind leans the UAV one way; a swing leans it both ways. So the lean is averaged as a
direction too (the body's up axis in the world's horizontal plane, over the same :data:`LEAN_TAU_S`), and with
``UavConfig.wind_held_rad`` (the ``px4`` preset's 0.05 rad) a placement is in a wind only where that held lean is
over it as well: the real PX4's calm came to 0.004-0.047 rad held at the judgement (25 placements; the one read
as a wind, 0.071 in magnitude, held 0.047), the px4 model's 4 m/s to 0.028-0.415 (12 of 389 judgements under 0.05,
each of a magnitude of 0.073-0.092, light-wind moments: flown as calm, the three walls' bricks no farther apart;
its calm air 0.0002-0.011, magnitude 0.043-0.065). docs/performance/autopilots.md.
"""

from __future__ import annotations

import dataclasses
import math

from masonry.motion import PIDGains
from masonry.ports import Telemetry

__all__ = ["LEAN_TAU_S", "WindLean", "place_gains"]

#: The time the lean is averaged over (s): turbulence tilts the UAV by as much again for a second or two.
LEAN_TAU_S = 3.0


class WindLean:
    """The tilt (rad, from the vertical) averaged over the ticks given, over :data:`LEAN_TAU_S` (zero at first)."""

    def __init__(self) -> None:
        self.tilt_rad = 0.0
        #: the body's up axis in the world's horizontal plane (x, y; about rad for small tilts), averaged alike
        self.up_xy = (0.0, 0.0)

    @property
    def held_rad(self) -> float:
        """The lean held in one direction (rad): the averaged up axis's length; a swing about the vertical
        averages out of it."""
        return math.hypot(*self.up_xy)

    def follow(self, tel: Telemetry, dt_s: float) -> None:
        """One tick of a hover: the means move toward ``tel``'s tilt (``dt_s`` since the last)."""
        k = min(1.0, dt_s / LEAN_TAU_S)
        roll, pitch, yaw = tel.attitude_rad
        self.tilt_rad += (math.hypot(roll, pitch) - self.tilt_rad) * k
        # the third column of R_world_body (masonry.geometry): the body's z axis in the world
        cr, sr, sp = math.cos(roll), math.sin(roll), math.sin(pitch)
        cy, sy = math.cos(yaw), math.sin(yaw)
        up_x, up_y = cy * sp * cr + sy * sr, sy * sp * cr - cy * sr
        self.up_xy = (self.up_xy[0] + (up_x - self.up_xy[0]) * k, self.up_xy[1] + (up_y - self.up_xy[1]) * k)

    def windy(self, threshold_rad: float, held_rad: float = 0.0) -> bool:
        """The mean tilt is over ``threshold_rad`` (never for a threshold of 0 or less) and, for ``held_rad`` > 0,
        the lean held in one direction (:attr:`held_rad`) is over ``held_rad`` too."""
        return 0.0 < threshold_rad < self.tilt_rad and (held_rad <= 0.0 or held_rad < self.held_rad)


def place_gains(configured: PIDGains | None, wind_xy_kp_per_s: float, in_wind: bool) -> PIDGains:
    """The position gains a placement flies: ``configured`` (None: the defaults) with the horizontal kp
    ``wind_xy_kp_per_s`` in a wind (``in_wind``, and ``wind_xy_kp_per_s`` > 0)."""
    gains = configured if configured is not None else PIDGains()
    if not in_wind or wind_xy_kp_per_s <= 0.0:
        return gains
    return dataclasses.replace(
        gains,
        x=dataclasses.replace(gains.x, kp=wind_xy_kp_per_s),
        y=dataclasses.replace(gains.y, kp=wind_xy_kp_per_s),
    )
