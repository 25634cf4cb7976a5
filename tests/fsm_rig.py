"""Test rig: a UAV model wired to scripted fakes (shared by the state-machine tests)."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from masonry.adapters.mavlink import MavlinkFlightController
from masonry.adapters.sitl import MavlinkSitl, SitlConfig, free_udp_port
from masonry.blueprint import Blueprint
from masonry.fakes import (
    FakeBrick,
    FakeCamera,
    FakeClock,
    FakeFlightController,
    FakeGripper,
    FakeSprayer,
    QueueMissionLink,
    ScriptedClearanceLink,
)
from masonry.fsm import AdhesionUav, BrickUav, UavConfig, build_uav
from masonry.fsm.model import UavModel
from masonry.planner.tasks import AdhesionTask, BrickTask, Task
from masonry.sim import World
from masonry.sim.world import SimUav

HOME = (0.0, -2.0, 0.0)
PICKUP = (3.0, 1.0, 0.05)
BRICK_ID = 7


def brick_task(
    task_id: str = "B7", brick: int = BRICK_ID, position=(0.0, 0.5, 0.25), yaw_rad: float = 0.0, pickup=PICKUP
) -> BrickTask:
    return BrickTask(task_id, brick, False, position, yaw_rad, pickup, (0.30, 0.15, 0.10))


def adhesion_task(task_id: str = "A0", start=(-0.15, 0.5, 0.2), end=(0.15, 0.5, 0.2)) -> AdhesionTask:
    return AdhesionTask(task_id, 3, 7, start, end, math.dist(start, end))


class Rig:
    """One UAV on fakes. Brick UAV: a brick lies near ``PICKUP`` (offset, yaw) where the fake camera sees it."""

    def __init__(
        self,
        kind: str = "brick",
        *,
        tasks: list[Any] | None = None,
        brick_offset_m: tuple[float, float] = (0.03, -0.02),
        brick_yaw_rad: float = 0.6,
        camera: dict[str, Any] | None = None,
        gripper: dict[str, Any] | None = None,
        fc: dict[str, Any] | None = None,
        config: dict[str, Any] | None = None,
        clearance: dict[str, Any] | None = None,
    ) -> None:
        self.clock = FakeClock()
        self.fc = FakeFlightController(self.clock, position_m=HOME, **(fc or {}))
        queued = tasks if tasks is not None else [brick_task() if kind == "brick" else adhesion_task()]
        # clearance: the link is a ScriptedClearanceLink (mission control's airspace) with these settings
        self.link: Any = (
            QueueMissionLink(queued)
            if clearance is None
            else ScriptedClearanceLink(queued, self.clock, **clearance)
        )
        airspace = None if clearance is None else self.link
        cfg = UavConfig(f"{kind}-1", kind, HOME, **(config or {}))  # type: ignore[arg-type]
        self.config = cfg
        if kind == "brick":
            top = (PICKUP[0] + brick_offset_m[0], PICKUP[1] + brick_offset_m[1], PICKUP[2] + 0.05)
            self.brick = FakeBrick(BRICK_ID, top, brick_yaw_rad)
            cam_kwargs = {"noise_sigma_m": 0.002, "seed": 1}
            cam_kwargs.update(camera or {})
            self.camera = FakeCamera(self.fc, [self.brick], markers=cfg.markers, **cam_kwargs)
            self.gripper = FakeGripper(contact=self._touching, clock=self.clock, **(gripper or {}))
            self.uav: Any = BrickUav(
                cfg, self.fc, self.gripper, self.camera, self.link, self.clock, clearance=airspace
            )
        else:
            self.sprayer = FakeSprayer(self.clock)
            self.uav = AdhesionUav(cfg, self.fc, self.sprayer, self.link, self.clock, clearance=airspace)

    def effector_m(self) -> tuple[float, float, float]:
        x, y, z = self.fc.position_m
        yaw = self.fc.yaw_rad
        ox, oy, oz = self.config.airframe.effector_offset_m
        return (
            x + math.cos(yaw) * ox - math.sin(yaw) * oy,
            y + math.sin(yaw) * ox + math.cos(yaw) * oy,
            z + oz,
        )

    def _touching(self) -> bool:
        ex, ey, ez = self.effector_m()
        tx, ty, tz = self.brick.top_center_m
        return math.hypot(ex - tx, ey - ty) <= 0.03 and abs(ez - tz) <= 0.015

    def run(
        self,
        max_s: float = 400.0,
        dt_s: float = 0.05,
        on_tick: Callable[[Rig], None] | None = None,
        results: int = 1,
    ) -> Rig:
        """Tick until ``results`` results are in and the UAV is at rest (or ``max_s`` passes)."""
        while self.clock.now_s() < max_s:
            self.uav.step(self.clock.now_s())
            if on_tick is not None:
                on_tick(self)
            if len(self.link.results) >= results and self.uav.finished:
                break
            self.clock.advance(dt_s)
        return self

    @property
    def states(self) -> list[str]:
        return [s for _, s in self.uav.trace]

    def visited(self) -> set[str]:
        return set(self.states)

    def followed(self, a: str, b: str) -> bool:
        """State ``b`` was entered right after ``a`` somewhere in the trace."""
        s = self.states
        return any(s[i] == a and s[i + 1] == b for i in range(len(s) - 1))


@contextmanager
def glue_on_px4_sitl() -> Iterator[
    tuple[MavlinkSitl, MavlinkFlightController, AdhesionUav, QueueMissionLink]
]:
    """An adhesion UAV with task A0 flying the project's SITL as PX4 over real MAVLink (x10 time); closed after."""
    port = free_udp_port()
    sitl = MavlinkSitl(
        port, time_scale=10.0, home_m=HOME, config=SitlConfig(autopilot="px4", heartbeat_hz=10.0)
    )
    fc = MavlinkFlightController(f"udpin:127.0.0.1:{port}", connect_timeout_s=5.0)
    sitl.start()
    try:
        fc.connect()
        link = QueueMissionLink([adhesion_task()])
        yield (
            sitl,
            fc,
            AdhesionUav(UavConfig("glue-1", "adhesion", HOME), fc, FakeSprayer(fc.clock), link, fc.clock),
            link,
        )
    finally:
        fc.close()
        sitl.stop()


def sim_machine(bp: Blueprint, world: World, sim_uav: SimUav, task: Task) -> UavModel:
    """The state machine of ``sim_uav`` (of ``world``) with ``task`` queued on its link."""
    spec = sim_uav.spec
    return build_uav(
        UavConfig.from_spec(spec, markers=bp.markers),
        fc=sim_uav.fc,
        link=QueueMissionLink([task]),
        clock=world.clock,
        gripper=sim_uav.gripper,
        camera=sim_uav.camera,
        sprayer=sim_uav.sprayer,
    )
