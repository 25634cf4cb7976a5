"""The world's vehicle model as a component: how each simulated UAV's vehicle is built.

A :class:`masonry.sim.World` builds every UAV's vehicle by calling its ``vehicle_model`` (default:
:func:`sim_vehicle`, a :class:`~masonry.sim.vehicle.SimVehicle` with the world's preset). Another model is a
callable of the same shape that returns a ``SimVehicle`` subclass with other dynamics (its ``step``, its
``command_velocity``) or other parameters; ``simulate(..., vehicle_model=...)`` hands it to the world.
docs/architecture.md shows one, and ``benchmarks/bench_vehicle_model.py`` flies a mission with it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

from masonry.sim.vehicle import SimVehicle

if TYPE_CHECKING:
    import numpy as np

    from masonry.blueprint import UavSpec
    from masonry.ports import Vec3
    from masonry.sim.vehicle_config import VehicleConfig
    from masonry.sim.wind import WindField

__all__ = ["VehicleModel", "sim_vehicle"]


class VehicleModel(Protocol):
    """Builds the vehicle of one UAV of the world (it starts landed and disarmed at ``position_m``).

    Args:
        spec: the UAV (name, role, home): a model may differ per role or per UAV.
        config: the world's vehicle parameters (the ``vehicle`` preset of the simulation).
        position_m, yaw_rad: where it stands and its heading.
        rng: its own random stream (noise, turbulence), derived from the world's seed and its name.
        wind: the wind it flies in (None: still air).
        battery_drain_per_s: the battery's drain in flight (the faults' override, or None: the config's).
        start_s: the world's clock now.
    """

    def __call__(
        self,
        spec: UavSpec,
        config: VehicleConfig,
        *,
        position_m: Vec3,
        yaw_rad: float,
        rng: np.random.Generator,
        wind: WindField | None,
        battery_drain_per_s: float | None,
        start_s: float,
    ) -> SimVehicle: ...


def sim_vehicle(
    spec: UavSpec,
    config: VehicleConfig,
    *,
    position_m: Vec3,
    yaw_rad: float,
    rng: np.random.Generator,
    wind: WindField | None,
    battery_drain_per_s: float | None,
    start_s: float,
) -> SimVehicle:
    """The default vehicle model: a :class:`~masonry.sim.vehicle.SimVehicle` with ``config`` (every UAV alike)."""
    return SimVehicle(
        config,
        position_m=position_m,
        yaw_rad=yaw_rad,
        rng=rng,
        wind=wind,
        battery_drain_per_s=battery_drain_per_s,
        start_s=start_s,
    )
