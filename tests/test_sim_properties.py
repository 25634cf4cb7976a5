"""Property tests of the world: whatever the UAVs do, bricks and vehicles stay physically consistent."""

from __future__ import annotations

import math
from collections.abc import Callable

from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint import Blueprint, Brick, UavSpec
from masonry.sim import Faults, SimUav, World
from masonry.sim.bricks import GROUND_Z_M, point_in_rect
from sim_helpers import fly_to

ACTIONS = st.lists(
    st.tuples(
        st.sampled_from(["fly", "magnet_on", "magnet_off", "unlock", "lock", "valve", "land"]),
        st.floats(-1.0, 1.0),
        st.floats(-1.0, 1.0),
        st.floats(-1.0, 1.0),
        st.integers(1, 60),
    ),
    min_size=1,
    max_size=12,
)


def little_wall() -> Blueprint:
    bricks = [Brick(i, (0.3 * i, 0.0, 0.05), placed=True) for i in range(3)]
    bricks += [Brick(3 + i, (0.15 + 0.3 * i, 0.0, 0.15), pickup_m=(0.3 * i, -0.6, 0.05)) for i in range(2)]
    fleet = (UavSpec("brick-1", "brick", (0.3, -0.6, 0.0)), UavSpec("glue-1", "adhesion", (0.3, 0.6, 0.0)))
    return Blueprint(bricks=tuple(bricks), fleet=fleet)


#: What each random action does to a UAV (a, b, c: its three numbers; "fly" is also re-sent at every step).
APPLY_ACTION: dict[str, Callable[[SimUav, float, float, float], object]] = {
    "fly": lambda u, a, b, c: u.fc.send_velocity((a, b, c), 0.0),
    "magnet_on": lambda u, a, b, c: u.gripper.set_magnet(True),
    "magnet_off": lambda u, a, b, c: u.gripper.set_magnet(False),
    "unlock": lambda u, a, b, c: u.gripper.set_joint_locked(False),
    "lock": lambda u, a, b, c: u.gripper.set_joint_locked(True),
    "valve": lambda u, a, b, c: u.sprayer.set_valve(a > 0),
    "land": lambda u, a, b, c: u.fc.land(),
}


@settings(max_examples=25)
@given(
    ACTIONS,
    st.integers(0, 50),
    st.sampled_from([0.0, 0.0, 0.5]),
    st.tuples(st.floats(-0.3, 0.9), st.floats(-0.2, 0.2)),
)
def test_bricks_rest_on_something_and_vehicles_stay_above_ground(
    actions: list[tuple[str, float, float, float, int]],
    seed: int,
    grasp: float,
    over: tuple[float, float],
) -> None:
    w = World(little_wall(), seed=seed, faults=Faults(grasp_failure=grasp))
    uavs = w.add_fleet()
    for u in uavs:
        u.fc.arm()
        u.fc.takeoff(0.8)
    w.run(4.0)
    # Start with a brick on the magnet (most of the time): the random actions then carry and drop it.
    brick_uav = uavs[0]
    x, y, top = w.bricks[3].top_center_m
    brick_uav.gripper.set_joint_locked(False)
    brick_uav.gripper.set_magnet(True)
    fly_to(w, brick_uav, (x, y, 1.0), tol_m=0.01, timeout_s=20.0)
    fly_to(w, brick_uav, (x, y, top + 0.44), tol_m=0.012, timeout_s=20.0, max_speed_mps=0.3)
    fly_to(w, brick_uav, (x, y, 1.0), tol_m=0.05, timeout_s=20.0)
    if grasp == 0.0:
        assert brick_uav.gripper.is_attached()
    fly_to(w, brick_uav, (over[0], over[1], 0.8), tol_m=0.02, timeout_s=20.0)  # somewhere over the wall
    for kind, a, b, c, steps in actions:
        for u in uavs:
            APPLY_ACTION[kind](u, a, b, c)
        for _ in range(steps):
            if kind == "fly":
                for u in uavs:
                    u.fc.send_velocity((a, b, c), 0.0)
            w.step(0.05)
            for u in uavs:
                assert u.position_m[2] >= GROUND_Z_M
                assert all(math.isfinite(x) for x in u.position_m)
    assert_bricks_rest_on_something(w, uavs)


def assert_bricks_rest_on_something(w: World, uavs: list[SimUav]) -> None:
    """Every brick is carried, on the ground or on a brick; carried ones hang under their UAV's magnet."""
    carried = {u.carried_brick for u in uavs} - {None}
    for brick in w.bricks.values():
        assert (brick.state == "carried") == (brick.id in carried)
        if brick.state == "carried":
            continue
        bottom = brick.bottom_z_m
        if abs(bottom - GROUND_Z_M) < 1e-9:
            continue
        # Resting on a brick: some brick below has its top at this bottom and lies under the footprint.
        below = [
            o
            for o in w.bricks.values()
            if o is not brick and o.state != "carried" and abs(o.top_z_m - bottom) < 1e-9
        ]
        assert below, f"brick {brick.id} floats at {bottom:.3f} m"
    for brick_id, err in w.placement_errors().items():
        assert math.isfinite(err) and w.bricks[brick_id].released
    for u in uavs:
        if u.carried_brick is not None:
            ex, ey, ez = u.effector_m()
            b = w.bricks[u.carried_brick]
            assert math.isclose(b.top_z_m, ez, abs_tol=1e-9)
            assert point_in_rect(ex, ey, *b.rect())
