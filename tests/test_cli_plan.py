"""`masonry plan`, `masonry schema`, `masonry blueprint ...` through typer's CliRunner, incl. every validation error."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from masonry.cli import app

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "blueprints" / "paper_case_study.yaml"
runner = CliRunner()

GOOD = """\
name: tiny
bricks:
  - {id: 0, position: [0.0, 0.0, 0.05], placed: true}
  - {id: 1, position: [0.0, 0.0, 0.15], pickup: [3.0, 0.0, 0.05]}
fleet:
  - {name: brick-1, role: brick, home: [2.0, -2.0, 0.0]}
  - {name: glue-1, role: adhesion, home: [0.0, -2.0, 0.0]}
"""


def _invoke(*args: str):
    return runner.invoke(app, list(args))


def test_paper_case_study_summary_shows_start_tasks_and_cross_conflicts() -> None:
    result = _invoke("plan", str(PAPER))
    assert result.exit_code == 0, result.stderr
    out = result.stdout
    assert "available now   2: A0, A1" in out
    rows = {line.split()[0]: line for line in out.splitlines() if line.startswith(("  B", "  A"))}
    # B0 sits on the stack glued by A0, B1 on the one glued by A1: each conflicts with the other stack's task.
    assert "A1" in rows["B0"].split("A0", 1)[1] and "A0" in rows["B1"].split("A1", 1)[1]


def test_paper_case_study_json() -> None:
    result = _invoke("plan", str(PAPER), "--format", "json")
    assert result.exit_code == 0, result.stderr
    data = json.loads(result.stdout)
    assert set(data) == {"tasks", "dependencies", "conflicts"}
    conflicts = {frozenset(c) for c in data["conflicts"]}
    assert frozenset({"B0", "A1"}) in conflicts and frozenset({"B1", "A0"}) in conflicts
    assert frozenset({"B0", "A0"}) not in conflicts and frozenset({"B1", "A1"}) not in conflicts
    assert len(conflicts) == len(data["conflicts"])
    done = {t["id"] for t in data["tasks"] if t.get("done")}
    prereq: dict[str, list[str]] = {}
    for u, v in data["dependencies"]:
        prereq.setdefault(u, []).append(v)
    todo = [t["id"] for t in data["tasks"] if not t.get("done")]
    available = [t for t in todo if all(v in done for v in prereq.get(t, []))]
    assert sorted(available) == ["A0", "A1"]


def test_issue_example_json_shape(tmp_path: Path) -> None:
    path = tmp_path / "tiny.yaml"
    path.write_text(GOOD)
    out = tmp_path / "plan.json"
    result = _invoke("plan", str(path), "--format", "json", "--output", str(out))
    assert result.exit_code == 0, result.stderr
    assert result.stdout == ""
    data = json.loads(out.read_text())
    assert data == {
        "tasks": [
            {
                "id": "B0",
                "kind": "brick",
                "brick": 0,
                "done": True,
                "position": [0.0, 0.0, 0.05],
                "yaw": 0.0,
                "pickup": None,
            },
            {
                "id": "B1",
                "kind": "brick",
                "brick": 1,
                "done": False,
                "position": [0.0, 0.0, 0.15],
                "yaw": 0.0,
                "pickup": [3.0, 0.0, 0.05],
            },
            {
                "id": "A0",
                "kind": "adhesion",
                "below": 0,
                "above": 1,
                "start": [-0.15, 0.0, 0.1],
                "end": [0.15, 0.0, 0.1],
                "length": 0.3,
            },
        ],
        "dependencies": [["B1", "A0"], ["A0", "B0"]],
        "conflicts": [],
    }


@pytest.mark.parametrize("suffix", [".dot", ".graphml", ".svg", ".png"])
def test_graph_export(tmp_path: Path, suffix: str) -> None:
    target = tmp_path / f"graphs{suffix}"
    result = _invoke("plan", str(PAPER), "--graph", str(target))
    assert result.exit_code == 0, result.stderr
    data = target.read_bytes()
    assert len(data) > 100
    if suffix == ".dot":
        text = data.decode()
        assert '"B0" -> "A0"' in text and "dashed" in text
    if suffix == ".graphml":
        import networkx as nx

        g = nx.read_graphml(target)
        kinds = {d["relation"] for _, _, d in g.edges(data=True)}
        assert kinds == {"dependency", "conflict"}
    if suffix == ".png":
        assert data[:8] == b"\x89PNG\r\n\x1a\n"


def test_bad_graph_suffix_is_one_line(tmp_path: Path) -> None:
    result = _invoke("plan", str(PAPER), "--graph", str(tmp_path / "g.pdf"))
    assert result.exit_code == 2
    assert result.stderr.count("\n") == 1 and "--graph" in result.stderr


def test_schema_is_valid_and_accepts_bundled_blueprints() -> None:
    import jsonschema

    result = _invoke("schema")
    assert result.exit_code == 0
    schema = json.loads(result.stdout)
    jsonschema.Draft202012Validator.check_schema(schema)
    for path in sorted((ROOT / "blueprints").glob("*.yaml")):
        jsonschema.validate(yaml.safe_load(path.read_text()), schema)
    bad = yaml.safe_load(GOOD)
    bad["bricks"][0]["colour"] = "red"
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(bad, schema)


@pytest.mark.parametrize(
    "args",
    [
        ["running-bond", "--courses", "3", "--bricks-per-course", "5", "--placed-courses", "1"],
        ["towers", "--towers", "3", "--height", "4", "--spacing", "1.2", "--brick-uavs", "2"],
        ["pyramid", "--base", "4", "--yaw", "0.7", "--origin", "2", "3"],
    ],
)
def test_blueprint_generators_write_plannable_files(tmp_path: Path, args: list[str]) -> None:
    out = tmp_path / "wall.yaml"
    result = _invoke("blueprint", *args, "-o", str(out))
    assert result.exit_code == 0, result.stderr
    planned = _invoke("plan", str(out), "--format", "json")
    assert planned.exit_code == 0, planned.stderr
    assert json.loads(planned.stdout)["tasks"]


def test_blueprint_generator_rejects_bad_counts() -> None:
    result = _invoke("blueprint", "running-bond", "--courses", "0")
    assert result.exit_code == 2
    assert "courses" in result.stderr and result.stderr.count("\n") == 1


BRICK0 = "  - {id: 0, position: [0.0, 0.0, 0.05], placed: true}\n"
FLEET = "fleet:\n  - {name: b, role: brick, home: [2.0, -2.0, 0.0]}\n  - {name: g, role: adhesion, home: [0.0, -2.0, 0.0]}\n"

# (file text, fragments that must all appear in the one-line message)
INVALID = {
    "yaml-syntax": ("bricks: [\n  - {id: 0,\n", ["YAML syntax error", "line"]),
    "not-mapping": ("- 1\n- 2\n", ["not a mapping"]),
    "empty": ("", ["empty file"]),
    "missing-bricks": (FLEET, ["missing key 'bricks'"]),
    "missing-fleet": ("bricks:\n" + BRICK0, ["missing key 'fleet'"]),
    "missing-position": (
        "bricks:\n  - {id: 0, placed: true}\n" + FLEET,
        ["brick 0", "missing key 'position'"],
    ),
    "unknown-top": ("clearence: 1.0\nbricks:\n" + BRICK0 + FLEET, ["unknown key 'clearence'", "clearance"]),
    "unknown-brick-key": (
        "bricks:\n  - {id: 0, position: [0, 0, 0.05], placed: true, colour: red}\n" + FLEET,
        ["brick 0", "unknown key 'colour'"],
    ),
    "wrong-type-position": (
        "bricks:\n  - {id: 0, position: [0, 0], placed: true}\n" + FLEET,
        ["brick 0: position"],
    ),
    "wrong-type-id": (
        "bricks:\n  - {id: one, position: [0, 0, 0.05], placed: true}\n" + FLEET,
        ["bricks[0]: id"],
    ),
    "wrong-type-placed": (
        "bricks:\n  - {id: 0, position: [0, 0, 0.05], placed: yes please}\n" + FLEET,
        ["brick 0: placed"],
    ),
    "wrong-type-clearance": ("clearance: far\nbricks:\n" + BRICK0 + FLEET, ["clearance", "must be a number"]),
    "nan": (
        "bricks:\n  - {id: 0, position: [.nan, 0, 0.05], placed: true}\n" + FLEET,
        ["brick 0: position", "finite"],
    ),
    "inf": (
        "bricks:\n  - {id: 0, position: [0, 0, 0.05], yaw: .inf, placed: true}\n" + FLEET,
        ["brick 0: yaw", "finite"],
    ),
    "zero-size": (
        "bricks:\n  - {id: 0, position: [0, 0, 0.05], size: [0.3, 0, 0.1], placed: true}\n" + FLEET,
        ["brick 0: size", "> 0"],
    ),
    "negative-default-size": (
        "brick: {size: [0.3, 0.15, -0.1]}\nbricks:\n" + BRICK0 + FLEET,
        ["brick.size", "> 0"],
    ),
    "zero-clearance": ("clearance: 0\nbricks:\n" + BRICK0 + FLEET, ["clearance", "> 0"]),
    "duplicate-id": (
        "bricks:\n" + BRICK0 + "  - {id: 0, position: [1, 0, 0.05], placed: true}\n" + FLEET,
        ["brick 0", "duplicate brick id"],
    ),
    "duplicate-uav": (
        "bricks:\n" + BRICK0 + "fleet:\n  - {name: b, role: brick, home: [0, 0, 0]}\n"
        "  - {name: b, role: adhesion, home: [1, 0, 0]}\n",
        ["'b'", "duplicate UAV name"],
    ),
    "interpenetrate": (
        "bricks:\n" + BRICK0 + "  - {id: 1, position: [0.1, 0.0, 0.05], placed: true}\n" + FLEET,
        ["brick 0", "interpenetrates brick 1"],
    ),
    "floating": (
        "bricks:\n" + BRICK0 + "  - {id: 1, position: [1.0, 0.0, 0.35], pickup: [3, 0, 0.05]}\n" + FLEET,
        ["brick 1", "neither on the ground nor resting"],
    ),
    "below-ground": (
        "bricks:\n  - {id: 0, position: [0, 0, -0.2], placed: true}\n" + FLEET,
        ["brick 0", "below the ground"],
    ),
    "placed-on-unplaced": (
        "bricks:\n  - {id: 0, position: [0, 0, 0.05], pickup: [3, 0, 0.05]}\n"
        "  - {id: 1, position: [0, 0, 0.15], placed: true}\n" + FLEET,
        ["brick 1", "placed but rests on brick 0"],
    ),
    "no-pickup": ("bricks:\n  - {id: 0, position: [0, 0, 0.05]}\n" + FLEET, ["brick 0", "pickup"]),
    "no-brick-uav": (
        (
            "bricks:\n  - {id: 0, position: [0, 0, 0.05], pickup: [3, 0, 0.05]}\n"
            "fleet:\n  - {name: g, role: adhesion, home: [0, 0, 0]}\n"
        ),
        ["fleet", "role `brick`"],
    ),
    "no-adhesion-uav": (
        "bricks:\n" + BRICK0 + "  - {id: 1, position: [0, 0, 0.15], pickup: [3, 0, 0.05]}\n"
        "fleet:\n  - {name: b, role: brick, home: [0, 0, 0]}\n",
        ["fleet", "role `adhesion`"],
    ),
    "unknown-role": (
        "bricks:\n" + BRICK0 + "fleet:\n  - {name: x, role: mortar, home: [0, 0, 0]}\n",
        ["fleet UAV 'x': role", "unknown role 'mortar'"],
    ),
    "thin-brick": (
        "bricks:\n  - {id: 0, position: [0, 0, 0.004], size: [0.3, 0.15, 0.008], placed: true}\n" + FLEET,
        ["brick 0: size", "must exceed 0.01 m"],
    ),
    "markers-do-not-fit": (
        "bricks:\n  - {id: 0, position: [0, 0, 0.05], size: [0.2, 0.1, 0.1], placed: true}\n" + FLEET,
        ["brick 0: size", "do not fit"],
    ),
    "bad-dictionary": (
        "brick: {markers: {dictionary: DICT_9X9_7}}\nbricks:\n" + BRICK0 + FLEET,
        ["brick.markers.dictionary", "unknown ArUco dictionary"],
    ),
}


@pytest.mark.parametrize("case", sorted(INVALID))
def test_every_validation_error_is_one_line_with_status_2(tmp_path: Path, case: str) -> None:
    text, fragments = INVALID[case]
    path = tmp_path / f"{case}.yaml"
    path.write_text(text)
    result = _invoke("plan", str(path))
    assert result.exit_code == 2, (result.stdout, result.stderr)
    assert result.stdout == ""
    err = result.stderr
    assert err.startswith(f"error: {path}") and err.count("\n") == 1, err
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment in err, (fragment, err)


def test_missing_file_and_directory(tmp_path: Path) -> None:
    for target in (tmp_path / "nope.yaml", tmp_path):
        result = _invoke("plan", str(target))
        assert result.exit_code == 2
        assert result.stderr.count("\n") == 1 and str(target) in result.stderr


def test_bad_format_option() -> None:
    result = _invoke("plan", str(PAPER), "--format", "xml")
    assert result.exit_code == 2 and "--format" in result.stderr
