"""A brick task on PX4 on GNSS (issue 20): against ``masonry sitl --vehicle px4`` and in ``--sim --vehicle px4``.

Per seed it flies ``masonry fly --uav brick --task B1`` of the paper's case study

- against the project's SITL with the ``px4`` vehicle (EKF2's flags, the ground 0.5 m up, the thrust ramp,
  GNSS-grade wander) on loopback, ``--fc udp:... --actuators sim --camera sim`` (the simulated world follows the
  position the autopilot reports);
- fully simulated, ``--sim --vehicle px4`` (the world keeps the true position: the placement error there includes
  the GNSS error);

and prints the status, the placement error and the task's duration.

    .venv/bin/python benchmarks/bench_px4.py --seeds 4 --time-scale 4
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from typer.testing import CliRunner

from masonry.adapters.sitl import free_udp_port
from masonry.cli import app
from masonry.cli.hardware import build_sitl

CASE_STUDY = str(Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml")


def _row(where: str, seed: int, stdout: str) -> str:
    out = json.loads(stdout)
    error = out.get("placement_error_m")
    return (
        f"{where:<22} seed {seed}: {out['status']:<6} placement "
        f"{'-' if error is None else f'{error * 1000:5.1f} mm'}, {out['duration_s']:6.1f} s"
        + (f" ({out['reason']})" if out.get("reason") else "")
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--time-scale", type=float, default=4.0)
    args = parser.parse_args()
    runner = CliRunner()
    task = ["--uav", "brick", "--blueprint", CASE_STUDY, "--task", "B1", "--format", "json"]
    for seed in range(args.seeds):
        port = free_udp_port()
        sitl, _ = build_sitl(
            port=port,
            uav="brick",
            blueprint=Path(CASE_STUDY),
            time_scale=args.time_scale,
            vehicle="px4",
            seed=seed,
        )
        sitl.start()
        try:
            res = runner.invoke(app, ["fly", *task, "--fc", f"udp:127.0.0.1:{port}", "--actuators", "sim",
                                      "--camera", "sim"])  # fmt: skip
        finally:
            sitl.stop()
        print(_row(f"sitl px4 x{args.time_scale:g}", seed, res.stdout), flush=True)
    for seed in range(args.seeds):
        res = runner.invoke(app, ["fly", *task, "--sim", "--vehicle", "px4", "--seed", str(seed)])
        print(_row("--sim --vehicle px4", seed, res.stdout), flush=True)


if __name__ == "__main__":
    main()
