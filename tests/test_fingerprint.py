"""The blueprint digests: equal for the same parsed wall, different for any change a task would see."""

from __future__ import annotations

import dataclasses

from masonry.blueprint import format_blueprint, load_blueprint
from masonry.fingerprint import fleet_digest, wall_digest


def test_same_wall_written_again_has_the_same_digests(tmp_path):
    bp = load_blueprint("blueprints/paper_case_study.yaml")
    again = tmp_path / "again.yaml"
    again.write_text("# rewritten\n" + format_blueprint(bp))
    bp2 = load_blueprint(again)
    assert wall_digest(bp2) == wall_digest(bp)
    assert fleet_digest(bp2) == fleet_digest(bp)


def test_a_moved_brick_or_another_clearance_changes_the_wall_digest_only():
    bp = load_blueprint("blueprints/paper_case_study.yaml")
    b0 = bp.bricks[-1]
    moved = dataclasses.replace(
        bp,
        bricks=(
            *bp.bricks[:-1],
            dataclasses.replace(b0, position_m=(b0.position_m[0] + 1e-6, *b0.position_m[1:])),
        ),
    )
    assert wall_digest(moved) != wall_digest(bp)
    assert fleet_digest(moved) == fleet_digest(bp)
    assert wall_digest(dataclasses.replace(bp, clearance_m=bp.clearance_m + 0.1)) != wall_digest(bp)


def test_another_fleet_changes_the_fleet_digest_only():
    bp = load_blueprint("blueprints/paper_case_study.yaml")
    u = bp.fleet[0]
    other = dataclasses.replace(bp, fleet=(dataclasses.replace(u, name=u.name + "x"), *bp.fleet[1:]))
    assert fleet_digest(other) != fleet_digest(bp)
    assert wall_digest(other) == wall_digest(bp)
