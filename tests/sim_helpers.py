"""Small closed-loop helpers for the simulator tests: a P position controller on telemetry, stepping the world."""

from __future__ import annotations

import math

from masonry.sim import SimUav, World

DT_S = 0.05


def fly_to(
    world: World,
    uav: SimUav,
    target_m: tuple[float, float, float],
    *,
    tol_m: float = 0.01,
    timeout_s: float = 60.0,
    gain: float = 1.2,
    max_speed_mps: float = 1.0,
    target_yaw_rad: float | None = None,
) -> bool:
    """Fly the UAV's body to ``target_m`` with a P controller on its (noisy) telemetry; True once within tol."""
    end = world.clock.now_s() + timeout_s
    while world.clock.now_s() < end:
        tel = uav.fc.telemetry()
        err = [t - p for t, p in zip(target_m, tel.position_m)]
        dist = math.sqrt(sum(e * e for e in err))
        yaw_err = (
            0.0 if target_yaw_rad is None else math.remainder(target_yaw_rad - tel.attitude_rad[2], math.tau)
        )
        if dist < tol_m and abs(yaw_err) < 0.02:
            return True
        v = [gain * e for e in err]
        speed = math.sqrt(sum(c * c for c in v))
        if speed > max_speed_mps:
            v = [c * max_speed_mps / speed for c in v]
        uav.fc.send_velocity((v[0], v[1], v[2]), 1.5 * yaw_err)
        world.step(DT_S)
    return False


def take_off(world: World, uav: SimUav, altitude_m: float = 1.2, timeout_s: float = 20.0) -> None:
    uav.fc.arm()
    uav.fc.takeoff(altitude_m)
    end = world.clock.now_s() + timeout_s
    while world.clock.now_s() < end and (uav.vehicle.taking_off or uav.vehicle.on_ground):
        world.step(DT_S)
    assert not uav.vehicle.on_ground and not uav.vehicle.taking_off


def hover(world: World, uav: SimUav, duration_s: float) -> None:
    for _ in range(round(duration_s / DT_S)):
        uav.fc.send_velocity((0.0, 0.0, 0.0), 0.0)
        world.step(DT_S)
