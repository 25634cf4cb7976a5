"""The airspace's inner loop: ``volumes_clear`` (written out) against ``not any(volumes_conflict(...))``.

Runs one mission (``masonry sim`` on a 2x30 running bond with 4 + 2 UAVs, seed 0; ``--quick``: 2x8 with 2 + 1)
recording every question mission control's airspace asked (a candidate flight's volumes against everyone
else's), then replays them through both functions and prints the time per call, the speed-up, and the whole
mission's wall time with each (the answers must be the same, and so must the schedule). Usage:

    .venv/bin/python benchmarks/bench_airspace.py [--quick]
"""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence

from masonry.blueprint_gen import running_bond
from masonry.mission import airspace
from masonry.mission.simulate import simulate
from masonry.mission.volumes import Volume, volumes_clear, volumes_conflict


def plain_clear(vols: Sequence[Volume], others: Sequence[Volume], sep_xy_m: float, sep_z_m: float) -> bool:
    """The same answer through the one-pair function."""
    return not any(volumes_conflict(v, q, sep_xy_m, sep_z_m) for v in vols for q in others)


def main(argv: list[str]) -> int:
    quick = "--quick" in argv
    bp = (
        running_bond(2, 8, brick_uavs=2, adhesion_uavs=1)
        if quick
        else running_bond(2, 30, brick_uavs=4, adhesion_uavs=2)
    )
    calls: list[tuple[list[Volume], list[Volume], float, float]] = []

    def recording(vols: Sequence[Volume], others: Sequence[Volume], sep_xy_m: float, sep_z_m: float) -> bool:
        calls.append((list(vols), list(others), sep_xy_m, sep_z_m))
        return volumes_clear(vols, others, sep_xy_m, sep_z_m)

    airspace.volumes_clear = recording  # type: ignore[assignment]
    try:
        simulate(bp, seed=0)
    finally:
        airspace.volumes_clear = volumes_clear
    pairs = sum(len(v) * len(o) for v, o, _x, _z in calls)
    print(
        f"{len(calls)} questions recorded ({pairs} volume pairs, {pairs / max(1, len(calls)):.1f} per question)"
    )
    assert all(volumes_clear(*c) == plain_clear(*c) for c in calls), "the two disagree"
    timings = {}
    for name, fn in (("volumes_clear (written out)", volumes_clear), ("any(volumes_conflict)", plain_clear)):
        best = float("inf")
        for _ in range(5):
            t0 = time.perf_counter()
            for c in calls:
                fn(*c)
            best = min(best, time.perf_counter() - t0)
        timings[name] = best
        print(
            f"  {name:30s} {best * 1e3:8.1f} ms for all, {best / max(1, len(calls)) * 1e6:6.2f} us per question"
        )
    fast, plain = timings.values()
    print(f"  speed-up x{plain / fast:.2f}")
    for name, fn in (("volumes_clear (written out)", volumes_clear), ("any(volumes_conflict)", plain_clear)):
        airspace.volumes_clear = fn  # type: ignore[assignment]
        try:
            t0 = time.perf_counter()
            r = simulate(bp, seed=0)
            print(
                f"  mission with {name:30s} {time.perf_counter() - t0:6.1f} s wall, makespan {r.makespan_s:.1f} s"
            )
        finally:
            airspace.volumes_clear = volumes_clear
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
