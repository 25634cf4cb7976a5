"""Would the swing gate, run as a watchdog before a gate state's work, change what the machines do? (issue 28)

The gate states (``pickup_align``, ``place_align``, ``hover``) test first whether the UAV has settled; only if not
do they run their gates (:mod:`masonry.fsm.gates`: the swing gate), then the leg timeout. A watchdog runs before
the state's work, so it would fail an attempt on a tick where the UAV both settles and swings. For each case-study
mission in wind this counts the gate states' ticks, the ticks on which the swing gate fails, the gates passed, and
the gates passed on a tick where the swing gate would have failed (the ticks on which the order matters).

    .venv/bin/python benchmarks/bench_gate_order.py               # 2 seeds per wind, arducopter vehicle
    .venv/bin/python benchmarks/bench_gate_order.py --seeds 5
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path
from typing import Any

from masonry.blueprint import load_blueprint
from masonry.fsm.adhesion import AdhesionUav
from masonry.fsm.brick import BrickUav
from masonry.mission.simulate import SimulatedMission
from masonry.ports import Telemetry
from masonry.sim import Faults
from masonry.sim.wind import WindConfig

ROOT = Path(__file__).resolve().parents[1]
COUNT: Counter[str] = Counter()
#: (mean wind m/s from the west, turbulence)
WINDS = [(4.0, "light"), (2.0, "moderate"), (6.0, "moderate")]


def _count(cls: Any, name: str, passed_to: str) -> None:
    """Wrap gate state handler ``cls.name``: before it runs, ask the gates (without moving the swing's mean)."""
    handler = getattr(cls, name)

    def counted(self: Any, tel: Telemetry) -> None:
        saved = self._swing
        fails = self._gate_failure(tel) is not None
        self._swing = saved  # the handler brings the mean up to date itself
        before = self.state
        handler(self, tel)
        COUNT["gate ticks"] += 1
        COUNT["swing fails"] += fails
        if self.state == passed_to and before != passed_to:
            COUNT["passed"] += 1
            COUNT["passed while the swing gate fails"] += fails

    setattr(cls, name, counted)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--vehicle", default="arducopter")
    args = parser.parse_args()
    _count(BrickUav, "do_pickup_align", "pickup_descend")
    _count(BrickUav, "do_place_align", "place_descend")
    _count(AdhesionUav, "do_hover", "descend")
    bp = load_blueprint(ROOT / "blueprints" / "paper_case_study.yaml")
    for speed, turbulence in WINDS:
        for seed in range(args.seeds):
            before = Counter(COUNT)
            faults = Faults(wind=WindConfig(speed_mps=speed, direction_deg=270.0, turbulence=turbulence))
            with SimulatedMission.from_blueprint(
                bp, seed=seed, faults=faults, vehicle=args.vehicle
            ) as mission:
                report = mission.run()
            got = ", ".join(f"{k} {COUNT[k] - before[k]}" for k in COUNT)
            print(
                f"{speed:.0f} m/s {turbulence}, seed {seed}: completed {report.completed}; {got}", flush=True
            )
    print("all: " + ", ".join(f"{k} {v}" for k, v in COUNT.items()))


if __name__ == "__main__":
    main()
