"""A larger fleet keeps the smaller fleet's pads (issue 27 §4, branch ``more42``): on the bundled pyramid the
admission rule keeps 3 brick + 1 adhesion UAVs busy from 4 + 2 to 8 + 4, and the lone sprayer's relief for its
battery swap is glue-2. Laid past all eight brick pads (26 m from the wall's middle, 4 + 2's at 14 m), glue-2's
flight to its first hold took 28.6 s against 8.8 s, and the whole mission after it came 25.3 s later: 8 + 4 was
slower than 4 + 2 (and 28.7 s slower than 2 + 1). With the pads laid step by step (:func:`masonry.mission.fleet.
ladder`) 8 + 4 flies 4 + 2's mission."""

from __future__ import annotations

from pathlib import Path

import pytest

from masonry.blueprint import load_blueprint
from masonry.mission.simulate import simulate

PYRAMID = Path(__file__).resolve().parent.parent / "blueprints" / "pyramid.yaml"


@pytest.mark.slow
def test_the_pyramids_8_plus_4_is_no_slower_than_its_4_plus_2() -> None:
    bp = load_blueprint(PYRAMID)
    runs = {
        fleet: simulate(
            bp,
            brick_uavs=fleet[0],
            adhesion_uavs=fleet[1],
            seed=3,
            policy="critical-path",
            camera="geometric",
            reservation="site",
        )
        for fleet in ((4, 2), (8, 4))
    }
    small, large = runs[(4, 2)], runs[(8, 4)]
    for r in (small, large):
        assert r.completed and r.conflict_violations == 0 and r.dependency_violations == 0
        assert r.min_separation_m is not None and r.min_separation_m >= 1.0
    assert large.makespan_s <= small.makespan_s + 0.05  # main: 1,208.1 against 1,182.8 s
