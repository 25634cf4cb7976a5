"""The px4 placements on one support split by cause (issue 30): the release, the target's error, the carry.

For every brick of ``bench_as_built.py``'s walls that stands on one support, at its release: *release*, the true
effector's distance from the true point its target meant (the target less the position source's wander then);
*align*, that point (moved by the carried brick's offset on the magnet the camera measured,
:mod:`masonry.fsm.carried_look`) from where the support truly puts the brick; *carry*, the rest (the conical
guide's residual on the magnet less what was measured of it, the world's release scatter). It prints rms / max
mm of each, the measured release error and the tick's position noise, the align part by the wall's sighting's age
at the release, and the worst
bricks (with their speed and time from the descent leg's planned end at the release). ``--neighbours`` takes
every brick with placed neighbours instead, against where their mean puts it (the benchmark's "neighbours" figure)::

    python benchmarks/bench_as_built_release.py --walls towers --seeds 10 [--set NAME=VALUE ...]
    python benchmarks/bench_as_built_release.py --walls towers,pyramid --seeds 10 --seed0 10 --neighbours --worst 8

(``--wind 4``: in 4 m/s wind with light turbulence, as ``bench_as_built.py --wind 4``; each worst brick also says how
many looks back up its descent flew, ``ReleaseGate.relooks``.)
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from bench_as_built import WALLS, _config, _neighbours

from masonry.fsm.brick import BrickUav
from masonry.fsm.wall_align import supports_of
from masonry.mission.simulate import SimulatedMission
from masonry.sim import Faults
from masonry.sim.wind import WindConfig

#: brick id -> what the release tick held (filled by the wrapper below)
RELEASES: dict[int, dict[str, np.ndarray | float]] = {}
MISSION: list[SimulatedMission] = []
_release = BrickUav.enter_place_release


def _record(self: BrickUav, *args: object, **kwargs: object) -> None:
    sim = MISSION[0].world.uavs[self.config.name]
    tel = self._tel
    assert tel is not None
    target = np.asarray(self.attempt.place_effector_target_m, dtype=float)
    true_m = np.asarray(sim.vehicle.position_m, dtype=float)
    shaper = sim.vehicle._shaper  # (the simulator's truth)
    gps = np.zeros(3) if shaper is None else np.asarray(shaper.gps_error_m, dtype=float)
    RELEASES[self.brick_task.brick] = {
        "measured": (np.asarray(self.effector.position(tel), dtype=float) - target)[:2],
        "noise": (np.asarray(tel.position_m, dtype=float) - true_m - gps)[:2],
        "true_target": (target - gps)[:2],
        # a release timed within the tick (ReleaseGate.ahead, Gripper.release_at): where the effector is then, on
        # its true velocity
        "effector": np.asarray(sim.effector_m(), dtype=float)[:2]
        + np.asarray(sim.vehicle.velocity_mps, dtype=float)[:2] * self._gate.ahead_s,
        "age_s": self._now_s - self._wall.seen_s,
        "speed": np.asarray(sim.vehicle.velocity_mps, dtype=float)[:2],
        "past_end_s": self._now_s - self.nav.end_s,
        "looks": float(self._gate.relooks),
        # the carried brick's offset on the magnet the camera measured (masonry.fsm.carried_look): the target is
        # the effector's, the brick's is this much off it
        "carried": np.asarray(self._wall.carried.world_m(self._place_yaw_rad()), dtype=float)[:2],
        # the error the gate judged: the tick's measured one carried on the measured velocity to a timed release
        "predicted": (np.asarray(self.effector.position(tel), dtype=float) - target)[:2]
        + np.asarray(tel.velocity_mps, dtype=float)[:2] * self._gate.ahead_s,
        # the side look's last leg's direction (pre-release point to drop-off; zero off the side look)
        "leg": _unit(-np.asarray(self._side.offset_m, dtype=float)[:2])
        if self._side.offset_m is not None and self._side.final
        else np.zeros(2),
    }
    _release(self, *args, **kwargs)


def _unit(v: np.ndarray) -> np.ndarray:
    n = float(np.hypot(*v))
    return v / n if n > 1e-9 else np.zeros(2)


def _leg_mm(v: np.ndarray, leg: np.ndarray) -> str:
    """``v`` (m) along / across the leg (mm), or as x / y off the side look."""
    if not np.any(leg):
        return f"xy ({v[0] * 1000:+.1f}, {v[1] * 1000:+.1f})"
    along = float(v @ leg)
    across = float(leg[0] * v[1] - leg[1] * v[0])
    return f"along {along * 1000:+.1f} across {across * 1000:+.1f}"


def _rms_mm(vs: list[np.ndarray]) -> float:
    return math.sqrt(float(np.mean([float(np.dot(v, v)) for v in vs]))) * 1000.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--walls", default="towers")
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--seed0", type=int, default=0)
    parser.add_argument("--worst", type=int, default=8)
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    parser.add_argument(
        "--neighbours",
        action="store_true",
        help="every brick with placed neighbours, against their mean (the benchmark's figure), not only one support",
    )
    parser.add_argument(
        "--wind", type=float, default=0.0, help="wind speed (m/s), light turbulence (0: calm)"
    )
    args = parser.parse_args()
    faults = Faults(wind=WindConfig(speed_mps=args.wind, turbulence="light")) if args.wind > 0 else None
    overrides = {name: float(value) for name, _, value in (item.partition("=") for item in args.set)}
    BrickUav.enter_place_release = _record  # type: ignore[method-assign]
    rows: list[tuple[str, int, int, dict[str, np.ndarray]]] = []
    for wall in args.walls.split(","):
        bp = WALLS[wall](0)
        near = _neighbours(bp)
        design = {
            b.id: (b.position_m[0], b.position_m[1], b.position_m[2] + b.size_m[2] / 2) for b in bp.bricks
        }
        for seed in range(args.seed0, args.seed0 + args.seeds):
            RELEASES.clear()
            config = _config("px4", wall=True, side_look=True, trend=True, overrides=overrides)
            mission = SimulatedMission.from_blueprint(
                bp, seed=seed, vehicle="px4", faults=faults, uav_config=config
            )
            MISSION[:] = [mission]
            mission.run()
            for b in bp.bricks:
                below = supports_of(design, b.id, b.size_m)
                if args.neighbours:
                    below = {o for o in near[b.id] if o in RELEASES}
                if b.id not in RELEASES or not below or (len(below) != 1 and not args.neighbours):
                    continue
                want = np.mean(
                    [
                        np.asarray(mission.world.bricks[s].position_m)[:2]
                        + (np.asarray(b.position_m)[:2] - np.asarray(bp.brick(s).position_m)[:2])
                        for s in below
                    ],
                    axis=0,
                )
                r = RELEASES[b.id]
                final = np.asarray(mission.world.bricks[b.id].position_m)[:2] - want
                release = np.asarray(r["effector"]) - np.asarray(r["true_target"])
                align = np.asarray(r["true_target"]) + np.asarray(r["carried"]) - want
                parts = {"final": final, "release": release, "align": align, "carry": final - release - align}
                rows.append((wall, seed, b.id, {**parts, **{k: np.asarray(v) for k, v in r.items()}}))
    print(f"{len(rows)} bricks {'with neighbours' if args.neighbours else 'on one support'}")
    for name in ("final", "release", "align", "carry", "measured", "noise"):
        vs = [r[3][name] for r in rows]
        print(
            f"{name:9s} rms {_rms_mm(vs):5.1f} mm, max {max(float(np.linalg.norm(v)) for v in vs) * 1000:5.1f} mm"
        )
    ages = sorted({round(float(r[3]["age_s"]), 1) for r in rows})
    print(
        "align rms by the sighting's age at the release: "
        + ", ".join(
            f"{a:.1f} s {_rms_mm([r[3]['align'] for r in rows if round(float(r[3]['age_s']), 1) == a]):.1f} mm "
            f"({sum(1 for r in rows if round(float(r[3]['age_s']), 1) == a)})"
            for a in ages
        )
    )
    legs = [r[3] for r in rows if np.any(r[3]["leg"])]
    if legs:
        parts = []
        for name in ("final", "release", "align", "predicted"):
            along = [float(np.asarray(p[name]) @ p["leg"]) for p in legs]
            across = [float(p["leg"][0] * p[name][1] - p["leg"][1] * p[name][0]) for p in legs]
            parts.append(
                f"{name} {math.sqrt(np.mean(np.square(along))) * 1000:.1f} / "
                f"{math.sqrt(np.mean(np.square(across))) * 1000:.1f} (mean {np.mean(along) * 1000:+.1f} / "
                f"{np.mean(across) * 1000:+.1f})"
            )
        print(
            f"{len(legs)} let go on the side look's last leg, rms (mean) along / across it (mm): "
            + ", ".join(parts)
        )
    print(
        "mean (x, y) mm over the bricks: "
        + ", ".join(
            f"{n} {np.round(np.mean([r[3][n] for r in rows], axis=0) * 1000, 1)}" for n in ("final", "align")
        )
    )
    for wall, seed, bid, p in sorted(rows, key=lambda r: -float(np.linalg.norm(r[3]["final"])))[: args.worst]:
        mm = {k: float(np.linalg.norm(p[k])) * 1000 for k in ("final", "release", "align", "carry", "noise")}
        print(
            f"{wall} seed {seed} B{bid}: {mm['final']:.1f} mm = release {mm['release']:.1f} + align "
            f"{mm['align']:.1f} + carry {mm['carry']:.1f} (vectors); measured {np.round(p['measured'] * 1000, 1)}, "
            f"the tick's noise {mm['noise']:.1f} mm; wall seen {float(p['age_s']):.2f} s before; "
            f"{float(np.linalg.norm(p['speed'])):.2f} m/s, {float(p['past_end_s']):+.2f} s past the leg's end, "
            f"{int(p['looks'])} looks"
        )
        leg = np.asarray(p["leg"])
        print(
            f"    predicted at the gate {float(np.linalg.norm(p['predicted'])) * 1000:.1f} mm; leg frame (mm): "
            f"final {_leg_mm(p['final'], leg)}; release {_leg_mm(p['release'], leg)}; align "
            f"{_leg_mm(p['align'], leg)}; velocity {_leg_mm(p['speed'], leg)} mm/s"
        )


if __name__ == "__main__":
    main()
