"""A mission flown by a custom vehicle model beside the default one (simulate's ``vehicle_model``); prints both.

Usage: python benchmarks/bench_vehicle_model.py (docs/architecture.md, "Swapping the vehicle model")."""

from masonry import SimOptions, SimVehicle, simulate
from masonry.blueprint_gen import running_bond
from masonry.sim import sim_vehicle


class Sluggish(SimVehicle):
    """An autopilot whose velocity loop reaches only 70 % of each setpoint (a mis-tuned gain)."""

    def command_velocity(self, velocity_mps, yaw_rate_radps, now_s):
        super().command_velocity(tuple(0.7 * v for v in velocity_mps), yaw_rate_radps, now_s)


def sluggish(spec, config, **start):
    return Sluggish(config, **start)  # the same for every UAV; ``spec`` (name, role) could choose


if __name__ == "__main__":
    bp, options = running_bond(2, 4, brick_uavs=2, adhesion_uavs=1), SimOptions(seed=1)
    for name, model in (("SimVehicle", sim_vehicle), ("Sluggish", sluggish)):
        r = simulate(bp, options, vehicle_model=model)
        err_cm = 100 * sum(r.placement_error_m.values()) / max(1, len(r.placement_error_m))
        print(
            f"{name:10s} completed {r.completed}, makespan {r.makespan_s:.1f} s, "
            f"mean placement error {err_cm:.1f} cm, wall {r.wall_time_s:.1f} s"
        )
