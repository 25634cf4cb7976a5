"""Walls larger than any ArUco dictionary can number: refused to fly, planned on request (planner studies)."""

from __future__ import annotations

import dataclasses

import pytest
from typer.testing import CliRunner

from masonry.blueprint import MAX_MARKED_BRICKS, format_blueprint, load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.cli import app
from masonry.errors import BlueprintError
from masonry.planner import plan


@pytest.fixture(scope="module")
def big_wall(tmp_path_factory):
    bp = running_bond(3, 400, placed_courses=1)  # 1,200 bricks: more than MAX_MARKED_BRICKS
    assert len(bp.bricks) > MAX_MARKED_BRICKS
    # without the marker numbers `masonry blueprint` gives it (issue 30): each brick's id is its marker number
    bp = dataclasses.replace(
        bp,
        bricks=tuple(dataclasses.replace(b, marker=None) for b in bp.bricks),
        markers=dataclasses.replace(bp.markers, dictionary="DICT_APRILTAG_36h10"),
    )
    path = tmp_path_factory.mktemp("big") / "wall.yaml"
    path.write_text(format_blueprint(bp))
    return path


def test_a_wall_beyond_every_dictionary_does_not_validate(big_wall):
    with pytest.raises(BlueprintError, match="no ArUco dictionary holds more than 2320 markers") as info:
        load_blueprint(big_wall)
    assert "give the bricks `marker` numbers" in str(info.value)


def test_it_plans_as_a_planner_only_study(big_wall):
    p = plan(load_blueprint(big_wall, check_marker_ids=False), check_marker_ids=False)
    assert sum(1 for t in p.tasks if t.id.startswith("B") and not t.done) == 800


def test_cli_plan_refuses_it_in_one_line_and_plans_it_with_planner_only(big_wall):
    runner = CliRunner()
    refused = runner.invoke(app, ["plan", str(big_wall)])
    assert refused.exit_code == 2
    assert "1160 bricks" in refused.output
    done = runner.invoke(app, ["plan", str(big_wall), "--planner-only", "--format", "json"])
    assert done.exit_code == 0, done.output
    assert '"tasks"' in done.output


def test_planner_only_still_bounds_ids():
    bp = running_bond(1, 3)
    huge = dataclasses.replace(bp, bricks=(dataclasses.replace(bp.bricks[0], id=10**26), *bp.bricks[1:]))
    with pytest.raises(BlueprintError, match=r"id must be in 0\.\."):
        plan(huge, check_marker_ids=False)
