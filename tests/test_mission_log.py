"""The mission log (``--log FILE.mcap``) and ``masonry replay``: the replay's outputs are the live run's, the log's
messages match their schemas, a bad file is one line and exit 2, and the event sink changes nothing."""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from mcap.reader import make_reader
from typer.testing import CliRunner

from foxglove_decode import decode
from masonry.blueprint import load_blueprint
from masonry.cli import app
from masonry.mission.events import KINDS, EventList, MissionEvent
from masonry.mission.report_codec import report_from_record, report_to_record
from masonry.mission.simulate import simulate
from masonry.mission.view import view_at
from masonry.observe.schemas import MASONRY

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"
runner = CliRunner()


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path | str]:
    """One `masonry sim --log` run with every output, and its stdout (text and JSON)."""
    d = tmp_path_factory.mktemp("live")
    out: dict[str, Path | str] = {"dir": d, "log": d / "run.mcap"}
    res = runner.invoke(
        app,
        [
            "sim",
            str(CASE_STUDY),
            "--log",
            str(d / "run.mcap"),
            "--format",
            "json",
            "--report",
            str(d / "report.json"),
            "--gantt",
            str(d / "gantt.png"),
            "--plot3d",
            str(d / "plot3d.png"),
            "--no-progress",
        ],
    )
    assert res.exit_code == 0, res.output
    out["json"] = res.stdout
    return out


def test_replay_writes_the_same_json_report_gantt_and_plot3d(live, tmp_path):
    res = runner.invoke(
        app,
        [
            "replay",
            str(live["log"]),
            "--format",
            "json",
            "--report",
            str(tmp_path / "report.json"),
            "--gantt",
            str(tmp_path / "gantt.png"),
            "--plot3d",
            str(tmp_path / "plot3d.png"),
        ],
    )
    assert res.exit_code == 0, res.output
    assert res.stdout == live["json"]  # the same bytes on stdout
    d = live["dir"]
    assert (tmp_path / "report.json").read_bytes() == (d / "report.json").read_bytes()
    # matplotlib's Agg PNG is deterministic for the same data: equal files are the same drawing
    assert (tmp_path / "gantt.png").read_bytes() == (d / "gantt.png").read_bytes()
    assert (tmp_path / "plot3d.png").read_bytes() == (d / "plot3d.png").read_bytes()


def test_replay_prints_the_same_text_summary(tmp_path):
    log = tmp_path / "a.mcap"
    live = runner.invoke(app, ["sim", str(CASE_STUDY), "--log", str(log), "--no-progress", "--seed", "3"])
    assert live.exit_code == 0, live.output
    again = runner.invoke(app, ["replay", str(log)])
    assert again.exit_code == 0, again.output
    assert again.stdout == live.stdout
    assert "mission completed: 4/4 tasks" in again.stdout


def test_replay_at_a_time_prints_the_mission_state_then(live):
    report = json.loads(str(live["json"]))
    b0 = next(t for t in report["tasks"] if t["id"] == "B0")
    mid = (b0["start_s"] + b0["end_s"]) / 2
    res = runner.invoke(app, ["replay", str(live["log"]), "--at", str(mid)])
    assert res.exit_code == 0, res.output
    lines = res.stdout.splitlines()
    assert lines[0].startswith(f"at {mid:.1f} s: mission running;")
    assert any(line.strip().startswith("running:") and "B0" in line for line in lines)
    brick = next(line for line in lines if line.strip().startswith("brick-1"))
    assert "task B0" in brick and "battery" in brick
    end = runner.invoke(app, ["replay", str(live["log"]), "--at", "1e6"])
    assert "mission completed; tasks: todo 0, running 0, done 4, stuck 0" in end.stdout
    start = runner.invoke(app, ["replay", str(live["log"]), "--at", "-1"])
    assert "tasks: todo 4, running 0, done 0" in start.stdout


