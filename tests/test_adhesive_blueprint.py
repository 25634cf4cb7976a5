"""The blueprint's optional ``adhesive`` (issue 31): parsed, validated with one line naming the field, written
back, in the schema, and absent leaves the wall's digest as it was."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from masonry.adhesive import Adhesive
from masonry.blueprint import BlueprintError, format_blueprint, load_blueprint, parse_blueprint
from masonry.blueprint_gen import running_bond
from masonry.cli import app
from masonry.fingerprint import wall_digest
from masonry.schema import blueprint_schema

runner = CliRunner()
GOOD = (
    "name: glue\n"
    "bricks:\n"
    "  - {id: 0, position: [0.0, 0.0, 0.05], placed: true}\n"
    "  - {id: 1, position: [0.3, 0.0, 0.05], placed: true}\n"
    "  - {id: 2, position: [0.15, 0.0, 0.15], pickup: [0.0, -3.0, 0.05]}\n"
    "fleet:\n"
    "  - {name: brick-1, role: brick, home: [2.0, -4.0, 0.0]}\n"
    "  - {name: glue-1, role: adhesion, home: [-2.0, -4.0, 0.0]}\n"
)


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "wall.yaml"
    path.write_text(text)
    return path


def test_absent_adhesive_is_none_and_keeps_the_digest(tmp_path: Path) -> None:
    bp = load_blueprint(_write(tmp_path, GOOD))
    assert bp.adhesive is None
    assert "adhesive" not in format_blueprint(bp)
    glued = load_blueprint(_write(tmp_path, GOOD + "adhesive: {open_time_s: 300}\n"))
    assert wall_digest(glued) != wall_digest(bp)


def test_adhesive_is_parsed_and_written_back(tmp_path: Path) -> None:
    bp = load_blueprint(_write(tmp_path, GOOD + "adhesive: {open_time_s: 300, cure_time_s: 120}\n"))
    assert bp.adhesive == Adhesive(open_time_s=300.0, cure_time_s=120.0)
    again = load_blueprint(_write(tmp_path, format_blueprint(bp)))
    assert again.adhesive == bp.adhesive
    cure_only = load_blueprint(_write(tmp_path, GOOD + "adhesive: {cure_time_s: 60}\n"))
    assert cure_only.adhesive == Adhesive(open_time_s=None, cure_time_s=60.0)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("adhesive: 300\n", "adhesive: must be a mapping"),
        ("adhesive: {}\n", "adhesive: is empty"),
        ("adhesive: {open_time: 300}\n", "adhesive: unknown key 'open_time' (did you mean 'open_time_s'?)"),
        ("adhesive: {open_time_s: 0}\n", "adhesive.open_time_s: 0 s is outside (0, 86400] s"),
        ("adhesive: {open_time_s: -5}\n", "adhesive.open_time_s: -5 s is outside (0, 86400] s"),
        ("adhesive: {open_time_s: five}\n", "adhesive.open_time_s: must be a number"),
        ("adhesive: {cure_time_s: -1}\n", "adhesive.cure_time_s: -1 s is outside [0, 86400] s"),
        ("adhesive: {cure_time_s: 1.0e9}\n", "adhesive.cure_time_s: 1e+09 s is outside [0, 86400] s"),
        ("adhesive: {open_time_s: .nan}\n", "adhesive.open_time_s: must be a finite number"),
    ],
)
def test_a_bad_adhesive_is_one_line_naming_file_and_field_exit_2(
    tmp_path: Path, text: str, expected: str
) -> None:
    path = _write(tmp_path, GOOD + text)
    with pytest.raises(BlueprintError) as info:
        load_blueprint(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and expected in message and "\n" not in message, message
    result = runner.invoke(app, ["plan", str(path)])
    assert result.exit_code == 2, result.output
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and expected in lines[0], result.stderr


def test_schema_accepts_and_rejects_like_the_parser() -> None:
    jsonschema = pytest.importorskip("jsonschema")
    import yaml

    schema = blueprint_schema()
    jsonschema.validate(yaml.safe_load(GOOD + "adhesive: {open_time_s: 300, cure_time_s: 0}\n"), schema)
    for bad in ("adhesive: {}\n", "adhesive: {open_time_s: 0}\n", "adhesive: {cure_time_s: -1}\n"):
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate(yaml.safe_load(GOOD + bad), schema)


def test_generated_walls_carry_no_adhesive() -> None:
    bp = running_bond(2, 3, placed_courses=1)
    assert bp.adhesive is None
    assert parse_blueprint({**_data(bp), "adhesive": None}, "x").adhesive is None


def _data(bp: object) -> dict[str, object]:
    import yaml

    return dict(yaml.safe_load(format_blueprint(bp)))  # type: ignore[arg-type]
