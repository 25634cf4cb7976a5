"""How far a simulated mission's bricks truly lie off their neighbours (the simulator's truth, not an estimate).

The measure of issue 30's "relative to neighbours" target, shared by tests/test_wall_align.py and
benchmarks/bench_place_taken.py: a wall built off as a whole (every brick shifted alike) scores zero.
"""

from __future__ import annotations

import math

import numpy as np

from masonry.mission.simulate import SimulatedMission

__all__ = ["neighbour_errors_m"]


def neighbour_errors_m(mission: SimulatedMission) -> list[float]:
    """Per placed brick (its task done) with placed neighbours, the horizontal distance (m) of its offset from the
    design to the mean offset of the bricks it touches in its course or stands on."""
    bp, world = mission.blueprint, mission.world
    done = {a.task_id for a in mission.control.history if a.status == "done"}
    placed = [b for b in bp.bricks if f"B{b.id}" in done]  # (not one found off its course: never done)
    off = {b.id: np.asarray(world.bricks[b.id].position_m) - np.asarray(b.position_m) for b in placed}
    out = []
    for b in placed:
        near = [
            o.id
            for o in placed
            if o.id != b.id
            and math.dist(o.position_m[:2], b.position_m[:2]) <= b.size_m[0] * 1.01
            and -1e-6 < b.position_m[2] - o.position_m[2] < b.size_m[2] + 1e-3
        ]
        if near:
            out.append(float(np.linalg.norm((off[b.id] - np.mean([off[i] for i in near], axis=0))[:2])))
    return out