def test_every_message_matches_its_schema_foxglove_ones_decoded_with_foxglove_definitions(live):
    """masonry's channels against their JSON schemas; Foxglove's decoded with the protobuf definitions the
    Foxglove SDK wrote into the file (its own, not the project's), each exactly one well-formed message."""
    import foxglove.messages as fm

    with open(live["log"], "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        by_name = {s.name: s for s in summary.schemas.values()}
        foxglove_names = {
            "foxglove.PoseInFrame",
            "foxglove.FrameTransform",
            "foxglove.SceneUpdate",
            "foxglove.Log",
        }
        assert foxglove_names | {
            "masonry.MissionEvent",
            "masonry.UavState",
            "masonry.Blueprint",
            "masonry.MissionReport",
        } == set(by_name)
        for name in foxglove_names:  # the SDK's own definitions, as it ships them
            sdk = getattr(fm, name.split(".", 1)[1]).get_schema()
            assert (by_name[name].encoding, by_name[name].data) == ("protobuf", bytes(sdk.data))
        assert all(s.encoding == "jsonschema" for n, s in by_name.items() if n.startswith("masonry."))
        assert "foxglove.SceneUpdate" not in MASONRY and all(n.startswith("masonry.") for n in MASONRY)
        topics = {c.topic for c in summary.channels.values()}
        assert {
            "/uav/brick-1/pose",
            "/uav/glue-1/state",
            "/wall",
            "/airspace",
            "/paths",
            "/tf",
            "/log",
        } <= topics
        validators = {
            sid: jsonschema.Draft7Validator(json.loads(s.data))
            for sid, s in summary.schemas.items()
            if s.encoding == "jsonschema"
        }
        n = 0
        kinds = set()
        decoded: dict[str, int] = {}
        seen: set[str] = set()
        last_ns = 0
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            if schema.encoding == "protobuf":
                assert channel.message_encoding == "protobuf" and schema.name.startswith("foxglove.")
                data = decode(schema.name, schema.data, message.data)
                decoded[schema.name] = decoded.get(schema.name, 0) + 1
                if channel.topic == "/wall" and "/wall" not in seen:  # the whole wall first
                    assert len(data["entities"]) == 8 and data["entities"][0]["frame_id"] == "world"
                seen.add(channel.topic)
            else:
                assert channel.message_encoding == "json"
                data = json.loads(message.data)
                errors = list(validators[schema.id].iter_errors(data))
                assert not errors, f"{channel.topic}: {errors[0].message}"
            if channel.topic == "/mission/events":
                kinds.add(data["kind"])
            assert message.log_time >= last_ns
            last_ns = message.log_time
            n += 1
    assert n > 100 and set(decoded) == foxglove_names and min(decoded.values()) >= 2
    assert {"start", "assigned", "completed", "clearance", "uav", "end"} <= kinds <= set(KINDS)


def test_a_foxglove_message_check_fails_on_a_wrong_message():
    import foxglove.messages as fm

    pose = fm.PoseInFrame.get_schema()
    log_line = fm.Log(message="not a pose", name="x").encode()
    with pytest.raises(AssertionError, match="not a well-formed"):
        decode(pose.name, pose.data, log_line + b"\xff")


def test_a_schema_check_fails_on_a_bad_message():
    v = jsonschema.Draft7Validator(MASONRY["masonry.UavState"])
    assert list(v.iter_errors({"timestamp": {"sec": -1, "nsec": 0}, "uav": 3}))


def test_replay_reads_a_log_written_before_the_foxglove_sdk(tmp_path):
    """A log whose Foxglove topics are JSON (written by masonry before this change, kept in tests/data): the
    report, its drawings, and its state at a time still come back."""
    old = ROOT / "tests" / "data" / "old_format_case_study.mcap"
    with open(old, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and {s.encoding for s in summary.schemas.values()} == {"jsonschema"}
    res = runner.invoke(app, ["replay", str(old), "--format", "json", "--gantt", str(tmp_path / "g.png")])
    assert res.exit_code == 0, res.output
    report = json.loads(res.stdout)
    # the run that wrote it: masonry sim blueprints/paper_case_study.yaml --seed 3 --log ...
    assert report["completed"] is True and report["makespan_s"] == 87.3 and report["seed"] == 3
    assert [t["status"] for t in report["tasks"]] == ["done"] * 4
    assert (tmp_path / "g.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    at = runner.invoke(app, ["replay", str(old), "--at", "1e6"])
    assert "mission completed; tasks: todo 0, running 0, done 4, stuck 0" in at.stdout, at.output


@pytest.mark.parametrize(
    ("content", "what"),
    [
        (None, "cannot read it"),
        (b"name: not a log\n", "not a readable MCAP file"),
        ("cut", "not a readable MCAP file"),
        ("foreign", "not a masonry mission log"),
    ],
)
def test_a_bad_log_is_one_line_naming_the_file_and_exit_2(live, tmp_path, content, what):
    bad = tmp_path / "bad.mcap"
    if content == "cut":
        bad.write_bytes(Path(live["log"]).read_bytes()[:5000])
    elif content == "foreign":
        from mcap.writer import Writer

        with open(bad, "wb") as f:
            w = Writer(f)
            w.start()
            ch = w.register_channel("/chatter", "json", 0)
            w.add_message(ch, 0, b"{}", 0)
            w.finish()
    elif content is not None:
        bad.write_bytes(content)
    res = runner.invoke(app, ["replay", str(bad)])
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1, res.output
    assert str(bad) in lines[0] and what in lines[0]


def test_the_report_record_reads_back_equal():
    bp = load_blueprint(CASE_STUDY)
    r = simulate(bp, seed=1)
    back = report_from_record(json.loads(json.dumps(report_to_record(r))))
    assert back.to_dict() == r.to_dict() and back.summary() == r.summary()
    assert back.attempts == r.attempts and back.tasks == r.tasks and back.uavs == r.uavs
    assert sorted(back.paths_m) == sorted(r.paths_m)
    assert all(np.array_equal(back.paths_m[k], np.asarray(r.paths_m[k])) for k in r.paths_m)
    # every field, whichever bound won and with a schedule followed (mission-control's log replayed the bound's
    # kind as the default "role" before)
    import dataclasses

    other = dataclasses.replace(r, lower_bound_kind="cp-sat", schedule_followed=3, schedule_assignments=4)
    again = report_from_record(json.loads(json.dumps(report_to_record(other))))
    assert [getattr(again, f.name) for f in dataclasses.fields(again) if f.name != "paths_m"] == [
        getattr(other, f.name) for f in dataclasses.fields(other) if f.name != "paths_m"
    ]
    assert again.to_json() == other.to_json()


def test_the_event_sink_only_watches_and_sees_every_assignment_and_completion():
    bp = load_blueprint(CASE_STUDY)
    sink = EventList()
    with_sink = simulate(bp, seed=2, events_sink=sink)
    without = simulate(bp, seed=2)
    assert with_sink.to_dict() == without.to_dict()
    assert with_sink.attempts == without.attempts
    ev = sink.events
    assert [e.time_s for e in ev] == sorted(e.time_s for e in ev)
    assigned = [(e.task_id, e.uav, e.fields["attempt"]) for e in ev if e.kind == "assigned"]
    assert assigned == [(a.task_id, a.uav, a.attempt) for a in with_sink.attempts]
    done = sorted(e.task_id for e in ev if e.kind == "completed")
    assert done == sorted(t.id for t in with_sink.tasks if t.status == "done")
    assert ev[-1].kind in ("uav", "end") and any(e.kind == "end" and e.fields["completed"] for e in ev)
    # each UAV's pose and battery sampled from the world, every SAMPLE_PERIOD_S at least
    samples = [e for e in ev if e.kind == "uav" and e.uav == "brick-1" and e.fields["battery"] is not None]
    assert len(samples) >= with_sink.makespan_s / 0.5
    assert all(0.0 < e.fields["battery"] <= 1.0 for e in samples)
    # the view folded from them ends where the report does
    view = view_at(ev, 1e9, [t.id for t in with_sink.tasks])
    assert view.counts()["done"] == 4 and view.completed is True
    assert [(b["task_id"], b["status"]) for b in view.bars] == [
        (a.task_id, a.status) for a in with_sink.attempts
    ]


def test_an_event_reads_back_and_a_bad_one_is_refused():
    e = MissionEvent(1.5, "failed", "brick-1", "B0", {"reason": "grasp"})
    assert MissionEvent.from_dict(json.loads(json.dumps(e.to_dict()))) == e
    assert "failed brick-1 B0: grasp" in e.line()
    from masonry.errors import MissionError

    for bad in (
        {"time_s": "x", "kind": "uav"},
        {"time_s": 1.0, "kind": "nope"},
        [],
        {"time_s": 1.0, "kind": "uav", "uav": 3},
    ):
        with pytest.raises(MissionError):
            MissionEvent.from_dict(bad)


def test_a_resumed_missions_log_starts_with_the_tasks_done_before(tmp_path):
    journal, log = tmp_path / "j.db", tmp_path / "r.mcap"
    first = runner.invoke(app, ["sim", str(CASE_STUDY), "--journal", str(journal), "--no-progress"])
    assert first.exit_code == 0, first.output
    again = runner.invoke(
        app,
        ["sim", str(CASE_STUDY), "--journal", str(journal), "--resume", "--log", str(log), "--no-progress"],
    )
    assert again.exit_code == 0, again.output
    at = runner.invoke(app, ["replay", str(log), "--at", "0"])
    assert "tasks: todo 0, running 0, done 4, stuck 0" in at.stdout, at.stdout
    with open(log, "rb") as f:
        schema, _, message = next(iter(make_reader(f).iter_messages(topics=["/wall"])))
        first_wall = decode(schema.name, schema.data, message.data)
    from masonry.observe.mcap_log import COLOURS

    done = dict(zip("rgba", (pytest.approx(c) for c in COLOURS["done"])))
    sprayed = dict(zip("rgba", (pytest.approx(c) for c in COLOURS["adhesion_done"])))
    assert len(first_wall["entities"]) == 8  # 4 placed beforehand, 4 done by the first run
    for e in first_wall["entities"]:
        colour = (e.get("cubes") or e.get("lines"))[0]["color"]
        assert colour == (done if e["cubes"] else sprayed), e["id"]


def test_the_docs_foxglove_layout_is_the_sdks_and_names_the_logs_topics(live):
    """docs/foxglove_layout.json is what ``masonry.observe.layout`` builds with the SDK's layout types, and every
    topic it names for the case study's UAVs is one the log writes."""
    import re

    from masonry.observe.layout import foxglove_layout

    text = (ROOT / "docs" / "foxglove_layout.json").read_text(encoding="utf-8")
    assert json.loads(text) == json.loads(foxglove_layout())
    with open(live["log"], "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    written = {c.topic for c in summary.channels.values()}
    named = set(re.findall(r'"(/[a-z/0-9-]+?)(?:\.[a-z_]+)?"', text))
    case_study = {t for t in named if not re.search(r"brick-2|glue-2", t)}
    assert {"/wall", "/airspace", "/paths", "/log", "/mission/events", "/uav/brick-1/state"} <= case_study
    assert case_study <= written, case_study - written
