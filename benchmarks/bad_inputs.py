"""A bad-input campaign: hundreds of broken files, options, journals and endpoints, fed to the real CLI.

Every case runs ``masonry ...`` in a subprocess (a fresh interpreter, as a user runs it) with a memory limit
and a time limit, and is classified:

- ``clean``: exit status 2 and exactly one line on stderr, starting with ``error:``, at most
  ``MAX_LINE_CHARS`` long, no traceback;
- ``traceback``: a Python traceback anywhere in the output;
- ``hang``: still running after the time limit (killed);
- ``accepted``: exit status 0 (the nonsense went through);
- ``other``: any other exit status, several lines, or a line too long.

Usage::

    python benchmarks/bad_inputs.py                 # every case, a table by category, the failures listed
    python benchmarks/bad_inputs.py --only blueprint --json out.json

docs/reliability.md gives the figures; tests/test_bad_inputs.py runs a sample of the same cases in CI.
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import resource
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"
MAX_LINE_CHARS = 400
TIME_LIMIT_S = 40.0
MEMORY_LIMIT_BYTES = 6 * 1024**3

#: the paper's case study as values, the base every broken blueprint is made from
BASE: dict[str, Any] = {
    "name": "bad-input",
    "clearance": 1.5,
    "cruise_altitude": 1.2,
    "brick": {
        "size": [0.30, 0.15, 0.10],
        "markers": {"dictionary": "DICT_4X4_50", "size": 0.05, "spacing": 0.175},
    },
    "bricks": [
        {"id": 2, "position": [0.0, -0.5, 0.05], "placed": True},
        {"id": 3, "position": [0.0, -0.5, 0.15], "placed": True},
        {"id": 4, "position": [0.0, 0.5, 0.05], "placed": True},
        {"id": 5, "position": [0.0, 0.5, 0.15], "placed": True},
        {"id": 0, "position": [0.0, -0.5, 0.25], "pickup": [3.0, -0.5, 0.05]},
        {"id": 1, "position": [0.0, 0.5, 0.25], "pickup": [3.0, 0.5, 0.05]},
    ],
    "fleet": [
        {"name": "brick-1", "role": "brick", "home": [2.0, -2.5, 0.0]},
        {"name": "glue-1", "role": "adhesion", "home": [0.0, -2.5, 0.0]},
    ],
}


@dataclass(frozen=True)
class Case:
    """One bad input: the command line (``{d}`` is the case's folder, ``{bp}`` the blueprint under test)."""

    category: str
    name: str
    argv: tuple[str, ...]
    setup: Callable[[Path], None] = lambda d: None
    #: environment additions for the subprocess
    env: tuple[tuple[str, str], ...] = ()


@dataclass
class Outcome:
    case: Case
    kind: str
    status: int | None
    seconds: float
    first_line: str
    lines: int = 0
    extra: dict[str, Any] = field(default_factory=dict)


# ------------------------------------------------------------------------------------------ blueprints


def _with(mutate: Callable[[dict[str, Any]], None]) -> dict[str, Any]:
    data = copy.deepcopy(BASE)
    mutate(data)
    return data


def _set(path: str, value: Any) -> Callable[[dict[str, Any]], None]:
    """A mutation that sets ``path`` ("bricks.4.position", "fleet.0.home.2") to ``value``."""

    def mutate(data: dict[str, Any]) -> None:
        keys = path.split(".")
        node: Any = data
        for k in keys[:-1]:
            node = node[int(k)] if isinstance(node, list) else node[k]
        last = keys[-1]
        if isinstance(node, list):
            node[int(last)] = value
        else:
            node[last] = value

    return mutate


def _delete(path: str) -> Callable[[dict[str, Any]], None]:
    def mutate(data: dict[str, Any]) -> None:
        keys = path.split(".")
        node: Any = data
        for k in keys[:-1]:
            node = node[int(k)] if isinstance(node, list) else node[k]
        del node[keys[-1]]

    return mutate


def _append(path: str, value: Any) -> Callable[[dict[str, Any]], None]:
    def mutate(data: dict[str, Any]) -> None:
        node: Any = data
        for k in path.split("."):
            node = node[int(k)] if isinstance(node, list) else node[k]
        node.append(value)

    return mutate


def _json_bytes(data: Any) -> bytes:
    # allow_nan: JSON itself has no NaN/Infinity, but Python's reader takes them: a user's tool may write them
    return json.dumps(data, allow_nan=True).encode()


CASE_STUDY_TEXT = CASE_STUDY.read_text()
BOMB = (
    "a: &a [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]\n"
    + "".join(
        f"{chr(98 + i)}: &{chr(98 + i)} [*{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, "
        f"*{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}]\n"
        for i in range(8)
    )
    + CASE_STUDY_TEXT.replace("position: [0.0, -0.5, 0.25]", "position: *i")
)

#: (name, file content) for broken files; .json for value-level breakage, .yaml for text-level
BLUEPRINT_FILES: list[tuple[str, str, bytes]] = [
    # text-level: what a YAML reader meets
    ("empty file", "bp.yaml", b""),
    ("only a comment", "bp.yaml", b"# nothing here\n"),
    ("a YAML list, not a mapping", "bp.yaml", b"- 1\n- 2\n"),
    ("a scalar", "bp.yaml", b"42\n"),
    ("YAML syntax error", "bp.yaml", b"bricks: [\n  {id: 0, position: [0, 0, 0.05}\n"),
    ("tab indentation", "bp.yaml", CASE_STUDY_TEXT.replace("  - {id: 2", "\t- {id: 2").encode()),
    ("binary garbage", "bp.yaml", bytes(range(256)) * 8),
    ("not UTF-8", "bp.yaml", CASE_STUDY_TEXT.replace("paper-case-study", "caf\xe9").encode("latin-1")),
    ("a NUL byte", "bp.yaml", CASE_STUDY_TEXT.encode()[:200] + b"\x00" + CASE_STUDY_TEXT.encode()[200:]),
    ("billion laughs in a position", "bp.yaml", BOMB.encode()),
    (
        "duplicate top-level key",
        "bp.yaml",
        CASE_STUDY_TEXT.replace("clearance: 1.5", "clearance: 1.5\nclearance: 0.001").encode(),
    ),
    (
        "duplicate key in a brick",
        "bp.yaml",
        CASE_STUDY_TEXT.replace("{id: 0, position:", "{id: 0, id: 7, position:").encode(),
    ),
    (
        "a YAML python tag",
        "bp.yaml",
        CASE_STUDY_TEXT.replace(
            "clearance: 1.5", "clearance: !!python/object/apply:os.system ['true']"
        ).encode(),
    ),
    (
        "a YAML timestamp as clearance",
        "bp.yaml",
        CASE_STUDY_TEXT.replace("clearance: 1.5", "clearance: 2001-12-14").encode(),
    ),
    (
        "deep nesting",
        "bp.yaml",
        CASE_STUDY_TEXT.replace("name: paper-case-study", "name: " + "[" * 5000 + "]" * 5000).encode(),
    ),
    (
        "200,000-element position",
        "bp.yaml",
        CASE_STUDY_TEXT.replace(
            "position: [0.0, -0.5, 0.25]", "position: [" + ", ".join(["0.5"] * 200_000) + "]"
        ).encode(),
    ),
    (
        "a 100 kB name",
        "bp.yaml",
        CASE_STUDY_TEXT.replace("name: paper-case-study", "name: [" + "x" * 100_000 + "]").encode(),
    ),
    ("truncated JSON", "bp.json", _json_bytes(BASE)[:-40]),
    ("JSON with NaN clearance", "bp.json", _json_bytes(_with(_set("clearance", float("nan"))))),
    (
        "JSON with infinite position",
        "bp.json",
        _json_bytes(_with(_set("bricks.4.position", [float("inf"), 0, 0.25]))),
    ),
]

#: (name, mutation of BASE) for value-level breakage, written as JSON
BLUEPRINT_VALUES: list[tuple[str, Callable[[dict[str, Any]], None]]] = [
    ("no bricks key", _delete("bricks")),
    ("no fleet key", _delete("fleet")),
    ("empty bricks", _set("bricks", [])),
    ("empty fleet", _set("fleet", [])),
    ("bricks is a mapping", _set("bricks", {"a": 1})),
    ("unknown top-level key", _set("clearence", 1.5)),
    ("clearance zero", _set("clearance", 0)),
    ("clearance negative", _set("clearance", -1.5)),
    ("clearance a string", _set("clearance", "wide")),
    ("clearance a list", _set("clearance", [1.5])),
    ("clearance a bool", _set("clearance", True)),
    ("clearance absurdly large", _set("clearance", 1e9)),
    ("cruise altitude zero", _set("cruise_altitude", 0)),
    ("cruise altitude negative", _set("cruise_altitude", -2)),
    ("cruise altitude below the wall top", _set("cruise_altitude", 0.2)),
    ("cruise altitude 1e6 m", _set("cruise_altitude", 1e6)),
    ("brick size negative", _set("brick.size", [-0.3, 0.15, 0.1])),
    ("brick size two numbers", _set("brick.size", [0.3, 0.15])),
    ("brick size zero height", _set("brick.size", [0.3, 0.15, 0.0])),
    ("marker dictionary unknown", _set("brick.markers.dictionary", "DICT_9X9_7")),
    ("marker size negative", _set("brick.markers.size", -0.05)),
    ("marker larger than the brick", _set("brick.markers.size", 0.5)),
    ("marker spacing zero", _set("brick.markers.spacing", 0)),
    ("unknown marker key", _set("brick.markers.colour", "red")),
    ("brick id negative", _set("bricks.4.id", -1)),
    ("brick id a float", _set("bricks.4.id", 0.5)),
    ("brick id a string", _set("bricks.4.id", "zero")),
    ("brick id 10**26", _set("bricks.4.id", 10**26)),
    ("brick id beyond the dictionary", _set("bricks.4.id", 40)),
    ("brick ids duplicated", _set("bricks.5.id", 0)),
    ("brick without id", _delete("bricks.4.id")),
    ("brick without position", _delete("bricks.4.position")),
    ("position two numbers", _set("bricks.4.position", [0.0, -0.5])),
    ("position strings", _set("bricks.4.position", ["a", "b", "c"])),
    ("position null", _set("bricks.4.position", None)),
    ("position 1e300", _set("bricks.4.position", [1e300, -0.5, 0.25])),
    ("position far away (1e7 m)", _set("bricks.4.position", [1e7, -0.5, 0.25])),
    ("brick under the ground", _set("bricks.0.position", [0.0, -0.5, -0.05])),
    ("brick floating in the air", _set("bricks.4.position", [0.0, -0.5, 0.55])),
    ("bricks overlapping", _set("bricks.5.position", [0.0, 0.5, 0.12])),
    ("brick on a 1 mm overlap", _set("bricks.4.position", [0.299, -0.5, 0.25])),
    ("yaw NaN", _set("bricks.4.yaw", float("nan"))),
    ("yaw a string", _set("bricks.4.yaw", "north")),
    ("placed a string", _set("bricks.4.placed", "yes")),
    ("unknown brick key", _set("bricks.4.colour", "red")),
    ("per-brick size negative", _set("bricks.4.size", [0.3, -0.15, 0.1])),
    ("pickup inside the wall", _set("bricks.4.pickup", [0.0, 0.5, 0.05])),
    ("two bricks share a pickup", _set("bricks.5.pickup", [3.0, -0.5, 0.05])),
    ("pickup under the ground", _set("bricks.4.pickup", [3.0, -0.5, -1.0])),
    ("pickup 500 m up", _set("bricks.4.pickup", [3.0, -0.5, 500.0])),
    ("pickup two numbers", _set("bricks.4.pickup", [3.0, -0.5])),
    ("UAV name with *", _set("fleet.0.name", "brick-*")),
    ("UAV name with $", _set("fleet.0.name", "brick$1")),
    ("UAV name with /", _set("fleet.0.name", "brick/1")),
    ("UAV name with #", _set("fleet.0.name", "brick#1")),
    ("UAV name with ?", _set("fleet.0.name", "brick?")),
    ("UAV name empty", _set("fleet.0.name", "")),
    ("UAV name mission-control", _set("fleet.0.name", "mission-control")),
    ("UAV names duplicated", _set("fleet.1.name", "brick-1")),
    ("UAV role unknown", _set("fleet.1.role", "painter")),
    ("UAV without home", _delete("fleet.0.home")),
    ("UAV home under the ground", _set("fleet.0.home", [2.0, -2.5, -1.0])),
    ("UAV home 300 m up", _set("fleet.0.home", [2.0, -2.5, 300.0])),
    ("two UAVs on one home", _set("fleet.1.home", [2.0, -2.5, 0.0])),
    ("UAV home inside the wall", _set("fleet.0.home", [0.0, -0.5, 0.0])),
    ("no brick UAV", _set("fleet", [{"name": "glue-1", "role": "adhesion", "home": [0.0, -2.5, 0.0]}])),
    ("no adhesion UAV", _set("fleet", [{"name": "brick-1", "role": "brick", "home": [2.0, -2.5, 0.0]}])),
    ("unknown UAV key", _set("fleet.0.speed", 3)),
    ("fleet entry a string", _set("fleet.0", "brick-1")),
    ("a brick entry a number", _set("bricks.0", 7)),
]


def _write(name: str, content: bytes) -> Callable[[Path], None]:
    def setup(d: Path) -> None:
        (d / name).write_bytes(content)

    return setup


def _blueprint_cases() -> list[Case]:
    files: list[tuple[str, str, Callable[[Path], None]]] = []
    for name, fname, content in BLUEPRINT_FILES:
        files.append((name, fname, _write(fname, content)))
    for name, mutate in BLUEPRINT_VALUES:
        files.append((name, "bp.json", _write("bp.json", _json_bytes(_with(mutate)))))

    def sparse(d: Path) -> None:
        with open(d / "bp.yaml", "wb") as fh:
            fh.truncate(100 * 1024**2)

    def fifo(d: Path) -> None:
        os.mkfifo(d / "bp.yaml")

    def directory(d: Path) -> None:
        (d / "bp.yaml").mkdir()

    def unreadable(d: Path) -> None:
        (d / "bp.yaml").write_text(CASE_STUDY_TEXT)
        (d / "bp.yaml").chmod(0)

    files += [
        ("a 100 MB file", "bp.yaml", sparse),
        ("a FIFO", "bp.yaml", fifo),
        ("a directory", "bp.yaml", directory),
        ("no such file", "missing.yaml", lambda d: None),
        ("/dev/zero", "/dev/zero", lambda d: None),
    ]
    if os.geteuid() != 0:  # root reads a mode-0 file anyway
        files.append(("unreadable file", "bp.yaml", unreadable))
    cases: list[Case] = []
    for name, fname, setup in files:
        path = fname if fname.startswith("/") else "{d}/" + fname
        cases.append(Case("blueprint/plan", name, ("plan", path), setup))
        cases.append(Case("blueprint/sim", name, ("sim", path), setup))
        cases.append(
            Case(
                "blueprint/fly",
                name,
                ("fly", "--uav", "brick", "--sim", "--blueprint", path, "--task", "B0"),
                setup,
            )
        )
    return cases


# ------------------------------------------------------------------------------------------ options


def _option_cases() -> list[Case]:
    cs = str(CASE_STUDY)
    sim = ("sim", cs)
    fly = ("fly", "--uav", "brick", "--sim", "--blueprint", cs, "--task", "B0")
    gen = ("blueprint", "running-bond")
    rows: list[tuple[str, tuple[str, ...]]] = [
        ("sim --dt 1e-6", (*sim, "--dt", "1e-6")),
        ("sim --dt 0", (*sim, "--dt", "0")),
        ("sim --dt -1", (*sim, "--dt", "-1")),
        ("sim --dt nan", (*sim, "--dt", "nan")),
        ("sim --dt 100", (*sim, "--dt", "100")),
        ("sim --brick-uavs 100000", (*sim, "--brick-uavs", "100000")),
        ("sim --brick-uavs -1", (*sim, "--brick-uavs", "-1")),
        ("sim --brick-uavs 0", (*sim, "--brick-uavs", "0")),
        ("sim --adhesion-uavs 0", (*sim, "--adhesion-uavs", "0")),
        ("sim --brick-uavs x", (*sim, "--brick-uavs", "x")),
        ("sim --policy magic", (*sim, "--policy", "magic")),
        ("sim --format xml", (*sim, "--format", "xml")),
        ("sim --camera sketch", (*sim, "--camera", "sketch")),
        ("sim --fault gusts=1e6", (*sim, "--fault", "gusts=1e6")),
        ("sim --fault grasp=2", (*sim, "--fault", "grasp=2")),
        ("sim --fault grasp=-0.1", (*sim, "--fault", "grasp=-0.1")),
        ("sim --fault grasp=nan", (*sim, "--fault", "grasp=nan")),
        ("sim --fault bogus=1", (*sim, "--fault", "bogus=1")),
        ("sim --fault grasp", (*sim, "--fault", "grasp")),
        ("sim --fault =0.3", (*sim, "--fault", "=0.3")),
        ("sim --fault uav-loss=nobody@10", (*sim, "--fault", "uav-loss=nobody@10")),
        ("sim --seed -1", (*sim, "--seed", "-1")),
        ("sim --resume without --journal", (*sim, "--resume")),
        ("sim --gantt with a .txt extension", (*sim, "--gantt", "{d}/chart.txt")),
        ("fly --dt 0", (*fly, "--dt", "0")),
        ("fly --dt 1e-6", (*fly, "--dt", "1e-6")),
        ("fly --timeout -1", (*fly, "--timeout", "-1")),
        ("fly --uav painter", ("fly", "--uav", "painter", "--sim", "--blueprint", cs, "--task", "B0")),
        ("fly --task B99", ("fly", "--uav", "brick", "--sim", "--blueprint", cs, "--task", "B99")),
        (
            "fly adhesion UAV on a brick task",
            ("fly", "--uav", "adhesion", "--sim", "--blueprint", cs, "--task", "B0"),
        ),
        ("fly --name nobody", (*fly, "--name", "nobody")),
        ("fly --fault grasp=5", (*fly, "--fault", "grasp=5")),
        (
            "fly --wait -1 (mission)",
            (
                "fly",
                "--uav",
                "brick",
                "--sim",
                "--blueprint",
                cs,
                "--mission",
                "tcp/127.0.0.1:1",
                "--wait",
                "-1",
            ),
        ),
        (
            "fly --time-scale 0 (mission)",
            (
                "fly",
                "--uav",
                "brick",
                "--sim",
                "--blueprint",
                cs,
                "--mission",
                "tcp/127.0.0.1:1",
                "--time-scale",
                "0",
            ),
        ),
        (
            "fly --mission not-an-endpoint",
            ("fly", "--uav", "brick", "--sim", "--blueprint", cs, "--mission", "nowhere"),
        ),
        (
            "fly --mission port 99999",
            ("fly", "--uav", "brick", "--sim", "--blueprint", cs, "--mission", "tcp/127.0.0.1:99999"),
        ),
        (
            "blueprint --placed-courses > --courses",
            (*gen, "--courses", "2", "--placed-courses", "3", "-o", "{d}/w.yaml"),
        ),
        ("blueprint --courses 0", (*gen, "--courses", "0", "-o", "{d}/w.yaml")),
        ("blueprint --courses -3", (*gen, "--courses", "-3", "-o", "{d}/w.yaml")),
        ("blueprint --bricks-per-course 0", (*gen, "--bricks-per-course", "0", "-o", "{d}/w.yaml")),
        (
            "blueprint --bricks-per-course 10**9",
            (*gen, "--bricks-per-course", "1000000000", "-o", "{d}/w.yaml"),
        ),
        (
            "blueprint --brick-size negative",
            (*gen, "--brick-size", "-0.3", "0.15", "0.1", "-o", "{d}/w.yaml"),
        ),
        ("plan --format xml", ("plan", cs, "--format", "xml")),
        ("plan --graph .bmp", ("plan", cs, "--graph", "{d}/g.bmp")),
        ("mission-control --tick 0", ("mission-control", cs, "--tick", "0")),
        ("mission-control --time-scale -1", ("mission-control", cs, "--time-scale", "-1")),
        ("mission-control --policy magic", ("mission-control", cs, "--policy", "magic")),
        ("mission-control --listen nonsense", ("mission-control", cs, "--listen", "nonsense")),
        ("mission-control --heartbeat-timeout -5", ("mission-control", cs, "--heartbeat-timeout", "-5")),
        ("markers --bricks 5-2", ("markers", "--bricks", "5-2", "-o", "{d}/m.pdf")),
        ("markers --bricks abc", ("markers", "--bricks", "abc", "-o", "{d}/m.pdf")),
        ("fsm diagram painter", ("fsm", "diagram", "painter", "-o", "{d}/x.svg")),
    ]
    return [Case("options", name, argv) for name, argv in rows]


# ------------------------------------------------------------------------------------------ outputs


def _output_cases() -> list[Case]:
    cs = str(CASE_STUDY)
    rows: list[tuple[str, tuple[str, ...], Callable[[Path], None]]] = [
        ("sim --report into a missing folder", ("sim", cs, "--report", "{d}/no/such/r.json"), lambda d: None),
        ("sim --gantt into a missing folder", ("sim", cs, "--gantt", "{d}/no/such/g.png"), lambda d: None),
        ("sim --plot3d into a missing folder", ("sim", cs, "--plot3d", "{d}/no/such/p.png"), lambda d: None),
        ("sim --report is a folder", ("sim", cs, "--report", "{d}/out"), lambda d: (d / "out").mkdir()),
        ("sim --journal into a missing folder", ("sim", cs, "--journal", "{d}/no/such/j.db"), lambda d: None),
        ("plan -o into a missing folder", ("plan", cs, "-o", "{d}/no/such/p.txt"), lambda d: None),
        ("plan --graph into a missing folder", ("plan", cs, "--graph", "{d}/no/such/g.svg"), lambda d: None),
        (
            "blueprint -o into a missing folder",
            ("blueprint", "running-bond", "-o", "{d}/no/such/w.yaml"),
            lambda d: None,
        ),
        (
            "markers -o into a missing folder",
            ("markers", "--bricks", "0-1", "-o", "{d}/no/such/m.pdf"),
            lambda d: None,
        ),
        (
            "fsm diagram -o into a missing folder",
            ("fsm", "diagram", "brick", "-o", "{d}/no/such/b.dot"),
            lambda d: None,
        ),
        (
            "mission-control --report into a missing folder",
            ("mission-control", cs, "--report", "{d}/no/such/r.json", "--max-time", "0.1"),
            lambda d: None,
        ),
    ]
    return [Case("outputs", name, argv, setup) for name, argv, setup in rows]


# ------------------------------------------------------------------------------------------ journals


def _journal_cases() -> list[Case]:
    cs = str(CASE_STUDY)
    small = str(ROOT / "blueprints" / "running_bond_small.yaml")

    def journal_of(blueprint: str, d: Path) -> None:
        """A journal in ``d`` written by a whole ``masonry sim`` of ``blueprint``."""
        subprocess.run(
            [*_masonry(), "sim", blueprint, "--journal", str(d / "j.db")],
            capture_output=True,
            timeout=300,
            check=False,
        )

    def edited(old: str, new: str) -> Callable[[Path], None]:
        """A journal of the case study with ``old`` replaced by ``new`` in its text."""

        def setup(d: Path) -> None:
            (d / "edited.yaml").write_text(CASE_STUDY_TEXT.replace(old, new))
            journal_of(str(d / "edited.yaml"), d)

        return setup

    def other_wall(d: Path) -> None:
        journal_of(small, d)

    same_ids_other_geometry = edited("pickup: [3.0, -0.5, 0.05]", "pickup: [3.5, -0.5, 0.05]")
    other_fleet = edited("name: glue-1", "name: glue-9")

    def finished(d: Path) -> None:
        journal_of(cs, d)

    def corrupt(d: Path) -> None:
        (d / "j.db").write_bytes(b"SQLite format 3\x00" + os.urandom(4096))

    def garbage(d: Path) -> None:
        (d / "j.db").write_bytes(os.urandom(8192))

    def foreign_db(d: Path) -> None:
        con = sqlite3.connect(d / "j.db")
        con.execute("create table invoices (id integer primary key, amount real)")
        con.execute("insert into invoices values (1, 9.5)")
        con.commit()
        con.close()

    def read_only(d: Path) -> None:
        finished(d)
        (d / "j.db").chmod(0o444)
        (d).chmod(0o555)

    rows: list[tuple[str, tuple[str, ...], Callable[[Path], None]]] = [
        ("resume a journal of another wall", ("sim", cs, "--journal", "{d}/j.db", "--resume"), other_wall),
        (
            "resume a journal of the same ids, other geometry",
            ("sim", cs, "--journal", "{d}/j.db", "--resume"),
            same_ids_other_geometry,
        ),
        ("resume a journal of another fleet", ("sim", cs, "--journal", "{d}/j.db", "--resume"), other_fleet),
        ("journal already holds a mission", ("sim", cs, "--journal", "{d}/j.db"), finished),
        ("resume a missing journal", ("sim", cs, "--journal", "{d}/none.db", "--resume"), lambda d: None),
        ("corrupt SQLite journal", ("sim", cs, "--journal", "{d}/j.db", "--resume"), corrupt),
        ("random bytes as journal", ("sim", cs, "--journal", "{d}/j.db", "--resume"), garbage),
        ("another program's database", ("sim", cs, "--journal", "{d}/j.db", "--resume"), foreign_db),
        ("another program's database, new mission", ("sim", cs, "--journal", "{d}/j.db"), foreign_db),
        ("journal is a folder", ("sim", cs, "--journal", "{d}/jdir"), lambda d: (d / "jdir").mkdir()),
        (
            "mission-control resumes another wall",
            ("mission-control", cs, "--journal", "{d}/j.db", "--resume", "--max-time", "0.1"),
            other_wall,
        ),
        (
            "mission-control on another program's database",
            ("mission-control", cs, "--journal", "{d}/j.db", "--max-time", "0.1"),
            foreign_db,
        ),
    ]
    if os.geteuid() != 0:
        rows.append(("read-only journal", ("sim", cs, "--journal", "{d}/j.db", "--resume"), read_only))
    return [Case("journals", name, argv, setup) for name, argv, setup in rows]


# ------------------------------------------------------------------------------------------ configs, keys, network


CONFIG_BOMB = (
    b"a: &a [1,1,1,1,1,1,1,1,1]\n"
    + b"".join(
        f"{chr(98 + i)}: &{chr(98 + i)} [{', '.join(['*' + chr(97 + i)] * 9)}]\n".encode() for i in range(7)
    )
    + b"velocity_lag_s: *h\n"
)


def _config_cases() -> list[Case]:
    cs = str(CASE_STUDY)
    fly = ("fly", "--uav", "brick", "--sim", "--blueprint", cs, "--task", "B0", "--config", "{d}/uav.yaml")
    rows: list[tuple[str, bytes]] = [
        ("uav.yaml binary", bytes(range(256)) * 16),
        ("uav.yaml not UTF-8", "fc: sim\nname: caf\xe9\n".encode("latin-1")),
        ("uav.yaml a list", b"- fc\n- sim\n"),
        ("uav.yaml unknown key", b"fc: sim\nwarp_drive: true\n"),
        ("uav.yaml velocity_lag_s negative", b"velocity_lag_s: -0.3\n"),
        ("uav.yaml velocity_lag_s a string", b"velocity_lag_s: slow\n"),
        ("uav.yaml velocity_lag_s 1e9", b"velocity_lag_s: 1.0e9\n"),
        ("uav.yaml syntax error", b"fc: [sim\n"),
        ("uav.yaml duplicate key", b"velocity_lag_s: 0.3\nvelocity_lag_s: 30\n"),
        ("uav.yaml billion laughs", CONFIG_BOMB),
    ]
    cases = [Case("configs", name, fly, _write("uav.yaml", content)) for name, content in rows]
    cases.append(Case("configs", "uav.yaml missing", fly))
    cases.append(
        Case(
            "configs",
            "--calibration missing",
            (
                "fly",
                "--uav",
                "brick",
                "--sim",
                "--blueprint",
                cs,
                "--task",
                "B0",
                "--camera",
                "render",
                "--calibration",
                "{d}/none.yaml",
            ),
        )
    )
    return cases


def _network_cases() -> list[Case]:
    cs = str(CASE_STUDY)
    mc = ("mission-control", cs, "--max-time", "0.1")
    fly = (
        "fly",
        "--uav",
        "brick",
        "--sim",
        "--blueprint",
        cs,
        "--mission",
        "tcp/127.0.0.1:7447",
        "--wait",
        "0.1",
    )
    rows: list[tuple[str, tuple[str, ...], Callable[[Path], None]]] = [
        (
            "mission-control on all interfaces without a key",
            (*mc, "--listen", "tcp/0.0.0.0:7447"),
            lambda d: None,
        ),
        (
            "fly --mission listening on all interfaces without a key",
            (*fly, "--listen", "tcp/0.0.0.0:0"),
            lambda d: None,
        ),
        ("mission-control --key-file missing", (*mc, "--key-file", "{d}/none.key"), lambda d: None),
        ("mission-control --key-file too short", (*mc, "--key-file", "{d}/k.key"), _write("k.key", b"short")),
        ("mission-control --key-file empty", (*mc, "--key-file", "{d}/k.key"), _write("k.key", b"")),
        (
            "mission-control --key-file is a folder",
            (*mc, "--key-file", "{d}/kdir"),
            lambda d: (d / "kdir").mkdir(),
        ),
        ("fly --key-file missing", (*fly, "--key-file", "{d}/none.key"), lambda d: None),
        ("fly --key-file 1 MB", (*fly, "--key-file", "{d}/k.key"), _write("k.key", os.urandom(1 << 20))),
        ("mission-control --zenoh-config missing", (*mc, "--zenoh-config", "{d}/none.json5"), lambda d: None),
        (
            "mission-control --zenoh-config garbage",
            (*mc, "--zenoh-config", "{d}/z.json5"),
            _write("z.json5", b"{ this is : not json5 "),
        ),
        (
            "mission-control --zenoh-config unknown key",
            (*mc, "--zenoh-config", "{d}/z.json5"),
            _write("z.json5", b'{ "warp": { "drive": true } }'),
        ),
        ("keygen -o into a missing folder", ("keygen", "-o", "{d}/no/such/k.key"), lambda d: None),
        ("keygen -o over an existing file", ("keygen", "-o", "{d}/k.key"), _write("k.key", b"precious")),
    ]
    return [Case("network", name, argv, setup) for name, argv, setup in rows]


def all_cases() -> list[Case]:
    """Every case of the campaign, in a fixed order."""
    return (
        _blueprint_cases()
        + _option_cases()
        + _output_cases()
        + _journal_cases()
        + _config_cases()
        + _network_cases()
    )


# ------------------------------------------------------------------------------------------ running


def _masonry() -> list[str]:
    exe = Path(sys.executable).with_name("masonry")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "masonry.cli"]


