"""Spare bricks in the simulated world: laid out at their pickups, and measured where they stand in for a brick.

A spare is a :class:`~masonry.sim.bricks.SimBrick` with its own id (the camera sees its markers, 2k and 2k+1),
scattered around its pickup as the wall's bricks are, from a random stream of its own (a blueprint's bricks lie
where they did without spares). Its "design" pose is its pickup: which brick it replaces is mission control's
choice (:mod:`masonry.mission.spares`), so its placement error is measured against that brick's design
(:meth:`masonry.mission.measured.MeasuredJournal.error_m`).
"""

from __future__ import annotations

import math

import numpy as np

from masonry.blueprint import Blueprint, Brick
from masonry.sim.bricks import BrickField, SimBrick

#: The random stream of the spares' scatter (the bricks' is 0).
SPARES_STREAM = 3


def lay_out_spares(
    field: BrickField, blueprint: Blueprint, seed: int, offset_m: float, yaw_spread_rad: float
) -> None:
    """Put each spare of ``blueprint`` at its pickup, within ``offset_m`` of it, its yaw within the spread."""
    spares = blueprint.spares or ()
    if not spares:
        return
    rng = np.random.default_rng([seed, SPARES_STREAM])
    radius = offset_m * np.sqrt(rng.random(len(spares)))
    angle = rng.uniform(-math.pi, math.pi, len(spares))
    yaw = rng.uniform(-yaw_spread_rad, yaw_spread_rad, len(spares))
    for i, s in enumerate(spares):
        x = s.pickup_m[0] + float(radius[i] * math.cos(angle[i]))
        y = s.pickup_m[1] + float(radius[i] * math.sin(angle[i]))
        design = Brick(s.id, s.pickup_m, s.size_m, pickup_m=s.pickup_m)
        brick = SimBrick(s.id, design, (x, y, 0.0), float(yaw[i]), "carried")
        support = field.support_under(brick.rect())
        brick.position_m = (x, y, support + s.size_m[2] / 2.0)
        brick.state = "pickup"
        field.add(brick)


__all__ = ["SPARES_STREAM", "lay_out_spares"]
