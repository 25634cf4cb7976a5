"""The state machines raise the error tree (masonry.errors), never a bare ValueError or RuntimeError (issue 28)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from fsm_rig import Rig
from masonry.errors import InvalidArgument, MasonryError
from masonry.fakes import FakeClock, FakeFlightController, QueueMissionLink
from masonry.fsm import UavConfig, build_uav, run_single_task
from masonry.fsm.diagram import write_diagram
from masonry.fsm.noise_gate import HoverNoise

FSM = Path(__file__).resolve().parent.parent / "src" / "masonry" / "fsm"
#: Built-in exceptions a module of masonry.fsm may not raise: the error tree has a class for each case.
_BARE = {"Exception", "ValueError", "RuntimeError", "TypeError", "KeyError", "IndexError"}


def _bare_raises(path: Path) -> list[str]:
    """``file:line name`` of each ``raise <built-in>(...)`` in ``path``."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Raise) and node.exc is not None:
            exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            if isinstance(exc, ast.Name) and exc.id in _BARE:
                found.append(f"{path.name}:{node.lineno} {exc.id}")
    return sorted(found)


def test_no_module_of_fsm_raises_a_bare_builtin_error() -> None:
    found = [hit for path in sorted(FSM.glob("*.py")) for hit in _bare_raises(path)]
    assert not found, f"raise an error of masonry.errors instead: {found}"


def test_the_scan_finds_a_bare_raise(tmp_path: Path) -> None:
    bad = tmp_path / "bad.py"
    bad.write_text("def f(x):\n    if x:\n        raise ValueError('no')\n    raise RuntimeError\n")
    assert _bare_raises(bad) == ["bad.py:3 ValueError", "bad.py:4 RuntimeError"]


def test_bad_arguments_raise_invalid_argument_naming_the_value(tmp_path: Path) -> None:
    rig = Rig("brick")
    with pytest.raises(InvalidArgument, match="dt_s must be > 0"):
        run_single_task(rig.uav, rig.clock, dt_s=0.0)
    clock = FakeClock()
    with pytest.raises(InvalidArgument, match="brick UAV brick-9 needs a gripper and a camera"):
        build_uav(
            UavConfig("brick-9", "brick", (0.0, 0.0, 0.0)),
            fc=FakeFlightController(clock),
            link=QueueMissionLink([]),
            clock=clock,
        )
    with pytest.raises(InvalidArgument, match="window_s must be finite"):
        HoverNoise(float("nan"))
    with pytest.raises(InvalidArgument, match="unknown machine 'crane'") as caught:
        write_diagram("crane", tmp_path / "crane.dot")
    # one tree, and still a ValueError for callers that caught that before
    assert isinstance(caught.value, MasonryError) and isinstance(caught.value, ValueError)
