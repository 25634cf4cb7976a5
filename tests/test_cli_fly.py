"""``masonry fly`` and ``masonry fsm diagram`` through typer's CliRunner."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from masonry.cli import app

CASE_STUDY = str(Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml")
runner = CliRunner()


def _fly(*args: str):
    return runner.invoke(app, ["fly", "--sim", "--blueprint", CASE_STUDY, *args])


def test_fly_brick_json_is_exactly_the_documented_shape() -> None:
    res = _fly("--uav", "brick", "--task", "B0", "--seed", "2", "--format", "json")
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert list(out) == ["uav", "task", "status", "duration_s", "placement_error_m", "trace"]
    assert out["uav"] == "brick-1" and out["task"] == "B0" and out["status"] == "done"
    assert 0.0 < out["duration_s"] < 120.0
    assert 0.0 <= out["placement_error_m"] <= 0.03
    assert out["trace"][0] == {"t_s": 0.0, "state": "idle"}
    assert out["trace"][1]["state"] == "takeoff"
    assert "place_release" in [e["state"] for e in out["trace"]]
    times = [e["t_s"] for e in out["trace"]]
    assert times == sorted(times)


def test_fly_adhesion_json_reports_coverage() -> None:
    res = _fly("--uav", "adhesion", "--task", "A1", "--format", "json")
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert list(out) == ["uav", "task", "status", "duration_s", "placement_error_m", "coverage", "trace"]
    assert out["uav"] == "glue-1" and out["placement_error_m"] is None and out["coverage"] >= 0.95


def test_fly_text_prints_the_trace_and_the_result() -> None:
    res = _fly("--uav", "brick", "--task", "B1")
    assert res.exit_code == 0, res.output
    lines = res.stdout.splitlines()
    assert lines[0].startswith("brick-1 flies B1")
    assert any(line.strip().endswith("pickup_estimate") for line in lines)
    assert lines[-1].startswith("B1: done in") and "placement error" in lines[-1]


def test_fly_failed_task_reports_the_reason() -> None:
    res = _fly("--uav", "brick", "--task", "B0", "--fault", "grasp=1.0", "--format", "json")
    assert res.exit_code == 0
    out = json.loads(res.stdout)
    assert out["status"] == "failed" and "not attached" in out["reason"] and out["placement_error_m"] is None
    text = _fly("--uav", "brick", "--task", "B0", "--fault", "grasp=1.0")
    assert text.exit_code == 1 and "failed" in text.stdout.splitlines()[-1]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--uav", "brick", "--task", "B42"], "--task B42: no such task"),
        (["--uav", "brick", "--task", "A0"], "is an adhesion task"),
        (["--uav", "brick", "--task", "B2"], "already in place"),
        (["--uav", "drone", "--task", "B0"], "--uav must be brick or adhesion"),
        (["--uav", "brick", "--task", "B0", "--name", "nobody"], "--name nobody: no UAV"),
        (["--uav", "brick", "--task", "B0", "--name", "glue-1"], "glue-1 is an adhesion UAV"),
        (["--uav", "brick", "--task", "B0", "--camera", "lidar"], "--camera"),
        (["--uav", "brick", "--task", "B0", "--fault", "grasp=lots"], "grasp"),
    ],
)
def test_fly_bad_input_is_one_line_and_exit_2(args: list[str], message: str) -> None:
    res = _fly(*args)
    assert res.exit_code == 2, res.output
    assert message in res.stderr
    assert res.stderr.count("\n") == 1 and "Traceback" not in res.stderr


def test_fly_without_sim_needs_adapters() -> None:
    res = runner.invoke(app, ["fly", "--uav", "brick", "--blueprint", CASE_STUDY, "--task", "B0"])
    assert res.exit_code == 2 and "--sim" in res.stderr


def test_fly_unreadable_blueprint(tmp_path: Path) -> None:
    res = runner.invoke(
        app, ["fly", "--sim", "--uav", "brick", "--blueprint", str(tmp_path / "no.yaml"), "--task", "B0"]
    )
    assert res.exit_code == 2 and "no.yaml" in res.stderr


@pytest.mark.parametrize("kind", ["brick", "adhesion"])
@pytest.mark.parametrize("ext", ["svg", "png", "dot"])
def test_fsm_diagram_renders(tmp_path: Path, kind: str, ext: str) -> None:
    out = tmp_path / f"{kind}.{ext}"
    res = runner.invoke(app, ["fsm", "diagram", kind, "-o", str(out)])
    assert res.exit_code == 0, res.output  # with graphviz's dot, or the built-in layout without it
    data = out.read_bytes()
    if ext == "svg":
        text = data.decode()
        assert "<svg" in text and ("estimate" in text if kind == "brick" else "spray" in text)
    elif ext == "png":
        assert data[:8] == b"\x89PNG\r\n\x1a\n"
    else:
        text = data.decode()
        assert text.startswith("digraph") and ("pickup" in text if kind == "brick" else "spray" in text)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["rocket", "-o", "x.svg"], "unknown machine"),
        (["brick", "-o", "x.pdf"], "must end in .svg, .png or .dot"),
    ],
)
def test_fsm_diagram_bad_input(args: list[str], message: str) -> None:
    res = runner.invoke(app, ["fsm", "diagram", *args])
    assert res.exit_code == 2 and message in res.stderr
