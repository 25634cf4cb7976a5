"""Where a released brick comes to rest, and a release timed inside a physics step (``Gripper.release_at``).

A brick let go falls onto what is under it and settles ``WorldConfig.release_scatter_m`` (plus
``release_scatter_per_m`` per metre of fall) from where it was let go.

The brick UAV's control tick is 0.1 s and the world's physics step 0.05 s; on the ``px4`` model the side look's
last leg crosses the 1.5 cm disc about the drop-off at 0.2-0.4 m/s, 2-4 cm a tick, so a release at a tick lets go
anywhere in the disc (docs/performance/as-built.md, branch ``release35``). A release due at a time inside a step
lets go of the brick where it was then: its pose interpolated between its poses at the step's two ends (the
vehicle's path is smooth over 0.05 s: its velocity follows a 0.15 s lag).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from masonry.ports import Vec3
    from masonry.sim.bricks import BrickField
    from masonry.sim.world import SimUav, World

__all__ = ["Pose", "interpolated_pose", "release_brick", "release_start", "release_within"]

Pose = tuple["Vec3", float]


def release_start(uav: SimUav, field: BrickField, end_s: float) -> Pose | None:
    """The carried brick's pose (position m, yaw rad) at the start of a step ending at ``end_s`` in which its timed
    release falls due; None when none does (no release due by then, or no brick carried)."""
    due_s, brick_id = uav.release_due_s, uav.carried_brick
    if due_s is None or due_s > end_s or brick_id is None:
        return None
    brick = field.bricks[brick_id]
    return brick.position_m, brick.yaw_rad


def interpolated_pose(start: Pose, end: Pose, fraction: float) -> Pose:
    """The pose ``fraction`` of the way from ``start`` to ``end`` (clamped to [0, 1]; yaw the short way round)."""
    f = min(1.0, max(0.0, fraction))
    (x0, y0, z0), yaw0 = start
    (x1, y1, z1), yaw1 = end
    yaw = math.remainder(yaw0 + f * math.remainder(yaw1 - yaw0, 2.0 * math.pi), 2.0 * math.pi)
    return (x0 + f * (x1 - x0), y0 + f * (y1 - y0), z0 + f * (z1 - z0)), yaw


def release_brick(world: World, uav: SimUav, pose: Pose | None = None, at_s: float | None = None) -> None:
    """``uav`` lets go of the brick it carries (if any): from ``pose`` (position m, yaw rad; None: where it hangs
    now) at ``at_s`` (None: now), onto what is under it."""
    brick_id = uav.carried_brick
    if brick_id is None:
        return
    field = world.field
    brick = field.bricks[brick_id]
    if pose is None:
        world._carry_pose(uav, brick)
    else:
        brick.position_m, brick.yaw_rad = pose
    cfg = world.config
    fall_m = brick.bottom_z_m - field.support_under(
        brick.rect(cfg.support_margin_m), below_z_m=brick.bottom_z_m
    )
    sigma = cfg.release_scatter_m + cfg.release_scatter_per_m * max(0.0, fall_m)
    dx, dy, dyaw = uav.rng.standard_normal(3).tolist()
    x, y, z = brick.position_m
    brick.position_m = (x + sigma * dx, y + sigma * dy, z)
    brick.yaw_rad = math.remainder(brick.yaw_rad + cfg.release_yaw_scatter_rad * dyaw, 2.0 * math.pi)
    field.drop(brick_id, cfg.support_margin_m)
    uav.carried_brick = None
    when_s = world.clock.now_s() if at_s is None else at_s
    world.releases.append((when_s, uav.name, brick_id))
    world.glue.placed(brick_id, brick.position_m, when_s)


def release_within(world: World, uav: SimUav, start: Pose, t0_s: float, t1_s: float) -> None:
    """The timed release due in the step from ``t0_s`` to ``t1_s``: the brick let go where it was at the time due
    (``start``: its pose at the step's start; its pose now is the step's end)."""
    due_s = uav.release_due_s
    uav.release_due_s, uav.magnet_on, uav._attempt = None, False, None
    if uav.carried_brick is None or due_s is None:
        return  # (let go already: the UAV failed in the step)
    brick = world.field.bricks[uav.carried_brick]
    pose = interpolated_pose(start, (brick.position_m, brick.yaw_rad), (due_s - t0_s) / (t1_s - t0_s))
    release_brick(world, uav, pose, due_s)
