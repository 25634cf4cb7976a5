"""The first hover's identified tuning against the autopilot's preset, on the real autopilots (issue 29).

Flies issue 29's one-brick scenario (``px4_sitl.ONE_BRICK``: brick 1 at (2, 1), its pickup at (4, -1), brick-1's
home at the origin; ``masonry fly --uav brick --task B1 --actuators sim --camera sim --format json``) with a
uav.yaml holding ``estimate_wait_s: 150`` and ``tuning: preset`` or ``tuning: identify``, ``--runs`` times each,
against:

- ``ardu``: ArduCopter SITL (hexa, ``copter.parm`` + ``copter-hexa.parm``, x``--speedup``), instance ``-I 10``;
- ``ardu-slow``: the same with a slower parameter set (``--slow-parm``, default ``ATC_INPUT_TC 0.6`` and
  ``PSC_JERK_XY 1.5``: a softer attitude input and velocity shaping, a longer lag), instance ``-I 11``;
- ``px4``: PX4 v1.16 SITL (SIH, defaults), instance ``--px4-instance``.

The cases run one after the other (``--cases``), each run on a fresh autopilot. Prints one line per run (status,
placement error, seconds of flight, the identification's line, how often an alignment failed on a swing) and a
JSON summary per case and tuning (done, median and worst error, median time).

    python benchmarks/bench_first_hover_tuning.py --runs 3
    python benchmarks/bench_first_hover_tuning.py --runs 3 --cases ardu-slow,px4
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import ardupilot_sitl
import px4_sitl

SHARED = Path(__file__).resolve().parents[2] / "shared"
SLOW_PARM = "ATC_INPUT_TC 0.6\nPSC_JERK_XY 1.5\n"


def fly(url: str, folder: Path, tuning: str, timeout_s: float, extra: str = "") -> dict[str, object]:
    """One ``masonry fly`` of the scenario: its JSON result with the identification's line and the swings."""
    (folder / "one_brick.yaml").write_text(px4_sitl.ONE_BRICK)
    (folder / "uav.yaml").write_text(f"estimate_wait_s: 150\ntuning: {tuning}\n" + extra.replace("\\n", "\n"))
    cmd = [sys.executable, "-c", "from masonry.cli import main; main()", "fly", "--uav", "brick", "--task", "B1",
           "--blueprint", str(folder / "one_brick.yaml"), "--fc", url, "--actuators", "sim", "--camera", "sim",
           "--config", str(folder / "uav.yaml"), "--format", "json"]  # fmt: skip
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, check=False)
    except subprocess.TimeoutExpired as exc:
        err = exc.stderr.decode(errors="replace") if isinstance(exc.stderr, bytes) else (exc.stderr or "")
        last = (err.strip().splitlines() or ["nothing on stderr"])[-1]
        return {"status": "failed", "identified": _identified(err),
                "reason": f"no result within {timeout_s:g} s of wall time (last said: {last})"}  # fmt: skip
    ident = _identified(proc.stderr)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
    if not lines:
        return {"status": "failed", "reason": (proc.stderr.strip().splitlines() or ["no output"])[-1]}
    out = dict(json.loads(lines[-1]))
    out["identified"] = ident
    out["swings"] = proc.stderr.count("swinging at") + proc.stdout.count("swinging at")
    return out


def _identified(stderr: str) -> str:
    """The first hover's line in ``masonry fly``'s log (empty: none)."""
    said = ("identified on first hover", "identification unusable")
    line = next((x for x in stderr.splitlines() if any(s in x for s in said)), "")
    return line.split(": ", 1)[-1]


def autopilot(case: str, folder: Path, args: argparse.Namespace) -> AbstractContextManager[str]:
    """A fresh autopilot for ``case`` (its MAVLink URL)."""
    if case == "px4":
        os.environ[px4_sitl.ENV] = str(args.run_sh.resolve())
        return px4_sitl.px4(folder / "px4", args.px4_instance)
    os.environ[ardupilot_sitl.ENV] = str(args.sitl.resolve())
    if case == "ardu-slow":
        return _with_parm(folder, args)
    return ardupilot_sitl.arducopter(folder / "sitl", 10, 1, speedup=args.speedup)


