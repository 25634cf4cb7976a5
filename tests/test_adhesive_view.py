"""Glue age where the operator sees it (issue 31): mission control's ``glue`` events, the live page's state and
``masonry replay --at`` show each bead waiting for its brick, its age and the open time left; the MCAP log keeps
the events."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from typer.testing import CliRunner

from masonry.adhesive import Adhesive
from masonry.blueprint import load_blueprint
from masonry.cli import app
from masonry.mission.events import EventList
from masonry.mission.simulate import simulate
from masonry.mission.view import view_at
from masonry.observe.web import static_file

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


def test_glue_events_give_each_beads_age_and_time_left() -> None:
    sink = EventList()
    r = simulate(
        dataclasses.replace(load_blueprint(CASE_STUDY), adhesive=Adhesive(open_time_s=60.0)),
        seed=0,
        events_sink=sink,
    )
    assert r.completed
    glue = [e for e in sink.events if e.kind == "glue"]
    done = {e.task_id: e.time_s for e in sink.events if e.kind == "completed"}  # (the last time)
    sprays = {(e.task_id, e.time_s) for e in sink.events if e.kind == "completed"}
    assert {e.task_id for e in glue} == {"A0", "A1"}
    for (
        e
    ) in glue:  # told when mission control heard the bead done (each spray), open for the blueprint's 60 s
        assert (e.task_id, e.fields["sprayed_s"]) in sprays and e.fields["sprayed_s"] <= e.time_s
        assert e.fields["open_until_s"] == e.fields["sprayed_s"] + 60.0
        assert e.fields["brick"] in ("B0", "B1") and "open until" in e.line()
    a0 = [e for e in glue if e.task_id == "A0"][-1]  # (its last spray: the one its brick goes on)
    brick = a0.fields["brick"]
    at = a0.time_s + 10.0
    assert at < done[brick]  # (the brick is not on it yet)
    view = view_at(sink.events, at, [t.id for t in r.tasks])
    state = view.snapshot()
    row = next(g for g in state["glue"] if g["bead"] == "A0")
    assert row["brick"] == brick
    assert row["age_s"] == round(at - a0.fields["sprayed_s"], 1)
    assert row["left_s"] == round(a0.fields["open_until_s"] - at, 1)
    assert any("glue waiting for its brick: " in line and "A0 under" in line for line in view.lines())
    after = view_at(sink.events, done[brick] + 0.1, [t.id for t in r.tasks]).snapshot()
    assert all(g["brick"] != brick for g in after["glue"])  # its brick is on it: no longer waiting


def test_without_an_adhesive_nothing_changes_on_the_page() -> None:
    sink = EventList()
    r = simulate(load_blueprint(CASE_STUDY), seed=0, events_sink=sink)
    assert not [e for e in sink.events if e.kind == "glue"]
    state = view_at(sink.events, r.makespan_s, [t.id for t in r.tasks]).snapshot()
    assert "glue" not in state
    assert b'id="glue"' in static_file("index.html") and b"drawGlue" in static_file("app.js")


def test_the_log_keeps_the_glue_events_and_replay_shows_them(tmp_path: Path) -> None:
    path = tmp_path / "glued.yaml"
    path.write_text(CASE_STUDY.read_text() + "adhesive: {open_time_s: 60}\n")
    log = tmp_path / "m.mcap"
    runner = CliRunner()
    out = runner.invoke(app, ["sim", str(path), "--seed", "0", "--log", str(log), "--no-progress"])
    assert out.exit_code == 0, out.output
    from masonry.observe.mcap_log import read_log

    events = read_log(log).events
    glue = [e for e in events if e.kind == "glue"]
    assert {e.task_id for e in glue} == {"A0", "A1"}
    at = glue[0].time_s + 1.0
    shown = runner.invoke(app, ["replay", str(log), "--at", f"{at:.1f}"])
    assert shown.exit_code == 0, shown.output
    assert f"{glue[0].task_id} under {glue[0].fields['brick']}" in shown.stdout, shown.stdout
