"""Blueprint values: parsing, defaults, writing back, generators and the JSON Schema."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import yaml

from masonry.blueprint import (
    BRICK_KEYS,
    MARKER_KEYS,
    TOP_KEYS,
    UAV_KEYS,
    BlueprintError,
    MarkerSpec,
    format_blueprint,
    load_blueprint,
    parse_blueprint,
)
from masonry.blueprint_gen import generate, pyramid, running_bond, towers
from masonry.schema import blueprint_schema

ROOT = Path(__file__).resolve().parents[1]

DATA = {
    "name": "two",
    "clearance": 1.0,
    "brick": {
        "size": [0.2, 0.1, 0.05],
        "markers": {"dictionary": "DICT_4X4_100", "size": 0.04, "spacing": 0.12},
    },
    "bricks": [
        {"id": 3, "position": [0.0, 0.0, 0.025], "placed": True},
        {
            "id": 7,
            "position": [0.0, 0.0, 0.075],
            "yaw": 0.0,
            "size": [0.2, 0.1, 0.05],
            "pickup": [2.0, 0.0, 0.025],
        },
    ],
    "fleet": [
        {"name": "b1", "role": "brick", "home": [1.0, -2.0, 0.0]},
        {"name": "g1", "role": "adhesion", "home": [-1.0, -2.0, 0.0]},
    ],
}


def test_parse_fills_defaults_and_units() -> None:
    bp = parse_blueprint(DATA, "mem.yaml")
    assert bp.name == "two" and bp.clearance_m == 1.0 and bp.cruise_altitude_m == 1.2
    assert bp.markers == MarkerSpec("DICT_4X4_100", 0.04, 0.12)
    b3, b7 = bp.bricks
    assert b3.size_m == (0.2, 0.1, 0.05) and b3.placed and b3.pickup_m is None and b3.yaw_rad == 0.0
    assert b7.pickup_m == (2.0, 0.0, 0.025) and not b7.placed
    assert bp.brick(7) is b7 and b7.marker_ids() == (14, 15)
    assert bp.uavs("adhesion")[0].home_m == (-1.0, -2.0, 0.0)
    assert bp.source == "mem.yaml"
    with pytest.raises(KeyError):
        bp.brick(99)


def test_format_then_load_round_trips(tmp_path: Path) -> None:
    bp = parse_blueprint(DATA, "mem.yaml")
    path = tmp_path / "rt.yaml"
    path.write_text(format_blueprint(bp, header="round trip"))
    again = load_blueprint(path)
    assert again.bricks == bp.bricks and again.fleet == bp.fleet and again.markers == bp.markers
    assert again.name == bp.name and again.clearance_m == bp.clearance_m


def test_json_files_load_too(tmp_path: Path) -> None:
    path = tmp_path / "wall.json"
    path.write_text(json.dumps(DATA))
    assert len(load_blueprint(path).bricks) == 2


@pytest.mark.parametrize("path", sorted((ROOT / "blueprints").glob("*.yaml")), ids=lambda p: p.name)
def test_bundled_blueprints_load(path: Path) -> None:
    bp = load_blueprint(path)
    assert bp.uavs("brick") and bp.bricks
    # Pickups are on a pallet away from the wall: farther than r_c from every brick of the wall.
    for b in bp.bricks:
        if b.pickup_m is not None:
            nearest = min(math.dist(b.pickup_m[:2], w.position_m[:2]) for w in bp.bricks)
            assert nearest > bp.clearance_m


def test_paper_case_study_matches_the_paper() -> None:
    bp = load_blueprint(ROOT / "blueprints" / "paper_case_study.yaml")
    assert bp.clearance_m == 1.5 and bp.cruise_altitude_m == 1.2
    assert len(bp.uavs("brick")) == 1 and len(bp.uavs("adhesion")) == 1
    todo = [b for b in bp.bricks if not b.placed]
    assert [b.id for b in todo] == [0, 1]
    assert 0 < math.dist(todo[0].position_m, todo[1].position_m) < bp.clearance_m
    # Pickups on the right (+x) of the stacks.
    assert all(b.pickup_m is not None and b.pickup_m[0] > b.position_m[0] + 2.0 for b in todo)


@pytest.mark.parametrize(
    "bp",
    [
        running_bond(
            5, 7, placed_courses=2, yaw_rad=0.3, origin_m=(4.0, -1.0), brick_uavs=2, adhesion_uavs=2
        ),
        towers(3, 4, spacing_m=1.2),
        pyramid(6, joint_m=0.01),
        generate("running-bond", courses=2, bricks_per_course=3, brick_size_m=(0.25, 0.12, 0.08)),
    ],
    ids=["running-bond", "towers", "pyramid", "generate"],
)
def test_generated_blueprints_are_valid_and_round_trip(bp, tmp_path: Path) -> None:
    path = tmp_path / "gen.yaml"
    path.write_text(format_blueprint(bp))
    again = load_blueprint(path)
    assert len(again.bricks) == len(bp.bricks) and len(again.fleet) == len(bp.fleet)
    for a, b in zip(again.bricks, bp.bricks):
        assert a.id == b.id and a.placed == b.placed
        assert a.position_m == pytest.approx(b.position_m, abs=1e-9)
    names = [u.name for u in bp.fleet]
    homes = [u.home_m for u in bp.fleet]
    assert len(set(names)) == len(names)
    assert all(math.dist(p, q) > bp.clearance_m for i, p in enumerate(homes) for q in homes[i + 1 :])


def test_running_bond_shape() -> None:
    bp = running_bond(3, 4, placed_courses=1)
    assert len(bp.bricks) == 12 and sum(b.placed for b in bp.bricks) == 4
    xs = sorted(b.position_m[0] for b in bp.bricks if b.position_m[2] > 0.1 and b.position_m[2] < 0.2)
    assert xs[1] - xs[0] == pytest.approx(0.30)
    assert bp.markers.dictionary == "DICT_4X4_50"
    assert running_bond(10, 10).markers.dictionary == "DICT_4X4_250"


@pytest.mark.parametrize("bad", [{"courses": 0}, {"bricks_per_course": -1}])
def test_generator_rejects_bad_counts(bad: dict[str, int]) -> None:
    with pytest.raises(BlueprintError):
        running_bond(**{"courses": 2, "bricks_per_course": 2, **bad})


def test_schema_keys_match_the_parser() -> None:
    schema = blueprint_schema()
    props = schema["properties"]
    assert tuple(props) == TOP_KEYS
    assert tuple(props["bricks"]["items"]["properties"]) == BRICK_KEYS
    assert tuple(props["fleet"]["items"]["properties"]) == UAV_KEYS
    assert tuple(props["brick"]["properties"]["markers"]["properties"]) == MARKER_KEYS


def test_yaml_error_names_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text("name: x\nbricks: [\n  {id: 0\n")
    with pytest.raises(BlueprintError) as info:
        load_blueprint(path)
    assert str(info.value).startswith(f"{path}: line ")
    assert "YAML syntax error" in str(info.value)
    assert yaml  # the loader is PyYAML's C loader when available
