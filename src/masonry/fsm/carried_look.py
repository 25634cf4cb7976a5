"""The carried brick's offset on the magnet, seen by the camera (issue 30): the drop-off is the brick's, not the rod's.

The conical guide centres a picked brick only so far: up to 6 mm of the pickup's offset remains (a fifth of it;
the simulator's ``guide_residual``), in the body frame, and the effector released on its target puts the brick
that much off it. On the px4 towers (``benchmarks/bench_as_built_release.py``) this *carry* part was 5.5-6.1 mm
rms, 9.9 mm at worst, of the bricks' offsets from their supports, beside the release's 10-11 mm and the target's
5-8 mm. The carried brick's own markers (its top face, under the camera beside the rod) are in the frames the
wall alignment reads anyway: each frame that shows one gives the brick's top-face centre and the effector from the
same telemetry, so their difference holds no position error (the GNSS wander cancels, as in
:mod:`masonry.fsm.wall_align`). Its mean over the frames of the placement (horizontal, in the body frame: the brick
turns with the heading) is taken off the drop-off's target, so that the brick's centre, not the effector, lands
on it. Only with the wall alignment (:attr:`~masonry.fsm.brick.BrickUav.on_wall`), where the frames are read.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from masonry.fsm.as_built import world_estimate

if TYPE_CHECKING:
    from masonry.fsm.brick import BrickUav
    from masonry.perception.types import TagPose
    from masonry.ports import Telemetry

__all__ = ["MAX_CARRY_M", "CarriedLook"]

#: An offset seen farther than this (m) from the effector is not the carried brick's (the guide allows 3 cm, its
#: residual a fifth of that): not counted.
MAX_CARRY_M = 0.03


class CarriedLook:
    """The mean horizontal offset (body frame, m) of the carried brick's top-face centre from the effector."""

    def __init__(self) -> None:
        self._sum = np.zeros(2)
        self.frames = 0

    def reset(self) -> None:
        """A new placement (the brick on the magnet may be another)."""
        self._sum = np.zeros(2)
        self.frames = 0

    def add(self, uav: BrickUav, tags: Sequence[TagPose], tel: Telemetry) -> None:
        """One frame's tags: the carried brick's offset from the effector joins the mean, if its markers are seen."""
        est = world_estimate(tags, uav.brick_task.brick, tel, uav._T_body_cam, uav._est_config)
        if est is None:
            return
        d = np.asarray(est[0], dtype=float)[:2] - np.asarray(uav.effector.position(tel), dtype=float)[:2]
        if float(np.hypot(*d)) > MAX_CARRY_M:
            return
        yaw = tel.attitude_rad[2]
        c, s = math.cos(yaw), math.sin(yaw)
        self._sum += np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])
        self.frames += 1

    def world_m(self, yaw_rad: float) -> np.ndarray:
        """The mean offset turned to the heading ``yaw_rad`` (world, m, z 0); zero before a frame showed it."""
        if self.frames == 0:
            return np.zeros(3)
        bx, by = self._sum / self.frames
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        return np.array([c * bx - s * by, s * bx + c * by, 0.0])
