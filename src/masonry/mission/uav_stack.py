"""One simulated UAV's stack beside the world: its state machine (a component), its ground crew and its readings.

:class:`masonry.mission.simulate.SimulatedMission` gives each UAV of the fleet a handler (its end of the mission
link) and a state machine that flies its ports. The machine comes from a :class:`UavMachineFactory` (default:
:func:`build_machine`, the brick or adhesion machine of :mod:`masonry.fsm`), so another machine can be flown in
the same simulation. The dispatcher's critical-path priority (:func:`priority_durations_s`) is here too: the
builder gives it to mission control.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Protocol

from masonry.errors import MasonryError
from masonry.fsm.config import UavConfig, blueprint_settings
from masonry.fsm.tuning import uav_settings

if TYPE_CHECKING:
    from masonry.blueprint import Blueprint, UavSpec
    from masonry.mission.handler import UavHandler
    from masonry.ports import Clock, UavPorts
    from masonry.sim import SimUav, SimVehicle

__all__ = [
    "BATTERY_SWAP_S",
    "PRIORITY_QUANTUM_S",
    "GroundCrew",
    "UavMachineFactory",
    "build_machine",
    "priority_durations_s",
    "template_config",
]

#: How long the ground crew takes to swap a landed UAV's battery (the handler keeps a reserve, see UavHandler).
BATTERY_SWAP_S = 60.0

#: The ground crew asked again after longer than this (s) starts its swap afresh (the UAV flew meanwhile).
SWAP_GAP_S = 1.0

#: Expected durations are rounded to this for the critical-path priority (see :func:`priority_durations_s`).
PRIORITY_QUANTUM_S = 5.0


def priority_durations_s(
    durations_s: Mapping[str, float], quantum_s: float = PRIORITY_QUANTUM_S
) -> dict[str, float]:
    """Expected durations rounded to ``quantum_s`` for the dispatcher's critical-path priority.

    The estimates are a model, good to several seconds; comparing chains that differ by less than that
    would let noise (a home a metre further away) decide, where the tie-break by flight distance is the
    better rule. In the paper's case study this is what makes A0, the adhesion task nearest the adhesion
    UAV, go first.
    """
    return {k: max(quantum_s, round(v / quantum_s) * quantum_s) for k, v in durations_s.items()}


def position_of(ports: UavPorts) -> Callable[[], tuple[float, float, float]]:
    """The UAV's position as its flight controller reports it (what its handler tells mission control)."""
    fc = ports.fc
    return lambda: fc.telemetry().position_m


def battery_of(vehicle: SimVehicle) -> Callable[[], float]:
    """The simulated vehicle's battery fraction (what its handler reports)."""
    return lambda: float(vehicle.battery_fraction)


class GroundCrew:
    """Swaps a landed, disarmed UAV's battery, taking ``BATTERY_SWAP_S``; True once the fresh pack is in.

    Given the simulated ``uav``, it also takes a brick off a landed UAV's magnet and lays it back where it was
    picked up (:meth:`return_brick`; docs/state-machines.md, "Putting a brick back").
    """

    def __init__(self, vehicle: SimVehicle, clock: Clock, uav: SimUav | None = None) -> None:
        self.vehicle = vehicle
        self.clock = clock
        self.uav = uav
        self._since_s: float | None = None
        self._last_s: float | None = None  # the last call (a swap is one unbroken run of calls)

    def return_brick(self, brick_id: int) -> bool:
        """Take brick ``brick_id`` off the landed UAV's magnet and back to its pickup; True once it is there."""
        uav = self.uav
        if uav is None or uav.carried_brick != brick_id or not self.vehicle.on_ground:
            return False
        uav.world.field.return_to_pickup(brick_id)
        uav.carried_brick = None
        return True

    def __call__(self) -> bool:
        v = self.vehicle
        if not (v.on_ground and not v.armed):
            self._since_s = None
            return False
        now = self.clock.now_s()
        if self._since_s is None or self._last_s is None or now - self._last_s > SWAP_GAP_S:
            # a swap left off (the UAV took a task the battery covered, see UavHandler.top_up_fraction) starts afresh
            self._since_s = now
        self._last_s = now
        if now - self._since_s < BATTERY_SWAP_S:
            return False
        try:
            v.swap_battery()
        except MasonryError:
            return False
        self._since_s = None
        return True


class UavMachineFactory(Protocol):
    """Builds the state machine one UAV flies with (``handler.attach`` gets it; it talks to ``handler`` as its
    mission link and clearance, and flies ``ports``).

    Args:
        spec: the UAV (name, role, home).
        ports: its ports (flight controller, gripper, sprayer, camera).
        blueprint: the wall (cruise altitude, markers, site fence).
        handler: its handler.
        clock: the mission's clock.
        lateral_altitude_m: the altitude of its lateral legs (its transit layer; None: the work altitude).
        template: the tuning every UAV flies with (None: ``UavConfig``'s defaults).
    """

    def __call__(
        self,
        spec: UavSpec,
        ports: UavPorts,
        blueprint: Blueprint,
        handler: UavHandler,
        clock: Clock,
        lateral_altitude_m: float | None,
        template: UavConfig | None,
    ) -> object: ...


def build_machine(
    spec: UavSpec,
    ports: UavPorts,
    blueprint: Blueprint,
    handler: UavHandler,
    clock: Clock,
    lateral_altitude_m: float | None = None,
    template: UavConfig | None = None,
) -> object:
    """The default machine: :class:`masonry.fsm.BrickUav` or :class:`~masonry.fsm.AdhesionUav` by role."""
    from masonry.fsm import AdhesionUav, BrickUav, UavConfig

    # the template's tuning (default: UavConfig's), with this UAV's identity, home, layer and the blueprint's
    base = template if template is not None else UavConfig(spec.name, spec.role, spec.home_m)
    config = dataclasses.replace(
        base,
        name=spec.name,
        role=spec.role,
        home_m=spec.home_m,
        **blueprint_settings(blueprint, spec),
        lateral_altitude_m=lateral_altitude_m,
        battery_swap_s=BATTERY_SWAP_S,
    )
    if spec.role == "brick":
        return BrickUav(config, ports.fc, ports.gripper, ports.camera, handler, clock, clearance=handler)
    return AdhesionUav(config, ports.fc, ports.sprayer, handler, clock, clearance=handler)


def template_config(uav_config: UavConfig | None, vehicle: str, airspace: str) -> UavConfig | None:
    """Every UAV's tuning: the one given, else a real autopilot's control preset (:mod:`masonry.fsm.tuning`),
    else None (``UavConfig``'s defaults); with the ``table`` airspace, no hold patience (a UAV waits on its
    stay, never given up for waiting)."""
    if (uav_config is not None or vehicle == "ideal") and airspace != "table":
        return uav_config
    if uav_config is None:
        tuning = uav_settings(vehicle) if vehicle != "ideal" else {}
        uav_config = UavConfig("template", "brick", (0.0, 0.0, 0.0), **tuning)
    return uav_config if airspace != "table" else dataclasses.replace(uav_config, hold_patience_s=None)
