"""The bricks over a bound off their neighbours (issue 30), one line each: which bricks the wall alignment saw.

For each brick of ``bench_as_built.py``'s walls placed farther than ``--over`` (m) from where its neighbours put
it (the benchmark's "neighbours" figure, from the simulator's truth), it prints: the error, its neighbours (placed
bricks it touches or stands on), the bricks the wall alignment last had in view before the release (``refs``) and
how long before the release it saw them, the brick's distance from where those references put it, how far the
references' mean lies from the neighbours' mean (what a brick aligned on them inherits), the horizontal distance
to each neighbour's offset, and the neighbour its as-built pose was measured relative to::

    python benchmarks/bench_as_built_trace.py --walls rotated-bond,pyramid --seeds 10 --over 0.018

(``--wind 4``: in 4 m/s wind with light turbulence, as ``bench_as_built.py --wind 4``.)
"""

from __future__ import annotations

import argparse

import numpy as np
from bench_as_built import WALLS, _config, _neighbours

from masonry.fsm.brick import BrickUav
from masonry.mission.simulate import SimulatedMission
from masonry.sim import Faults
from masonry.sim.wind import WindConfig

#: brick id -> what the wall alignment had at the release (filled by the wrapper below)
SEEN: dict[int, tuple[list[int], float]] = {}
_release = BrickUav.enter_place_release


def _record(self: BrickUav, *args: object, **kwargs: object) -> None:
    w = self._wall
    SEEN[self.brick_task.brick] = (sorted(w.estimates), self._now_s - w.seen_s)
    _release(self, *args, **kwargs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--walls", default="rotated-bond,towers,pyramid")
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--seed0", type=int, default=0)
    parser.add_argument("--over", type=float, default=0.02)
    parser.add_argument("--vehicle", default="px4")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    parser.add_argument(
        "--wind", type=float, default=0.0, help="wind speed (m/s), light turbulence (0: calm)"
    )
    args = parser.parse_args()
    faults = Faults(wind=WindConfig(speed_mps=args.wind, turbulence="light")) if args.wind > 0 else None
    overrides = {name: float(value) for name, _, value in (item.partition("=") for item in args.set)}
    BrickUav.enter_place_release = _record  # type: ignore[method-assign]
    for wall in args.walls.split(","):
        bp = WALLS[wall](0)
        near = _neighbours(bp)
        for seed in range(args.seed0, args.seed0 + args.seeds):
            SEEN.clear()
            config = _config(args.vehicle, wall=True, side_look=True, trend=True, overrides=overrides)
            mission = SimulatedMission.from_blueprint(
                bp, seed=seed, vehicle=args.vehicle, faults=faults, uav_config=config
            )
            report = mission.run()
            offs = {
                b.id: np.asarray(mission.world.bricks[b.id].position_m) - np.asarray(b.position_m)
                for b in bp.bricks
                if not b.placed
                and mission.world.bricks[b.id].released
                and mission.world.bricks[b.id].state == "placed"
            }
            for bid, off in offs.items():
                nb = [o for o in near[bid] if o in offs or bp.brick(o).placed]
                if not nb:
                    continue
                mean_nb = np.mean([offs.get(o, np.zeros(3)) for o in nb], axis=0)
                err = float(np.linalg.norm(off - mean_nb))
                if err < args.over:
                    continue
                refs, age_s = SEEN.get(bid, ([], float("nan")))
                mean_ref = np.mean([offs.get(o, np.zeros(3)) for o in refs], axis=0) if refs else np.zeros(3)
                pose = report.as_built.get(f"B{bid}")
                to_nb = " ".join(
                    f"B{o}:{np.linalg.norm(offs.get(o, np.zeros(3))[:2] - off[:2]) * 1000:.0f}" for o in nb
                )
                print(
                    f"{wall} seed {seed} B{bid}: {err * 1000:.1f} mm; neighbours {nb}, refs {refs} seen "
                    f"{age_s:.2f} s before; from the refs {np.linalg.norm(off - mean_ref) * 1000:.1f} mm, refs' "
                    f"mean from the neighbours' {np.linalg.norm(mean_ref - mean_nb) * 1000:.1f} mm; to each "
                    f"neighbour (mm) {to_nb}; as-built relative to "
                    f"{None if pose is None else pose.relative_to}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