def _limits() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT_BYTES, MEMORY_LIMIT_BYTES))


def classify(status: int | None, stdout: str, stderr: str, timed_out: bool) -> tuple[str, str, int]:
    """The outcome kind, the first line of stderr, and how many non-empty lines stderr has."""
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    first = lines[0] if lines else (stdout.strip().splitlines() or [""])[0]
    if timed_out:
        return "hang", first, len(lines)
    if "Traceback (most recent call last)" in stdout + stderr:
        return "traceback", first, len(lines)
    if status == 0:
        return "accepted", first, len(lines)
    if status == 2 and len(lines) == 1 and lines[0].startswith("error:") and len(lines[0]) <= MAX_LINE_CHARS:
        return "clean", first, len(lines)
    return "other", first, len(lines)


def run_case(case: Case, workdir: Path, time_limit_s: float = TIME_LIMIT_S) -> Outcome:
    """Set the case up in a fresh folder under ``workdir``, run it, classify what came out."""
    d = Path(tempfile.mkdtemp(dir=workdir))
    try:
        case.setup(d)
        argv = [a.replace("{d}", str(d)) for a in case.argv]
        env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1", **dict(case.env)}
        t0 = time.monotonic()
        timed_out = False
        # preexec_fn is safe here: this script starts no threads
        proc = subprocess.Popen(
            [*_masonry(), *argv],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            env=env,
            cwd=d,
            preexec_fn=_limits,  # noqa: PLW1509
            start_new_session=True,
        )
        try:
            out_b, err_b = proc.communicate(timeout=time_limit_s)
        except subprocess.TimeoutExpired:
            timed_out = True
            os.killpg(proc.pid, 9)
            out_b, err_b = proc.communicate()
        seconds = time.monotonic() - t0
        out, err = out_b.decode(errors="replace"), err_b.decode(errors="replace")
        kind, first, nlines = classify(proc.returncode, out, err, timed_out)
        return Outcome(case, kind, None if timed_out else proc.returncode, seconds, first[:300], nlines)
    finally:
        for p in (d, *d.rglob("*")):
            try:
                p.chmod(0o700)
            except OSError:
                pass
        shutil.rmtree(d, ignore_errors=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default="", help="run only the categories starting with this text")
    parser.add_argument("--json", type=Path, help="write every outcome to this JSON file")
    parser.add_argument("--time-limit", type=float, default=TIME_LIMIT_S, help="seconds per case")
    parser.add_argument("--verbose", "-v", action="store_true", help="print every case as it runs")
    args = parser.parse_args(argv)
    cases = [c for c in all_cases() if c.category.startswith(args.only)]
    outcomes: list[Outcome] = []
    t0 = time.monotonic()
    with tempfile.TemporaryDirectory() as tmp:
        for i, case in enumerate(cases, 1):
            o = run_case(case, Path(tmp), args.time_limit)
            outcomes.append(o)
            if args.verbose or o.kind != "clean":
                print(
                    f"[{i}/{len(cases)}] {o.kind:9s} {case.category:15s} {case.name}: exit {o.status}, "
                    f"{o.seconds:.1f} s: {o.first_line[:160]}",
                    flush=True,
                )
    by_cat: dict[str, Counter[str]] = {}
    for o in outcomes:
        by_cat.setdefault(o.case.category, Counter())[o.kind] += 1
    kinds = ("clean", "traceback", "hang", "accepted", "other")
    print(f"\n{'category':16s} {'cases':>6s} " + " ".join(f"{k:>9s}" for k in kinds))
    for cat, counts in by_cat.items():
        print(f"{cat:16s} {sum(counts.values()):6d} " + " ".join(f"{counts[k]:9d}" for k in kinds))
    total = Counter(o.kind for o in outcomes)
    print(f"{'all':16s} {len(outcomes):6d} " + " ".join(f"{total[k]:9d}" for k in kinds))
    slowest = max(outcomes, key=lambda o: o.seconds, default=None)
    print(
        f"\n{len(outcomes)} cases in {time.monotonic() - t0:.0f} s; slowest {slowest.seconds:.1f} s "
        f"({slowest.case.category}: {slowest.case.name})"
        if slowest
        else "no cases"
    )
    if args.json:
        args.json.write_text(
            json.dumps(
                [
                    {
                        "category": o.case.category,
                        "name": o.case.name,
                        "kind": o.kind,
                        "status": o.status,
                        "seconds": round(o.seconds, 2),
                        "line": o.first_line,
                    }
                    for o in outcomes
                ],
                indent=1,
            )
            + "\n"
        )
    return 0 if total["clean"] == len(outcomes) else 1


if __name__ == "__main__":
    sys.exit(main())
