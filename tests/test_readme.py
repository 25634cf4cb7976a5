"""The README's set-up commands are what CI runs, and every bundled blueprint it names exists."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _readme_commands() -> list[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    return re.findall(r"```bash\n(.+?)\n```", text)


def test_readme_opens_with_the_two_setup_commands() -> None:
    main_job, tests = _readme_commands()[:2]
    assert "masonry sim blueprints/" in main_job
    assert "pytest" in tests


def test_ci_runs_the_readme_test_command_exactly() -> None:
    tests = _readme_commands()[1]
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert tests in ci.splitlines()


def test_main_job_blueprint_is_bundled() -> None:
    main_job = _readme_commands()[0]
    path = re.search(r"masonry sim (\S+)", main_job)
    assert path is not None and (ROOT / path.group(1)).is_file()