def _with_parm(folder: Path, args: argparse.Namespace) -> AbstractContextManager[str]:
    """ArduCopter with the slow parameter set laid over its defaults: a folder holding a link to the binary and
    its defaults files, the slow set appended to copter-hexa.parm."""

    @contextlib.contextmanager
    def run() -> Iterator[str]:
        parm = folder / "slow.parm"
        parm.write_text(args.slow_parm.replace("\\n", "\n"))
        real = ardupilot_sitl.sitl_binary
        binary = real()
        wrapper = folder / "arducopter"
        # the defaults file list is built from the binary's folder: a folder with links to it and the slow set
        for name in ("copter.parm", "copter-hexa.parm"):
            text = (binary.parent / name).read_text()
            (folder / name).write_text(text + (parm.read_text() if name == "copter-hexa.parm" else ""))
        wrapper.symlink_to(binary)
        ardupilot_sitl.sitl_binary = lambda: wrapper  # type: ignore[assignment]
        try:
            with ardupilot_sitl.arducopter(folder / "sitl", 11, 2, speedup=args.speedup) as url:
                yield url
        finally:
            ardupilot_sitl.sitl_binary = real  # type: ignore[assignment]

    return run()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sitl", type=Path, default=SHARED / "sitl/arducopter")
    ap.add_argument("--run-sh", type=Path, default=SHARED / "px4/run.sh")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--cases", default="ardu,ardu-slow,px4")
    ap.add_argument("--tunings", default="preset,identify")
    ap.add_argument("--px4-instance", type=int, default=0)
    ap.add_argument("--speedup", type=int, default=2, help="ArduCopter SITL's speed-up")
    ap.add_argument("--slow-parm", default=SLOW_PARM, help="the slow case's parameters (NAME VALUE lines)")
    ap.add_argument("--timeout", type=float, default=400.0, help="wall seconds a run may take")
    ap.add_argument("--extra", default="", help="lines added to uav.yaml (not the scenario's; e.g. a pid:)")
    args = ap.parse_args()
    summary = []
    for case in args.cases.split(","):
        for tuning in args.tunings.split(","):
            rows = []
            for run in range(args.runs):
                with tempfile.TemporaryDirectory() as tmp:
                    folder = Path(tmp)
                    with autopilot(case, folder, args) as url:
                        if case == "px4":
                            time.sleep(10.0)  # it refuses to arm in its first seconds (bench_px4_brick.py)
                        out = fly(url, folder, tuning, args.timeout, args.extra)
                error = out.get("placement_error_m")
                row = {
                    "status": out.get("status"),
                    "error_mm": None if error is None else round(float(error) * 1000, 1),  # type: ignore[arg-type]
                    "duration_s": out.get("duration_s"),
                    "swings": out.get("swings"),
                    "identified": out.get("identified", ""),
                    "reason": out.get("reason"),
                }
                rows.append(row)
                print(f"{case} {tuning} run {run}: {row['status']}, {row['error_mm']} mm, {row['duration_s']} s, "
                      f"{row['swings']} swing failures; {row['identified'] or '-'}"
                      + (f"; {row['reason']}" if row["reason"] else "")
                      + f" (load {os.getloadavg()[0]:.1f})", flush=True)  # fmt: skip
            summary.append(_summary(case, tuning, rows))
            print(json.dumps(summary[-1]), flush=True)
    print(json.dumps(summary))


def _summary(case: str, tuning: str, rows: list[dict[str, object]]) -> dict[str, object]:
    done = [r for r in rows if r["status"] == "done"]
    errors = [float(r["error_mm"]) for r in done if r["error_mm"] is not None]  # type: ignore[arg-type]
    times = [float(r["duration_s"]) for r in done if r["duration_s"] is not None]  # type: ignore[arg-type]
    med: Callable[[list[float]], float | None] = lambda v: round(statistics.median(v), 1) if v else None  # noqa: E731
    return {
        "case": case,
        "tuning": tuning,
        "done": len(done),
        "of": len(rows),
        "error_mm_median": med(errors),
        "error_mm_worst": max(errors, default=None),
        "duration_s_median": med(times),
        "swing_failures": sum(int(r["swings"] or 0) for r in rows),  # type: ignore[call-overload]
    }


if __name__ == "__main__":
    main()
