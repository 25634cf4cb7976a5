"""The ratchet on the code's health figures (issue 28): they may fall, never rise."""

from __future__ import annotations

import ast
from pathlib import Path

from code_health import (
    AIRSPACE_MAX_LINES,
    CEILINGS,
    CONTROL_MAX_LINES,
    HANDLER_MAX_LINES,
    MAX_MODULE_LINES,
    MISSION_MAX_LINES,
    OVERSIZE_CEILINGS,
    _in_function_imports,
    measure,
)


def test_no_module_grows_past_the_size_limit() -> None:
    health = measure()
    grown = {
        name: n
        for name, n in health.module_lines.items()
        if n > OVERSIZE_CEILINGS.get(name, MAX_MODULE_LINES)
    }
    assert not grown, f"modules over their line ceiling (split them, do not raise the ceiling): {grown}"


def test_no_mission_module_is_over_the_issue_27_target() -> None:
    health = measure()
    over = {
        name: n
        for name, n in health.module_lines.items()
        if name.startswith("mission/") and n > MISSION_MAX_LINES
    }
    assert not over, f"mission/ modules over {MISSION_MAX_LINES} lines (split them along a seam): {over}"


def test_mission_control_stays_within_the_issue_27_target() -> None:
    lines = measure().module_lines["mission/control.py"]
    assert lines <= CONTROL_MAX_LINES, (
        f"mission/control.py is {lines} lines, over {CONTROL_MAX_LINES}: move a responsibility out to its own "
        "module (as control_inbox, control_watch), do not raise the target"
    )


def test_the_airspace_protocol_stays_within_its_ceiling() -> None:
    lines = measure().module_lines["mission/airspace.py"]
    assert lines <= AIRSPACE_MAX_LINES, (
        f"mission/airspace.py is {lines} lines, over {AIRSPACE_MAX_LINES}: move a responsibility out to its own "
        "module (as airspace_records, airspace_progress), do not raise the ceiling"
    )


def test_the_uav_handler_stays_within_its_ceiling() -> None:
    lines = measure().module_lines["mission/handler.py"]
    assert lines <= HANDLER_MAX_LINES, (
        f"mission/handler.py is {lines} lines, over {HANDLER_MAX_LINES}: move a responsibility out to its own "
        "module (as handler_battery, handler_check, handler_columns), do not raise the ceiling"
    )


def test_a_module_back_under_the_limit_leaves_the_oversize_list() -> None:
    health = measure()
    shrunk = [name for name in OVERSIZE_CEILINGS if health.module_lines.get(name, 0) <= MAX_MODULE_LINES]
    assert not shrunk, (
        f"remove from OVERSIZE_CEILINGS (they are {MAX_MODULE_LINES} lines or fewer now): {shrunk}"
    )


def test_any_and_in_function_imports_stay_under_their_ceilings() -> None:
    health = measure()
    assert health.any_mentions <= CEILINGS["any_mentions"], health.any_mentions
    assert health.in_function_imports <= CEILINGS["in_function_imports"], health.in_function_imports


def test_the_counters_count_what_they_say(tmp_path: Path) -> None:
    code = (
        "from typing import Any\n"
        "import masonry.geometry\n"
        "def f(x: Any) -> Any:\n"
        "    from masonry import errors\n"
        "    from . import sibling\n"
        "    import numpy, masonry.timing\n"
        "    def g() -> None:\n"
        "        import masonry.planner\n"
        "    return x\n"
    )
    assert _in_function_imports(ast.parse(code)) == 4
    (tmp_path / "m.py").write_text(code)
    (tmp_path / "n.py").write_text("x = 1\n")
    health = measure(tmp_path)
    assert health.any_mentions == 3
    assert health.in_function_imports == 4
    assert health.module_lines == {"m.py": 9, "n.py": 1}
