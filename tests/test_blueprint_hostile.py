"""Hostile and physically impossible blueprint files, and UAV names that could confuse the mission network.

Each gets one short line naming the file, the field or id and the problem, and exit status 2 from `masonry plan`,
`masonry sim` and `masonry fly` alike: never a traceback, a hang, unbounded memory or a silent wrong answer.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from masonry.blueprint import (
    MAX_CLEARANCE_M,
    MIN_SUPPORT_FRACTION,
    QUOTE_MAX_CHARS,
    Blueprint,
    BlueprintError,
    Brick,
    UavSpec,
    load_blueprint,
    quote,
)
from masonry.blueprint_gen import running_bond
from masonry.cli import app
from masonry.errors import InputError
from masonry.planner import plan

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()

# A valid wall: two placed bricks side by side, one brick on them, its pickup 3 m away; two UAVs.
HEAD = "name: hostile\nclearance: 1.5\ncruise_altitude: 1.2\n"
BRICKS = (
    "bricks:\n"
    "  - {id: 0, position: [0.0, 0.0, 0.05], placed: true}\n"
    "  - {id: 1, position: [0.3, 0.0, 0.05], placed: true}\n"
    "  - {id: 2, position: [0.15, 0.0, 0.15], pickup: [0.0, -3.0, 0.05]}\n"
)
FLEET = (
    "fleet:\n"
    "  - {name: brick-1, role: brick, home: [2.0, -4.0, 0.0]}\n"
    "  - {name: glue-1, role: adhesion, home: [-2.0, -4.0, 0.0]}\n"
)
GOOD = HEAD + BRICKS + FLEET

#: Keep a runaway (the old code's billion laughs, /dev/zero) from taking the shared machine's memory.
CHILD_MEMORY_BYTES = 1_000_000_000


def _write(tmp_path: Path, text: str, name: str = "bp.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _error(tmp_path: Path, text: str) -> str:
    with pytest.raises(BlueprintError) as info:
        load_blueprint(_write(tmp_path, text))
    message = str(info.value)
    assert "\n" not in message and len(message) < 400, message
    return message


def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (CHILD_MEMORY_BYTES, CHILD_MEMORY_BYTES))


def _masonry(*args: str, timeout_s: float = 60.0) -> subprocess.CompletedProcess[str]:
    """`masonry ARGS` in a child process with a memory cap and a timeout (a hang fails the test, not the run)."""
    code = "import sys; from masonry.cli import app; sys.argv = ['masonry', *sys.argv[1:]]; app()"
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    return subprocess.run(
        [sys.executable, "-c", code, *args],
        capture_output=True,
        text=True,
        timeout=timeout_s,
        preexec_fn=_limit_memory,
        env=env,
        check=False,
    )


def _commands(path: Path) -> list[list[str]]:
    return [
        ["plan", str(path)],
        ["sim", str(path)],
        ["fly", "--sim", "--uav", "brick", "--blueprint", str(path), "--task", "B2"],
    ]


def _one_line_exit_2(result: subprocess.CompletedProcess[str] | object) -> str:
    code = getattr(result, "returncode", getattr(result, "exit_code", None))
    err = str(getattr(result, "stderr", ""))
    assert code == 2, (code, err[-2000:])
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err, err[-2000:]
    assert len(lines[0]) < 400, lines[0][:500]
    return lines[0]


def test_the_good_wall_is_valid(tmp_path: Path) -> None:
    bp = load_blueprint(_write(tmp_path, GOOD))
    assert len(plan(bp).tasks) == 5  # 3 bricks (2 placed), 2 adhesion lines


# -- alias bomb, file size, devices, FIFOs ------------------------------------------------------------------

BOMB = (
    HEAD
    + 'a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]\n'
    + "".join(
        f"{chr(98 + k)}: &{chr(98 + k)} [" + ",".join([f"*{chr(97 + k)}"] * 9) + "]\n" for k in range(8)
    )
    + "bricks:\n  - {id: 0, position: *i, placed: true}\n"
    + FLEET
)


def test_alias_bomb_is_one_line_from_plan_sim_and_fly(tmp_path: Path) -> None:
    path = _write(tmp_path, BOMB)
    assert len(BOMB.encode()) < 1200  # a ~1 KB file that expands to 9^9 strings
    for args in _commands(path):  # each within _masonry's timeout: 9^9 strings would take far longer
        line = _one_line_exit_2(_masonry(*args))
        assert "aliases expand the document" in line and str(path) in line


def test_an_alias_within_the_limit_is_fine(tmp_path: Path) -> None:
    text = (
        HEAD
        + "brick:\n  size: &s [0.3, 0.15, 0.1]\n"
        + BRICKS.replace("placed: true}", "placed: true, size: *s}")
    )
    assert load_blueprint(_write(tmp_path, text + FLEET)).bricks[0].size_m == (0.3, 0.15, 0.1)


def test_recursive_alias_is_an_error(tmp_path: Path) -> None:
    assert "recursive alias" in _error(tmp_path, GOOD + "x: &r [1, *r]\n")


def test_file_over_the_size_limit(tmp_path: Path) -> None:
    path = tmp_path / "huge.yaml"
    with path.open("wb") as f:
        f.truncate(65 * 1024 * 1024)  # sparse: no disk used
    with pytest.raises(BlueprintError, match="over the 64 MB limit"):
        load_blueprint(path)


def test_dev_zero_is_refused_at_once() -> None:
    line = _one_line_exit_2(_masonry("plan", "/dev/zero"))
    assert "/dev/zero" in line and "not a regular file" in line


def test_fifo_is_refused_not_waited_on(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe.yaml"
    os.mkfifo(fifo)
    line = _one_line_exit_2(_masonry("plan", str(fifo), timeout_s=30.0))
    assert "not a regular file" in line


# -- duplicate keys, numbers ---------------------------------------------------------------------------------


def test_duplicate_key_names_both_lines(tmp_path: Path) -> None:
    message = _error(tmp_path, GOOD.replace("clearance: 1.5\n", "clearance: 1.5\nclearance: 0.001\n"))
    assert "duplicate key 'clearance'" in message and "line 3" in message and "line 2" in message


def test_duplicate_key_in_a_flow_mapping(tmp_path: Path) -> None:
    text = GOOD.replace("{id: 2, position: [0.15, 0.0, 0.15]", "{id: 2, position: [0.15, 0.0, 0.15], id: 7")
    assert "duplicate key 'id'" in _error(tmp_path, text)


def test_exponent_numbers_are_numbers(tmp_path: Path) -> None:
    text = GOOD.replace("clearance: 1.5", "clearance: 15e-1").replace(
        "[0.0, -3.0, 0.05]", "[0.0, -3.0, 5e-2]"
    )
    bp = load_blueprint(_write(tmp_path, text))
    assert bp.clearance_m == 1.5 and bp.brick(2).pickup_m == (0.0, -3.0, 0.05)
    message = _error(tmp_path, GOOD.replace("[0.0, -3.0, 0.05]", "[1e9, -3.0, 0.05]"))
    assert "brick 2: pickup" in message and "off the site" in message


# -- ranges ----------------------------------------------------------------------------------------------------


def test_huge_position_is_off_the_site(tmp_path: Path) -> None:
    message = _error(tmp_path, GOOD.replace("[0.15, 0.0, 0.15]", "[1.0e+300, 0.0, 0.15]"))
    assert "brick 2: position" in message and "off the site" in message


def test_huge_id_is_not_in_its_dictionary(tmp_path: Path) -> None:
    message = _error(tmp_path, GOOD.replace("{id: 2,", f"{{id: {10**26},"))
    assert "DICT_4X4_50" in message and "brick ids 0..24" in message


def test_each_brick_marker_ids_exist_in_its_dictionary(tmp_path: Path) -> None:
    assert "brick 25" in _error(tmp_path, GOOD.replace("{id: 2,", "{id: 25,"))  # markers 50, 51 of 0..49
    assert load_blueprint(_write(tmp_path, GOOD.replace("{id: 2,", "{id: 24,"))).brick(24).marker_ids() == (
        48,
        49,
    )


def test_generated_walls_pick_a_dictionary_that_numbers_every_brick() -> None:
    bp = running_bond(20, 30)  # 600 bricks: markers 0..1199, more than any 4x4 dictionary holds
    assert bp.markers.dictionary == "DICT_APRILTAG_36h10"
    assert len(plan(bp).tasks) > 600


def test_absurd_clearance(tmp_path: Path) -> None:
    message = _error(tmp_path, GOOD.replace("clearance: 1.5", "clearance: 1000"))
    assert "clearance" in message and f"{MAX_CLEARANCE_M:g}" in message


# -- physically impossible sites ---------------------------------------------------------------------------------


def test_pickup_inside_the_walls_footprint(tmp_path: Path) -> None:
    message = _error(tmp_path, GOOD.replace("[0.0, -3.0, 0.05]", "[0.31, 0.02, 0.05]"))
    assert "brick 2: pickup" in message and "inside the wall's footprint" in message and "brick 1" in message


def test_two_bricks_sharing_one_pickup(tmp_path: Path) -> None:
    text = (
        GOOD.replace(FLEET, "")
        + "  - {id: 3, position: [0.45, 0.0, 0.15], pickup: [0.0, -3.0, 0.05]}\n"
        + FLEET
    )
    text = text.replace(
        "{id: 1, position: [0.3, 0.0, 0.05], placed: true}",
        "{id: 1, position: [0.3, 0.0, 0.05], placed: true}\n"
        "  - {id: 4, position: [0.6, 0.0, 0.05], placed: true}",
    )
    message = _error(tmp_path, text)
    assert "brick 3: pickup" in message and "brick 2's pickup too" in message


def test_stacked_pickups_are_fine(tmp_path: Path) -> None:
    text = (
        GOOD.replace(FLEET, "")
        + "  - {id: 3, position: [0.45, 0.0, 0.15], pickup: [0.0, -3.0, 0.15]}\n"
        + FLEET
    )
    text = text.replace(
        "{id: 1, position: [0.3, 0.0, 0.05], placed: true}",
        "{id: 1, position: [0.3, 0.0, 0.05], placed: true}\n"
        "  - {id: 4, position: [0.6, 0.0, 0.05], placed: true}",
    )
    assert len(load_blueprint(_write(tmp_path, text)).bricks) == 5


@pytest.mark.parametrize(
    ("pickup", "fragment"), [("[0.0, -3.0, -0.5]", "below the ground"), ("[0.0, -3.0, 50.0]", "at most 10 m")]
)
def test_pickup_height(tmp_path: Path, pickup: str, fragment: str) -> None:
    message = _error(tmp_path, GOOD.replace("[0.0, -3.0, 0.05]", pickup))
    assert "brick 2: pickup" in message and fragment in message


@pytest.mark.parametrize(
    ("home", "fragment"), [("[2.0, -4.0, -1.0]", "below the ground"), ("[2.0, -4.0, 40.0]", "at most 10 m")]
)
def test_home_height(tmp_path: Path, home: str, fragment: str) -> None:
    message = _error(tmp_path, GOOD.replace("[2.0, -4.0, 0.0]", home))
    assert "'brick-1': home" in message and fragment in message


def test_brick_on_a_1_mm_overlap(tmp_path: Path) -> None:
    text = GOOD.replace("[0.15, 0.0, 0.15]", "[0.599, 0.0, 0.15]").replace(
        "[0.0, -3.0, 0.05]", "[1.0, -3.0, 0.05]"
    )
    message = _error(tmp_path, text)
    assert "brick 2" in message and "0.3 % of its footprint rests on brick(s) 1" in message
    assert f"at least {MIN_SUPPORT_FRACTION * 100:.0f} %" in message


def test_a_running_bond_end_brick_half_supported_is_fine(tmp_path: Path) -> None:
    text = GOOD.replace("[0.15, 0.0, 0.15]", "[0.45, 0.0, 0.15]")
    assert load_blueprint(_write(tmp_path, text)).brick(2).position_m == (0.45, 0.0, 0.15)


def test_two_uavs_with_the_same_home(tmp_path: Path) -> None:
    message = _error(tmp_path, GOOD.replace("[-2.0, -4.0, 0.0]", "[2.0, -4.0, 0.0]"))
    assert "'glue-1': home" in message and "is 0 m from the home of 'brick-1'" in message
    assert "pads must be at least 1 m apart (the airframe's 0.8 m span plus 0.2 m)" in message


def test_pads_too_close_for_two_airframes_or_to_the_work(tmp_path: Path) -> None:
    # GOOD: brick-1's home at (2, -4), the wall around the origin, pickups at y = -2
    message = _error(tmp_path, GOOD.replace("[-2.0, -4.0, 0.0]", "[2.0, -4.95, 0.0]"))
    assert "'glue-1': home: is 0.95 m from the home of 'brick-1'" in message
    load_blueprint(_write(tmp_path, GOOD.replace("[-2.0, -4.0, 0.0]", "[2.0, -5.0, 0.0]")))  # 1 m: fine
    message = _error(tmp_path, GOOD.replace("[-2.0, -4.0, 0.0]", "[-0.5, -1.0, 0.0]"))
    assert "'glue-1': home: is 0.989 m from the wall (brick 0): a pad must be at least 1.15 m" in message
    message = _error(tmp_path, GOOD.replace("[-2.0, -4.0, 0.0]", "[0.5, -3.5, 0.0]"))
    assert "'glue-1': home: is 0.707 m from brick 2's pickup: a pad must be at least 1.15 m" in message


def test_home_inside_the_wall(tmp_path: Path) -> None:
    message = _error(tmp_path, GOOD.replace("[-2.0, -4.0, 0.0]", "[0.05, 0.0, 0.0]"))
    assert "'glue-1': home" in message and "inside the wall's footprint" in message


def test_cruise_below_the_finished_walls_top(tmp_path: Path) -> None:
    message = _error(tmp_path, GOOD.replace("cruise_altitude: 1.2", "cruise_altitude: 0.15"))
    assert (
        "cruise_altitude" in message and "not above the finished wall's top (z = 0.2 m, brick 2)" in message
    )


def test_generated_tall_wall_cruises_over_it() -> None:
    bp = running_bond(15, 4)  # 1.5 m tall, above the default 1.2 m cruise altitude
    assert bp.cruise_altitude_m == pytest.approx(2.0)
    assert len(plan(bp).tasks) > 0


# -- the r_c boundary -------------------------------------------------------------------------------------------


def test_pairs_at_exactly_r_c_conflict() -> None:
    # 9 x 0.3 and 14 x 0.3 are 1.5000000000000004 m apart in floating point: the paper's dist <= r_c holds.
    a, b = 9 * 0.3, 14 * 0.3
    bricks = (
        Brick(0, (a, 0.0, 0.05), pickup_m=(0.0, -3.0, 0.05)),
        Brick(1, (b, 0.0, 0.05), pickup_m=(1.0, -3.0, 0.05)),
    )
    fleet = (UavSpec("b", "brick", (0.0, -5.0, 0.0)), UavSpec("g", "adhesion", (2.0, -5.0, 0.0)))
    assert b - a > 1.5
    assert plan(Blueprint(bricks=bricks, fleet=fleet, clearance_m=1.5)).conflicts == (("B0", "B1"),)


# -- quoting, long values, fly --config ------------------------------------------------------------------------


def test_quote_is_bounded() -> None:
    big = [0.0] * 200_000
    text = quote(big)
    assert len(text) <= QUOTE_MAX_CHARS and "200000 items" in text
    assert len(quote("x" * 10**6)) <= QUOTE_MAX_CHARS

    class Counted:
        rendered = 0

        def __repr__(self) -> str:
            Counted.rendered += 1
            return "c"

    # the work is bounded, not only the text: a handful of the 200,000 items is rendered, never the list whole
    assert "200000 items" in quote([Counted() for _ in range(200_000)])
    assert 1 <= Counted.rendered <= 6


def test_200000_element_position_is_a_short_line(tmp_path: Path) -> None:
    text = GOOD.replace("[0.15, 0.0, 0.15]", "[" + ", ".join(["0.0"] * 200_000) + "]")
    path = _write(tmp_path, text)
    for args in _commands(path):
        line = _one_line_exit_2(runner.invoke(app, args))
        assert "brick 2: position" in line and "200000 items" in line


def test_unknown_huge_key_is_a_short_line(tmp_path: Path) -> None:
    message = _error(tmp_path, GOOD + ("k" * 1000) + ": 1\n")  # libyaml takes keys up to 1024 characters
    assert "unknown key 'kkkk" in message


def test_non_utf8_blueprint(tmp_path: Path) -> None:
    path = tmp_path / "latin1.yaml"
    path.write_bytes(GOOD.replace("hostile", "h\xe9").encode("latin-1"))
    line = _one_line_exit_2(runner.invoke(app, ["plan", str(path)]))
    assert "not UTF-8 text" in line


@pytest.mark.parametrize(
    "content", [bytes(range(256)) * 8, "fc: caf\xe9\n".encode("latin-1"), b"\x89PNG\r\n\x1a\n\0\0"]
)
def test_fly_config_binary_or_not_utf8(tmp_path: Path, content: bytes) -> None:
    config = tmp_path / "uav.yaml"
    config.write_bytes(content)
    result = runner.invoke(
        app,
        [
            "fly",
            "--uav",
            "brick",
            "--blueprint",
            str(ROOT / "blueprints" / "paper_case_study.yaml"),
            "--task",
            "B0",
            "--config",
            str(config),
        ],
    )
    line = _one_line_exit_2(result)
    assert str(config) in line


def test_fly_config_long_value_is_a_short_line(tmp_path: Path) -> None:
    from masonry.adapters.wiring import load_uav_config

    config = tmp_path / "uav.yaml"
    config.write_text("origin_m: [" + ", ".join(["0.0"] * 200_000) + "]\n")
    with pytest.raises(InputError) as info:
        load_uav_config(config)
    assert len(str(info.value)) < 300 and "200000 items" in str(info.value)
    config.write_text("fc: sim\nfc: udpin:0.0.0.0:14550\n")
    with pytest.raises(InputError, match="duplicate key 'fc'"):
        load_uav_config(config)


# -- UAV names (section 1) ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "name", ["b*", "b$1", "a/b", "b#", "b?", "**", "-x", "b 1", "mission-control", "x" * 65, "ünï"]
)
def test_uav_name_that_is_not_a_zenoh_key_chunk(tmp_path: Path, name: str) -> None:
    message = _error(tmp_path, GOOD.replace("name: glue-1", f"name: {name!r}"))
    assert "name" in message and ("not a UAV name" in message or "mission control's own name" in message)


@pytest.mark.parametrize("name", ["glue-1", "G_2", "uav.3", "7", "x" * 64])
def test_uav_names_that_are_fine(tmp_path: Path, name: str) -> None:
    assert (
        load_blueprint(_write(tmp_path, GOOD.replace("name: glue-1", f"name: {name!r}"))).fleet[1].name
        == name
    )


def test_uav_name_checked_on_values_too() -> None:
    bricks = (Brick(0, (0.0, 0.0, 0.05), pickup_m=(0.0, -3.0, 0.05)),)
    with pytest.raises(BlueprintError, match="not a UAV name"):
        plan(Blueprint(bricks=bricks, fleet=(UavSpec("a/b", "brick", (0.0, -5.0, 0.0)),)))


# -- every bad blueprint: one line, exit 2, from plan, sim and fly alike -------------------------------------------


@pytest.mark.parametrize(
    "text",
    [
        GOOD.replace("clearance: 1.5\n", "clearance: 1.5\nclearance: 0.001\n"),
        GOOD.replace("[0.0, -3.0, 0.05]", "[1.0e+300, -3.0, 0.05]"),
        GOOD.replace("name: glue-1", "name: 'g*'"),
        GOOD.replace("cruise_altitude: 1.2", "cruise_altitude: 0.1"),
        GOOD.replace("[0.0, -3.0, 0.05]", "[0.31, 0.02, 0.05]"),
    ],
    ids=["duplicate-key", "huge-number", "uav-name", "cruise", "pickup-in-wall"],
)
def test_plan_sim_fly_alike(tmp_path: Path, text: str) -> None:
    path = _write(tmp_path, text)
    lines = {_one_line_exit_2(runner.invoke(app, args)) for args in _commands(path)}
    assert len(lines) == 1, lines  # the same line from all three commands


@pytest.mark.parametrize(
    "text",
    [
        GOOD.replace("name: glue-1", "name: 'g*'"),
        GOOD.replace("name: glue-1", "name: mission-control"),
        GOOD.replace("clearance: 1.5", "clearance: 1000"),
        GOOD.replace("[0.0, -3.0, 0.05]", "[1.0e+300, -3.0, 0.05]"),
        GOOD.replace("[0.0, -3.0, 0.05]", "[0.0, -3.0, 50.0]"),
        GOOD.replace("[2.0, -4.0, 0.0]", "[2.0, -4.0, -1.0]"),
    ],
    ids=["name", "reserved-name", "clearance", "off-site", "pickup-high", "home-low"],
)
def test_schema_has_the_same_limits(text: str) -> None:
    jsonschema = pytest.importorskip("jsonschema")
    import yaml

    from masonry.schema import blueprint_schema

    schema = blueprint_schema()
    jsonschema.validate(yaml.safe_load(GOOD), schema)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(yaml.safe_load(text), schema)
