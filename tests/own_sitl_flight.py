"""``masonry fly`` of the case study's B1 against the project's own PX4-preset SITL in lock-step (shared by
tests/test_px4.py and tests/test_sitl_lockstep.py)."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner, Result

from masonry.adapters.sitl import MavlinkSitl, free_udp_port
from masonry.cli import app
from masonry.cli.hardware import build_sitl

CASE_STUDY = str(Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml")


def start_lockstep_sitl(seed: int) -> tuple[MavlinkSitl, int]:
    """``masonry sitl --vehicle px4 --lockstep`` for the case study's brick UAV at up to 4x real time, started; and
    its UDP port."""
    port = free_udp_port()
    sitl, _ = build_sitl(
        port=port,
        uav="brick",
        blueprint=Path(CASE_STUDY),
        time_scale=4.0,
        vehicle="px4",
        seed=seed,
        lockstep=True,
    )
    sitl.start()
    return sitl, port


def fly_b1_argv(port: int) -> list[str]:
    """``masonry fly`` of B1 against the SITL on ``port``, simulated actuators and camera."""
    return ["fly", "--uav", "brick", "--blueprint", CASE_STUDY, "--task", "B1", "--fc", f"udp:127.0.0.1:{port}",
            "--actuators", "sim", "--camera", "sim"]  # fmt: skip


def lockstep_brick_flight(seed: int) -> tuple[Result, MavlinkSitl]:
    """Fly B1 (``--actuators sim --camera sim --format json``) against ``masonry sitl --vehicle px4 --lockstep``
    at up to 4x real time; the CLI's result and the (stopped) SITL."""
    sitl, port = start_lockstep_sitl(seed)
    try:
        res = CliRunner().invoke(app, [*fly_b1_argv(port), "--format", "json"])
    finally:
        sitl.stop()
    return res, sitl
