"""Where the as-built look's error comes from (issue 30): per look, the telemetry's part and the camera's.

For one vehicle model, wall and seed it flies the mission in ``masonry sim`` and records every frame of every
as-built look (``masonry.fsm.as_built``): the telemetry's position error at the frame's tick (against the
simulator's true position of the UAV) and the frame's estimate of the placed brick's top-face centre against its
truth; the rest of the estimate's error is the camera's (marker noise and the attitude's). Per look it prints the
frames, the seconds and heights they span, and the horizontal error of the look's mean split into the
telemetry's and the camera's part, its vertical error, and the camera's per-frame spread; then the mean and max.

    .venv/bin/python benchmarks/bench_as_built_look.py --vehicle arducopter --wall towers --seed 0
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np
from bench_as_built import WALLS, _true_top_m

from masonry.fsm import as_built
from masonry.mission.simulate import SimulatedMission
from masonry.sim import Faults
from masonry.sim.ports import SimCamera
from masonry.sim.wind import WindConfig


@dataclass(frozen=True)
class Frame:
    brick: int
    t_s: float
    true_m: np.ndarray
    tel_m: np.ndarray
    est_m: np.ndarray


def record(frames: list[Frame]) -> None:
    """Wrap the simulated camera's as-built frame and the look so that each frame estimated is recorded."""
    tick: dict[str, object] = {}
    read = SimCamera.read_as_built
    look = as_built.AsBuiltLook.look

    def read_as_built(self: SimCamera):  # type: ignore[no-untyped-def]
        v = self._uav.vehicle
        tick["true"], tick["t"] = np.array([v._x, v._y, v._z]), v._t
        return read(self)

    def looked(self: as_built.AsBuiltLook, camera, brick_id, tel, *args, **kwargs) -> None:  # type: ignore[no-untyped-def]
        n = self.window.count
        tick.clear()
        look(self, camera, brick_id, tel, *args, **kwargs)
        if "true" in tick and self.window.count > n:
            est = np.asarray(self.window._centers[-1])
            true = tick["true"]
            assert isinstance(true, np.ndarray)
            frames.append(Frame(brick_id, float(tick["t"]), true, np.asarray(tel.position_m), est))  # type: ignore[arg-type]

    SimCamera.read_as_built = read_as_built  # type: ignore[method-assign]
    as_built.AsBuiltLook.look = looked  # type: ignore[method-assign]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vehicle", default="arducopter")
    parser.add_argument("--wall", default="towers")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--wind", type=float, default=0.0, help="mean wind m/s (light turbulence); 0: calm")
    args = parser.parse_args()
    frames: list[Frame] = []
    record(frames)
    faults = Faults(wind=WindConfig(speed_mps=args.wind, turbulence="light")) if args.wind > 0 else None
    mission = SimulatedMission.from_blueprint(
        WALLS[args.wall](0), seed=args.seed, vehicle=args.vehicle, faults=faults
    )
    mission.run()
    by: dict[int, list[Frame]] = {}
    for f in frames:
        by.setdefault(f.brick, []).append(f)
    print(
        "brick  frames  s     h0 m  h1 m   telemetry xy  camera xy  look xy  look z  camera per frame (x) mm"
    )
    rows = []
    for bid, fs in by.items():
        if len(fs) < 2:
            continue
        top = _true_top_m(mission.world, bid)
        tel = np.array([f.tel_m - f.true_m for f in fs])
        est = np.array([f.est_m - top for f in fs])
        cam = est - tel
        row = [
            np.linalg.norm(tel.mean(0)[:2]),
            np.linalg.norm(cam.mean(0)[:2]),
            np.linalg.norm(est.mean(0)[:2]),
            abs(est.mean(0)[2]),
            np.std(cam[:, 0]),
        ]
        rows.append(row)
        h0, h1 = fs[0].true_m[2] - top[2], fs[-1].true_m[2] - top[2]
        print(
            f"B{bid:<4} {len(fs):>6}  {fs[-1].t_s - fs[0].t_s:4.1f}  {h0:4.2f}  {h1:4.2f}   "
            + "  ".join(f"{v * 1000:9.2f}" for v in row)
        )
    a = np.array(rows) * 1000
    print(
        "mean   "
        + " ".join(f"{v:.2f}" for v in a.mean(0))
        + "   max "
        + " ".join(f"{v:.2f}" for v in a.max(0))
    )


if __name__ == "__main__":
    main()
