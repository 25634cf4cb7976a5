"""Hierarchical state machines for the brick and adhesion UAVs (paper, Sections IV and V), on ports only.

The machines are data (:mod:`masonry.fsm.states`), built with ``transitions``' HierarchicalMachine; the models
(:class:`BrickUav`, :class:`AdhesionUav`) hold the callbacks and talk only to :mod:`masonry.ports`. Step one
by hand in a notebook::

    from masonry.fakes import FakeClock, FakeFlightController, FakeSprayer, QueueMissionLink
    from masonry.fsm import AdhesionUav, UavConfig
    from masonry.planner.tasks import AdhesionTask

    clock = FakeClock()
    link = QueueMissionLink([AdhesionTask("A0", 0, 1, (1, 0, 0.2), (1.3, 0, 0.2), 0.3)])
    uav = AdhesionUav(UavConfig("glue-1", "adhesion", (0, 0, 0)), FakeFlightController(clock),
                      FakeSprayer(clock), link, clock)
    while not (link.results and uav.finished):
        uav.step(clock.now_s()); clock.advance(0.05)
    uav.trace
"""

from __future__ import annotations

from masonry.fsm.adhesion import AdhesionUav
from masonry.fsm.brick import BrickUav
from masonry.fsm.config import UavConfig, blueprint_settings
from masonry.fsm.model import UavModel
from masonry.fsm.runner import SingleTaskRun, build_uav, fly_task, run_single_task
from masonry.fsm.states import MACHINES, leaf_states
from masonry.fsm.watchdogs import Abort, Watchdog

__all__ = [
    "MACHINES",
    "Abort",
    "AdhesionUav",
    "BrickUav",
    "SingleTaskRun",
    "UavConfig",
    "UavModel",
    "Watchdog",
    "blueprint_settings",
    "build_uav",
    "fly_task",
    "leaf_states",
    "run_single_task",
]
