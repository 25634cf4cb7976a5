"""Library errors name parameters, not flags; the CLI translates them (``MasonryError.options``, ``cli_message``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from masonry.cli.app import OPTION_FLAGS, cli_message, cli_text
from masonry.errors import CommandRejected, InputError, MasonryError

SRC = Path(__file__).resolve().parents[1] / "src" / "masonry"
#: Modules whose errors may still name flags: none left (the check below would skip them).
NOT_YET: set[str] = set()


def test_options_become_flags_only_where_named_in_backticks() -> None:
    exc = InputError("`key_file` /k: not a regular file (see `masonry keygen`)", options=("key_file",))
    assert cli_message(exc) == "--key-file /k: not a regular file (see `masonry keygen`)"
    assert cli_message(InputError("`key_file` stays")) == "`key_file` stays"  # not listed: untouched
    rejected = CommandRejected("arm", "give more with `estimate_timeout_s`", options=("estimate_timeout_s",))
    assert cli_message(rejected) == "arm rejected: give more with --estimate-wait"
    assert OPTION_FLAGS["estimate_timeout_s"] == "--estimate-wait"
    assert (
        cli_text("`time_scale` and `dt` must be > 0", ("time_scale", "dt"))
        == "--time-scale and --dt must be > 0"
    )
    assert MasonryError("plain").options == ()


def test_library_error_messages_name_no_flags() -> None:
    """No ``raise`` outside the CLI spells a ``--flag`` in its message (the modules of NOT_YET aside)."""
    offenders = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        if rel.startswith("cli/") or rel in NOT_YET:
            continue
        lines = path.read_text(encoding="utf-8").splitlines()
        for i, line in enumerate(lines):
            if "raise " in line:
                statement = " ".join(lines[i : i + 4])
                head = statement.split(" from ")[0]
                if '"--' in head or " --" in head.split("raise ", 1)[1]:
                    offenders.append(f"{rel}:{i + 1}: {line.strip()}")
    assert offenders == []


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["markers", "--bricks", "5-2", "-o", "m.pdf"], "error: --bricks: range '5-2' runs backwards"),
        (
            ["markers", "--bricks", "-3", "-o", "m.pdf"],
            "error: --bricks: expected ids like 0-9 or 0,2,5-7; got '-3'",
        ),
    ],
)
def test_the_cli_prints_flags(args: list[str], expected: str, tmp_path) -> None:
    from typer.testing import CliRunner

    from masonry.cli import app

    res = CliRunner().invoke(app, [a if a != "m.pdf" else str(tmp_path / a) for a in args])
    assert res.exit_code == 2 and res.stderr.strip() == expected, res.output
