"""Per-tick cost of the UAV state machines (``step``) in the simulated world, and a whole single-task flight.

Prints: microseconds per ``step`` by machine state group, world step cost for comparison, and the real-time
factor of ``masonry fly``-style runs. Run: ``python benchmarks/bench_fsm.py``.
"""

from __future__ import annotations

import time
from collections import defaultdict
from pathlib import Path

from masonry.blueprint import load_blueprint
from masonry.fakes import QueueMissionLink
from masonry.fsm import UavConfig, build_uav
from masonry.planner import plan
from masonry.sim import World

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


def profile(task_id: str, seed: int = 0, camera: str = "geometric") -> None:
    bp = load_blueprint(CASE_STUDY)
    task = plan(bp).task(task_id)
    world = World(bp, seed=seed, camera=camera)  # type: ignore[arg-type]
    spec = next(u for u in bp.fleet if u.role == task.kind)
    su = world.add_uav(spec)
    link = QueueMissionLink([task])
    uav = build_uav(
        UavConfig.from_spec(spec, markers=bp.markers),
        fc=su.fc,
        link=link,
        clock=world.clock,
        gripper=su.gripper,
        camera=su.camera,
        sprayer=su.sprayer,
    )
    per_state: dict[str, list[float]] = defaultdict(lambda: [0.0, 0])
    world_s = 0.0
    ticks = 0
    t_wall = time.perf_counter()
    while not (link.results and uav.finished) and world.clock.now_s() < 400:
        state = uav.state
        t0 = time.perf_counter()
        uav.step(world.clock.now_s())
        t1 = time.perf_counter()
        world.step(0.05)
        world_s += time.perf_counter() - t1
        acc = per_state[state.split("_")[0] if state.startswith(("pickup_estimate",)) is False else state]
        acc[0] += t1 - t0
        acc[1] += 1
        ticks += 1
    wall = time.perf_counter() - t_wall
    sim_s = world.clock.now_s()
    total_step = sum(v[0] for v in per_state.values())
    print(
        f"{task_id} ({camera}): {ticks} ticks, {sim_s:.1f} s simulated in {wall:.3f} s wall "
        f"(real-time factor {sim_s / wall:.0f}x)"
    )
    print(
        f"  uav.step mean {1e6 * total_step / ticks:.1f} us/tick, world.step mean {1e6 * world_s / ticks:.1f} us/tick"
    )
    for state, (secs, n) in sorted(per_state.items(), key=lambda kv: -kv[1][0] / kv[1][1]):
        print(f"    {state:18s} {1e6 * secs / n:8.1f} us/tick over {n} ticks")


def steady_flight(n: int = 2000) -> None:
    """Cost of one control step in flight (a long transport leg on fakes): the machine's own cost + PID."""
    from masonry.fakes import FakeBrick, FakeCamera, FakeClock, FakeFlightController, FakeGripper
    from masonry.fsm import BrickUav
    from masonry.planner.tasks import BrickTask

    clock = FakeClock()
    fc = FakeFlightController(clock, velocity_time_constant_s=0.0)
    task = BrickTask("B0", 0, False, (500.0, 0.0, 0.05), 0.0, (0.0, 0.0, 0.05))
    link = QueueMissionLink([task])
    uav = BrickUav(
        UavConfig("b", "brick", (0.0, 0.0, 0.0)),
        fc,
        FakeGripper(),
        FakeCamera(fc, [FakeBrick(0, (0, 0, 0.1))]),
        link,
        clock,
    )
    while uav.state != "transport":
        uav.step(clock.now_s())
        clock.advance(0.1)
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        for _ in range(n):
            uav.step(clock.now_s())
            clock.advance(0.1)
        best = min(best, (time.perf_counter() - t0) / n)
    assert uav.state == "transport"
    print(f"steady flight: {1e6 * best:.1f} us per control step (fake flight controller, best of 3 x {n})")
    from masonry import motion

    pid = motion.PID()
    t0 = time.perf_counter()
    for i in range(n):
        pid.step(
            i * 0.1,
            (0.0, 0.0, 1.0),
            (0.1, 0.0, 1.0),
            velocity_ff_mps=(0.0, 0.0, 0.0),
            yaw_rad=0.0,
            target_yaw_rad=0.0,
        )
    print(f"  of which PID.step: {1e6 * (time.perf_counter() - t0) / n:.1f} us")


if __name__ == "__main__":
    profile("B0")
    profile("A0")
    profile("B0", camera="render")
    steady_flight()
