"""The SITL tests under load: N runs in a row with a busy process on one core; prints passes and failures.

Each run is ``pytest -n WORKERS`` over the tests that fly a SITL (the project's ``masonry sitl``, where
``MASONRY_ARDUPILOT_SITL`` names it ArduCopter's, and where ``MASONRY_PX4_SITL`` names it the real PX4's), while a process spins on one core for the whole loop
(issue 29: every such test must pass 10 runs in a row on a 2-core machine under ``-n 2`` with a core busy).
Prints one line per run (passed, failed, skipped, wall seconds, the failing tests) and a total; asserts nothing.

Usage: python benchmarks/bench_sitl_load.py [--runs 10] [--workers 2] [--no-busy] [--ardupilot] [--px4]
       [--tests tests/test_sitl_fly.py ...] [--log DIR] [--speedup K]

``--log DIR`` keeps each failing run's whole output (``--tb=long``: the failing test's stderr, e.g. mission
control's) in ``DIR/run-NN.txt`` and its tests' temporary folders (pytest's ``--basetemp``: a real PX4's
``px4.log``, ``fly.err``) in ``DIR/run-NN-tmp`` (a clean run's removed). Each run's line ends with the load average (1, 5, 15 min) after it.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The tests that fly the project's SITL (MavlinkSitl in-process, ``masonry sitl``, tests/fsm_rig.py's
#: ``glue_on_px4_sitl``, tests/own_sitl_flight.py): every test file that starts one (issue 29's list).
SITL_TESTS = (
    "tests/test_sitl.py",
    "tests/test_sitl_fly.py",
    "tests/test_hw_mission.py",
    "tests/test_px4.py",
    "tests/test_tuning_choice.py",
    "tests/test_sitl_lockstep.py",
    "tests/test_autopilot_takeover.py",
    "tests/test_contract_clock.py",
    "tests/test_flight_contract.py",
    "tests/test_fsm_emergency.py",
    "tests/test_own_velocity_loop.py",
    "tests/test_wind_heard.py",
    "tests/test_first_hover.py",
)
#: ArduCopter's SITL (tests/ardupilot_sitl.py; skipped by the tests where MASONRY_ARDUPILOT_SITL is unset).
ARDUPILOT_TESTS = (
    "tests/test_ardupilot_sitl.py",
    "tests/test_mavlink_fence.py",
    "tests/test_ardupilot_bond.py",
)
#: The real PX4 v1.16 SITL (tests/px4_sitl.py; skipped by the tests where MASONRY_PX4_SITL is unset).
PX4_TESTS = ("tests/test_px4_sitl.py",)


def _tmp(log: Path) -> Path:
    """A run's tests' temporary folders (pytest's ``--basetemp``) beside its log: kept where other sessions' pytest
    runs would otherwise rotate them away before a failure is looked at."""
    return log.with_name(f"{log.stem}-tmp")


def _run(tests: list[str], workers: int, log: Path | None = None) -> tuple[dict[str, int], list[str], float]:
    started = time.perf_counter()
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-n",
            str(workers),
            "-rfE",
            "--tb=line" if log is None else "--tb=long",
            "-p",
            "no:cacheprovider",
            *([] if log is None else ["--basetemp", str(_tmp(log))]),
            *tests,
        ],
        check=False,
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=3600,
    )
    wall_s = time.perf_counter() - started
    if log is not None and proc.returncode != 0:  # the whole output of a failing run, stderr and all
        log.write_text(proc.stdout + proc.stderr)
    elif log is not None:  # a clean run's temporary folders (its SITLs' logs) are not kept
        shutil.rmtree(_tmp(log), ignore_errors=True)
    counts = dict.fromkeys(("passed", "failed", "skipped", "error"), 0)
    for number, kind in re.findall(r"(\d+) (passed|failed|skipped|error)", proc.stdout):
        counts[kind] = int(number)
    failing = [line[:240] for line in re.findall(r"^(?:FAILED|ERROR) (.+)$", proc.stdout, flags=re.MULTILINE)]
    # --tb=line: one "path:line: error" per failure, what it waited for or asserted
    failing += [
        f"  {why[:300]}" for why in re.findall(r"^(/\S+\.py:\d+: .+)$", proc.stdout, flags=re.MULTILINE)
    ]
    if proc.returncode not in (0, 1) and not failing:
        failing = [f"pytest exit {proc.returncode}: {proc.stdout[-300:]!r}"]
    return counts, failing, wall_s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--workers", type=int, default=2, help="pytest-xdist workers (-n)")
    ap.add_argument("--no-busy", action="store_true", help="no busy process (the baseline)")
    ap.add_argument(
        "--ardupilot", action="store_true", help="add ArduCopter SITL's tests (needs its env var)"
    )
    ap.add_argument("--px4", action="store_true", help="add the real PX4 SITL's tests (needs its env var)")
    ap.add_argument("--tests", nargs="*", default=None, help="test files or ids (default: the SITL tests)")
    ap.add_argument(
        "--speedup",
        type=int,
        default=None,
        help="ArduCopter SITL's --speedup in its tests (default: theirs, tests/ardupilot_sitl.py SPEEDUP)",
    )
    ap.add_argument(
        "--log", type=Path, default=None, help="folder for each failing run's whole pytest output"
    )
    args = ap.parse_args()
    tests = list(args.tests) if args.tests else list(SITL_TESTS)
    if args.ardupilot and not args.tests:
        if not os.environ.get("MASONRY_ARDUPILOT_SITL"):
            sys.exit("--ardupilot: set MASONRY_ARDUPILOT_SITL to the arducopter binary")
        tests += list(ARDUPILOT_TESTS)
    if args.px4 and not args.tests:
        if not os.environ.get("MASONRY_PX4_SITL"):
            sys.exit("--px4: set MASONRY_PX4_SITL to ../shared/px4/run.sh")
        tests += list(PX4_TESTS)
    if args.speedup is not None:
        os.environ["MASONRY_ARDUPILOT_SITL_SPEEDUP"] = str(args.speedup)  # read by tests/ardupilot_sitl.py
    busy = None if args.no_busy else subprocess.Popen([sys.executable, "-c", "while True: pass"])
    print(
        f"{args.runs} runs of pytest -n {args.workers} over {' '.join(tests)}; "
        f"{'no busy process' if busy is None else 'one core kept busy'}; {os.cpu_count()} cores"
        + ("" if args.speedup is None else f"; ArduCopter SITL at --speedup {args.speedup}")
    )
    clean = 0
    failures: dict[str, int] = {}
    try:
        for i in range(1, args.runs + 1):
            log = None
            if args.log is not None:
                args.log.mkdir(parents=True, exist_ok=True)
                log = args.log / f"run-{i:02d}.txt"
            counts, failing, wall_s = _run(tests, args.workers, log)
            ok = not failing and counts["failed"] == 0 and counts["error"] == 0 and counts["passed"] > 0
            clean += ok
            for line in (f for f in failing if not f.startswith(" ")):
                test = line.split(" - ", 1)[0]
                failures[test] = failures.get(test, 0) + 1
            print(
                f"run {i:2d}: {counts['passed']} passed, {counts['failed']} failed, {counts['skipped']} skipped, "
                f"{wall_s:.0f} s, load average {' '.join(f'{x:.1f}' for x in os.getloadavg())}"
                + "".join(f"\n        FAILED {line}" for line in failing),
                flush=True,
            )
    finally:
        if busy is not None:
            busy.kill()
            busy.wait()
    print(f"clean runs: {clean}/{args.runs}")
    for test, n in sorted(failures.items(), key=lambda kv: -kv[1]):
        print(f"  {test}: failed in {n} of {args.runs} runs")


if __name__ == "__main__":
    main()
