"""Behaviour pinned: the schedules of a fixed set of missions, compared with digests recorded beside this file.

A refactor that says "behaviour unchanged" must leave every digest as it is. A change that means to change
behaviour (a bug fixed) re-records them in its own commit and says why in the CHANGELOG::

    python tests/test_behaviour_pinned.py --record        # rewrites tests/pinned_schedules.json
    python tests/test_behaviour_pinned.py                 # prints each case: pinned, changed or new

The digest covers every attempt of the mission (task, UAV, attempt number, start and end to 10 ms, outcome),
the placement errors (0.1 mm) and the minimum separation (1 mm): what a user sees in ``masonry sim --format
json``. The case study, the faults run and the UAV-loss run are pinned whole. The 2x30, 4x25 and 200-brick walls
(4 + 2 and 3 + 2 UAVs, fifo and critical-path, three seeds) are pinned over their first ``HORIZON_S`` of
mission time: by then every UAV has taken off, flown several tasks, been held and granted by the airspace and
chained adhesion segments, so any change to the machines, the airspace or the dispatcher shows there, and the
18 runs cost seconds instead of minutes (docs/performance/test-suite.md has the suite's time).
"""

from __future__ import annotations

import hashlib
import json
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from masonry.blueprint import Blueprint, load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.mission.report import MissionReport
from masonry.mission.simulate import simulate
from masonry.sim import Faults

ROOT = Path(__file__).resolve().parents[1]
PINNED = Path(__file__).with_name("pinned_schedules.json")
#: mission seconds over which the long walls are pinned
HORIZON_S = 900.0


@dataclass(frozen=True)
class Pin:
    name: str
    blueprint: Callable[[], Blueprint]
    options: dict[str, Any]


def _case_study() -> Blueprint:
    return load_blueprint(ROOT / "blueprints" / "paper_case_study.yaml")


def _pins() -> list[Pin]:
    pins = [
        Pin(f"case-study/{policy}/seed{seed}", _case_study, {"policy": policy, "seed": seed})
        for policy in ("fifo", "critical-path")
        for seed in (0, 1, 2)
    ]
    walls: list[tuple[str, Callable[[], Blueprint], int, int]] = [
        ("2x30", lambda: running_bond(2, 30), 4, 2),
        ("4x25", lambda: running_bond(4, 25), 4, 2),
        ("running-bond-200", lambda: load_blueprint(ROOT / "blueprints" / "running_bond_200.yaml"), 3, 2),
    ]
    for name, make, brick, adhesion in walls:
        for policy in ("fifo", "critical-path"):
            for seed in (0, 1, 2):
                pins.append(
                    Pin(
                        f"{name}/{brick}+{adhesion}/{policy}/seed{seed}",
                        make,
                        {
                            "brick_uavs": brick,
                            "adhesion_uavs": adhesion,
                            "policy": policy,
                            "seed": seed,
                            "max_time_s": HORIZON_S,
                        },
                    )
                )
    pins.append(
        Pin(
            "case-study/faults",
            _case_study,
            {"seed": 1, "faults": Faults(grasp_failure=0.3, dropout=0.2, occlusion=0.2)},
        )
    )
    pins.append(
        Pin(
            "running-bond-small/uav-loss",
            lambda: load_blueprint(ROOT / "blueprints" / "running_bond_small.yaml"),
            {
                "brick_uavs": 2,
                "adhesion_uavs": 1,
                "seed": 0,
                "faults": Faults(uav_loss_at_s={"brick-2": 120.0}),
            },
        )
    )
    return pins


PINS = _pins()


def _r(value: float | None, digits: int) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def schedule_digest(report: MissionReport) -> str:
    """The digest of what a user sees of a mission: its attempts, placement errors and minimum separation."""
    rows = [
        f"{a.task_id},{a.uav},{a.attempt},{_r(a.start_s, 2)},{_r(a.end_s, 2)},{a.status}"
        for a in sorted(report.attempts, key=lambda a: (a.start_s, a.task_id, a.attempt))
    ]
    rows += [f"{k}:{_r(v, 4)}" for k, v in sorted(report.placement_error_m.items())]
    rows.append(f"sep:{_r(report.min_separation_m, 3)} completed:{report.completed}")
    return hashlib.sha256("\n".join(rows).encode()).hexdigest()[:16]


def run_pin(pin: Pin) -> str:
    # the paper's reservation (conflicting tasks never at once, the default): the schedules these digests were
    # recorded with; the ``site`` reservation has its own tests (tests/test_sites.py)
    return schedule_digest(simulate(pin.blueprint(), camera="geometric", reservation="task", **pin.options))


def _recorded() -> dict[str, str]:
    return json.loads(PINNED.read_text()) if PINNED.exists() else {}


def test_every_pin_is_recorded():
    assert sorted(_recorded()) == sorted(p.name for p in PINS), (
        "re-record: python tests/test_behaviour_pinned.py --record"
    )


@pytest.mark.slow
@pytest.mark.parametrize("pin", PINS, ids=[p.name for p in PINS])
def test_schedule_is_unchanged(pin: Pin):
    recorded = _recorded().get(pin.name)
    assert recorded is not None, f"{pin.name} has no recorded digest"
    assert run_pin(pin) == recorded, (
        f"{pin.name}: the schedule changed; if that is meant, re-record in its own "
        "commit and say why in the CHANGELOG"
    )


def test_the_digest_sees_a_change_of_one_attempt():
    report = simulate(_case_study(), camera="geometric", seed=0)
    import dataclasses

    moved = dataclasses.replace(report.attempts[0], end_s=(report.attempts[0].end_s or 0.0) + 0.01)
    other = dataclasses.replace(report, attempts=(moved, *report.attempts[1:]))
    assert schedule_digest(other) != schedule_digest(report)


def main(argv: list[str]) -> int:
    record = "--record" in argv
    old = _recorded()
    new: dict[str, str] = {}
    changed = 0
    for pin in PINS:
        digest = run_pin(pin)
        new[pin.name] = digest
        state = "new" if pin.name not in old else ("pinned" if old[pin.name] == digest else "CHANGED")
        changed += state != "pinned"
        print(f"{state:8s} {digest} {pin.name}", flush=True)
    if record:
        PINNED.write_text(json.dumps(new, indent=1, sort_keys=True) + "\n")
        print(f"recorded {len(new)} digests in {PINNED}")
        return 0
    return 1 if changed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
