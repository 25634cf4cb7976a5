"""The side look's last leg tick by tick (issue 30): how near each pass came to the drop-off, and the tick let go.

For every brick of ``bench_as_built.py``'s walls placed on the side look's last leg, from the simulator's truth at
each tick of the leg (the effector against the true point its target meant: the target less the position
source's wander): the tick released, the nearest tick of the pass it was released on, and the pass's closest
point on the straight line between ticks (and on the next tick's, the velocity carried on); for the releases over
``--ticks`` (m), the pass's last six ticks with the measured error, the speed, the wall's sighting's age, the UAV
off the leg's reference and the reference off the leg's end, and the time from the leg's planned end::

    python benchmarks/bench_as_built_pass.py --walls towers --seeds 10 --wind 4 [--set NAME=VALUE ...]

``--directions`` prints instead, for the first side look planned on each wall (seed ``--seed0``), every
direction :func:`masonry.fsm.side_look.look_offset_m` tries: the pre-release displacement it needs and where, on
the last leg from there to the drop-off, the support leaves the camera's view (the wall at its design, and with it
2 cm off): the stretch the leg flies blind::

    python benchmarks/bench_as_built_pass.py --walls towers --wind 4 --directions
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from bench_as_built import WALLS, _config

from masonry.fsm import side_look
from masonry.fsm.brick import BrickUav
from masonry.geometry import rot_z
from masonry.mission.sim_loop import CONTROL_PERIOD_S
from masonry.mission.simulate import SimulatedMission
from masonry.sim import Faults
from masonry.sim.wind import WindConfig

#: brick id -> the leg's ticks: (t_s, true error xy, measured error xy, velocity xy, sighting age s, looks flown,
#: UAV off the reference xy, reference off the leg's end xy, time past the leg's end s)
TICKS: dict[int, list[tuple]] = {}
RELEASED: dict[int, float] = {}
MISSION: list[SimulatedMission] = []
_descend = BrickUav.do_place_descend
_release = BrickUav.enter_place_release


def _tick(self: BrickUav, tel: object) -> None:
    _descend(self, tel)  # type: ignore[arg-type]
    if not self._side.final or self._gate.looking:
        return
    sim = MISSION[0].world.uavs[self.config.name]
    shaper = sim.vehicle._shaper
    gps = np.zeros(3) if shaper is None else np.asarray(shaper.gps_error_m, dtype=float)
    target = np.asarray(self.attempt.place_effector_target_m, dtype=float)
    t = self._tel
    assert t is not None
    TICKS.setdefault(self.brick_task.brick, []).append(
        (
            self._now_s,
            (np.asarray(sim.effector_m(), dtype=float) - (target - gps))[:2],
            (np.asarray(self.effector.position(t), dtype=float) - target)[:2],
            np.asarray(sim.vehicle.velocity_mps, dtype=float)[:2],
            self._now_s - self._wall.seen_s,
            self._gate.relooks,
            (
                np.asarray(t.position_m, dtype=float)
                - np.asarray(self.nav.reference(self._now_s)[0], dtype=float)
            )[:2],
            (
                np.asarray(self.nav.reference(self._now_s)[0], dtype=float)
                - np.asarray(self.nav.target_m, dtype=float)
            )[:2],
            self._now_s - self.nav.end_s,
        )
    )


def _record(self: BrickUav, *args: object, **kwargs: object) -> None:
    RELEASED[self.brick_task.brick] = self._now_s
    _release(self, *args, **kwargs)


def _closest_m(a: np.ndarray, b: np.ndarray) -> float:
    """The least distance from the origin on the segment a-b."""
    d = b - a
    dd = float(np.dot(d, d))
    f = 0.0 if dd == 0.0 else min(1.0, max(0.0, -float(np.dot(a, d)) / dd))
    return float(np.linalg.norm(a + f * d))


#: the first side look planned: its scene and the pre-release displacement chosen
PLANNED: list[tuple[side_look.LookScene, np.ndarray]] = []
_plan = side_look.SideLook.plan


class _Planned(Exception):
    """The first side look is planned: the mission need not run on."""


def _first_plan(self: side_look.SideLook, uav: BrickUav) -> np.ndarray:
    out = _plan(self, uav)
    if self.offset_m is not None:
        PLANNED.append((side_look.scene_of(uav), self.offset_m.copy()))
        raise _Planned
    return out


def _directions(scene: side_look.LookScene, chosen_m: np.ndarray) -> None:
    """Print, per direction tried, the pre-release displacement and where the support leaves the view."""
    pre = side_look.PRE_RELEASE_GAP_M
    print(
        f"  chosen {np.round(chosen_m[:2] * 1000)} mm; body yaw {math.degrees(scene.body_yaw_rad):.0f} deg, the "
        "directions in the body frame"
    )
    R = rot_z(scene.body_yaw_rad)[:2, :2]
    for k in range(16):
        a = 2 * math.pi * k / 16
        unit = R @ np.array([math.cos(a), math.sin(a)])
        near = next(
            (
                d
                for d in side_look._DISTANCES_M
                if side_look._support_seen(scene, d * unit, pre, side_look.TRACK_SPREAD_M)
            ),
            None,
        )
        if near is None:
            print(f"  {math.degrees(a):5.1f} deg: no displacement keeps the support in view")
            continue
        lost = []
        for spread in (0.0, 0.02):
            last = near
            for f in np.linspace(1.0, 0.0, 101):
                if not side_look._support_seen(scene, f * near * unit, f * pre, spread):
                    break
                last = f * near
            lost.append(last)
        print(
            f"  {math.degrees(a):5.1f} deg: displaced {near * 100:.0f} cm, the support out of view "
            f"{lost[0] * 100:.1f} cm from the drop-off (2 cm off its design: {lost[1] * 100:.1f} cm)"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--walls", default="towers")
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--seed0", type=int, default=0)
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    parser.add_argument("--wind", type=float, default=0.0)
    parser.add_argument(
        "--ticks", type=float, default=0.014, help="print the ticks of releases over this (m)"
    )
    parser.add_argument("--directions", action="store_true")
    args = parser.parse_args()
    faults = Faults(wind=WindConfig(speed_mps=args.wind, turbulence="light")) if args.wind > 0 else None
    overrides = {name: float(value) for name, _, value in (item.partition("=") for item in args.set)}
    if args.directions:
        side_look.SideLook.plan = _first_plan  # type: ignore[method-assign]
        for wall in args.walls.split(","):
            PLANNED.clear()
            config = _config("px4", wall=True, side_look=True, trend=True, overrides=overrides)
            mission = SimulatedMission.from_blueprint(
                WALLS[wall](0), seed=args.seed0, vehicle="px4", faults=faults, uav_config=config
            )
            try:
                mission.run()
            except _Planned:
                pass
            print(f"{wall}:" + ("" if PLANNED else " no side look"))
            if PLANNED:
                _directions(*PLANNED[0])
        return
    BrickUav.do_place_descend = _tick  # type: ignore[method-assign]
    BrickUav.enter_place_release = _record  # type: ignore[method-assign]
    rel, best, line = [], [], []
    for wall in args.walls.split(","):
        bp = WALLS[wall](0)
        for seed in range(args.seed0, args.seed0 + args.seeds):
            TICKS.clear()
            RELEASED.clear()
            config = _config("px4", wall=True, side_look=True, trend=True, overrides=overrides)
            mission = SimulatedMission.from_blueprint(
                bp, seed=seed, vehicle="px4", faults=faults, uav_config=config
            )
            MISSION[:] = [mission]
            mission.run()
            for bid, ticks in TICKS.items():
                if bid not in RELEASED:
                    continue
                at = [i for i, k in enumerate(ticks) if abs(k[0] - RELEASED[bid]) < 1e-6]
                if not at:
                    continue
                i = at[-1]
                leg = [k for k in ticks if k[5] == ticks[i][5]]
                j = leg.index(ticks[i])
                e = float(np.linalg.norm(ticks[i][1]))
                # the pass: the ticks of this leg up to the release and one after it (had it not let go)
                near = min(float(np.linalg.norm(k[1])) for k in leg[: j + 1])
                seg = min(
                    (_closest_m(leg[m][1], leg[m + 1][1]) for m in range(len(leg) - 1) if m + 1 <= j),
                    default=e,
                )
                ahead = _closest_m(ticks[i][1], ticks[i][1] + ticks[i][3] * CONTROL_PERIOD_S)
                seg = min(seg, ahead)
                rel.append(e)
                best.append(near)
                line.append(seg)
                if e >= args.ticks:
                    print(
                        f"{wall} seed {seed} B{bid}: released {e * 1000:.1f} mm, pass nearest tick {near * 1000:.1f}, "
                        f"closest between ticks {seg * 1000:.1f}"
                    )
                    for k in leg[max(0, j - 5) : j + 1]:
                        print(
                            f"    t {k[0]:8.2f} true {np.round(k[1] * 1000, 1)} ({np.linalg.norm(k[1]) * 1000:5.1f}) "
                            f"measured {np.round(k[2] * 1000, 1)} ({np.linalg.norm(k[2]) * 1000:5.1f}) "
                            f"{np.linalg.norm(k[3]):.2f} m/s seen {k[4]:.2f} s before; off ref {np.round(k[6] * 1000, 1)}, ref to end {np.round(k[7] * 1000, 1)}, {k[8]:+.1f} s"
                        )

    def rms(v: list[float]) -> float:
        return math.sqrt(float(np.mean(np.square(v)))) * 1000

    print(
        f"{len(rel)} releases on the last leg: released rms {rms(rel):.1f} max {max(rel) * 1000:.1f} mm; "
        f"the leg's nearest tick up to it rms {rms(best):.1f}; closest between ticks rms {rms(line):.1f} mm"
    )


if __name__ == "__main__":
    main()
