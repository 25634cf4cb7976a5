"""The CP-SAT schedule of a wall and fleet for the fleet benchmarks, solved once and cached on disk (issue 27).

``masonry schedule`` with a time limit is not deterministic (2 workers race), and a 90 s solve per wall and
fleet makes a sweep of seeds and policies slow. :func:`cached_schedule` solves it as the command does (the fleet
of ``fleet_for``, the plan of the blueprint, its cruise altitude, seed 0, 2 workers, decomposition ``auto``),
stamps it with the wall's and fleet's digests (so ``simulate(..., policy="schedule", schedule=...)`` accepts
it), and keeps it as JSON in ``--schedule-cache`` (default ``$XDG_CACHE_HOME/masonry/schedules``, else
``~/.cache/masonry/schedules``). The file name holds the wall and fleet digests, the reservation, the time limit
and a digest of the schedule model's source (``masonry/planner/schedule*.py`` but the policy, ``bounds*.py``,
``timing.py``):
a changed model solves anew. Every run of a sweep, every seed and policy, follows the same schedule.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from pathlib import Path

import masonry
from masonry.blueprint import Blueprint
from masonry.fingerprint import fleet_digest, wall_digest
from masonry.mission.fleet import fleet_for, with_fleet
from masonry.mission.schedule_file import read_schedule, stamp_schedule
from masonry.planner import plan as make_plan
from masonry.planner.schedule import physical_terms, solve_schedule
from masonry.planner.schedule_values import OfflineSchedule

#: the solver's seed and workers, as the benchmarks have always called it
SEED = 0
WORKERS = 2


def default_cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "masonry" / "schedules"


def model_digest() -> str:
    """A digest of the source of the schedule model (a change to it solves the schedules again)."""
    root = Path(masonry.__file__).resolve().parent
    planner = root / "planner"
    files = sorted(
        [
            *(f for f in planner.glob("schedule*.py") if f.name != "schedule_policy.py"),
            *planner.glob("bounds*.py"),
            root / "timing.py",
        ]
    )
    h = hashlib.sha256()
    for f in files:
        h.update(f.name.encode())
        h.update(f.read_bytes())
    return h.hexdigest()[:12]


def cached_schedule(
    blueprint: Blueprint,
    bricks: int,
    adhesion: int,
    reservation: str,
    time_limit_s: float,
    cache_dir: Path | None = None,
    chaining: bool = True,
    physical: str = "",
) -> tuple[OfflineSchedule, float, bool]:
    """The schedule of ``blueprint`` flown by ``bricks`` + ``adhesion`` UAVs, the seconds it took to get (the
    solve, or reading the file) and whether it came from the cache (``chaining``: the model's chain term, as
    ``solve_schedule``'s; ``physical``: its ``--physical`` terms, e.g. ``flown``, none by default)."""
    fleet = fleet_for(blueprint, bricks, adhesion)
    bp = blueprint if fleet == blueprint.fleet else with_fleet(blueprint, fleet)
    where = cache_dir if cache_dir is not None else default_cache_dir()
    name = (
        f"{wall_digest(bp)}-{fleet_digest(bp)}-{reservation}-{time_limit_s:g}s-seed{SEED}-w{WORKERS}"
        f"{'' if chaining else '-nochain'}{_physical_tag(physical)}-{model_digest()}.json"
    )
    path = where / name
    wall0 = time.perf_counter()
    if path.exists():
        return read_schedule(path), time.perf_counter() - wall0, True
    result = stamp_schedule(
        solve_as_the_cli(blueprint, bricks, adhesion, reservation, time_limit_s, physical, chaining=chaining),
        bp,
    )
    took_s = time.perf_counter() - wall0
    where.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(result.to_dict(), indent=1) + "\n", encoding="utf-8")
    tmp.replace(path)
    return result, took_s, False


def _physical_tag(physical: str) -> str:
    """The file name's part for ``physical`` terms (none: nothing, so the plain schedules keep their names)."""
    terms = physical_terms(physical)
    return f"-{'+'.join(terms)}" if terms else ""


def solve_as_the_cli(
    blueprint: Blueprint,
    bricks: int,
    adhesion: int,
    reservation: str,
    time_limit_s: float,
    physical: str = "",
    chaining: bool = True,
) -> OfflineSchedule:
    """``masonry schedule [--physical TERMS]`` of the wall and fleet, solved as the command solves it: the fleet of
    ``fleet_for``, the plan of the blueprint, its cruise altitude and r_c, :data:`WORKERS` workers, seed
    :data:`SEED` (not cached)."""
    fleet = fleet_for(blueprint, bricks, adhesion)
    bp = blueprint if fleet == blueprint.fleet else with_fleet(blueprint, fleet)
    return solve_schedule(
        make_plan(bp),
        fleet,
        cruise_altitude_m=bp.cruise_altitude_m,
        reservation=reservation,
        time_limit_s=time_limit_s,
        seed=SEED,
        workers=WORKERS,
        decomposition="auto",
        physical=physical,
        clearance_m=bp.clearance_m,
        chaining=chaining,
    )
