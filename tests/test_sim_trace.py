"""`masonry sim`'s text summary shows the mission trace: the paper case study in the paper's order."""

from __future__ import annotations

import re
from pathlib import Path

from typer.testing import CliRunner

from masonry.cli import app

CASE_STUDY = Path(__file__).resolve().parent.parent / "blueprints" / "paper_case_study.yaml"


def test_text_summary_lists_attempts_in_start_order() -> None:
    result = CliRunner().invoke(app, ["sim", str(CASE_STUDY), "--reservation", "task"])  # the paper's rule
    assert result.exit_code == 0, result.output
    rows = re.findall(r"^\s+([\d.]+) s ->\s+([\d.]+) s\s+(\S+)\s+(\S+)\s+done$", result.output, re.MULTILINE)
    assert [task for _, _, task, _ in rows] == ["A0", "B0", "A1", "B1"]
    starts = [float(s) for s, _, _, _ in rows]
    assert starts == sorted(starts)
    assert {uav for _, _, task, uav in rows if task.startswith("B")} == {"brick-1"}
