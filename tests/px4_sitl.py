"""PX4 v1.16 SITL (SIH) for the tests that fly the real PX4 (issue 29): found, started, stopped.

``MASONRY_PX4_SITL`` names ``../shared/px4/run.sh`` (``.ci/run`` sets it when that exists). Without it, the tests
that need it are skipped with one reason. Each instance runs in its own working folder and process group (run.sh
execs PX4 in the foreground: the process is PX4's), stopped with SIGTERM, then killed whole; instance numbers 7-9
(offboard link on UDP 14540 + N) keep clear of a developer's instances 0 and 1.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

ENV = "MASONRY_PX4_SITL"


def px4_run_sh() -> Path:
    """PX4's run.sh, or skip (one reason) when it is not configured."""
    value = os.environ.get(ENV)
    if not value:
        pytest.skip(f"PX4 SITL not available: set {ENV} to its run.sh (../shared/px4/run.sh)")
    path = Path(value)
    if not path.is_file():
        pytest.skip(f"PX4 SITL not available: {ENV}={value} is not a file")
    return path


@contextlib.contextmanager
def px4(workdir: Path, instance: int) -> Iterator[str]:
    """Run one PX4 SIH quadrotor (instance ``instance``, no .ulg logging); yields the URL ``masonry fly --fc`` takes."""
    run_sh = px4_run_sh()
    workdir.mkdir(parents=True, exist_ok=True)
    log = (workdir / "px4.log").open("w")
    proc = subprocess.Popen(
        ["sh", str(run_sh), str(workdir / "px4"), str(instance)],
        env={**os.environ, "PX4_PARAM_SDLOG_MODE": "-1"}, stdout=log, stderr=subprocess.STDOUT,
        start_new_session=True,
    )  # fmt: skip
    try:
        yield f"udpin:0.0.0.0:{14540 + instance}"
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=10)
        log.close()
