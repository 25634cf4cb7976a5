"""What the mission log (``--log FILE.mcap``) costs a simulated mission, and what it holds.

Flies the same mission with no sink and with an :class:`~masonry.observe.mcap_log.McapLog`, ``--runs`` times
each, alternating, and prints the wall time of each run, the log's size, its messages per topic kind, and how
long ``masonry.observe.mcap_log.read_log`` takes to read it back (what ``masonry replay`` does first).

    .venv/bin/python benchmarks/bench_log.py
    .venv/bin/python benchmarks/bench_log.py --blueprint blueprints/running_bond_200.yaml --runs 1
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections import Counter
from pathlib import Path

from mcap.reader import make_reader

from masonry.blueprint import load_blueprint
from masonry.mission.simulate import SimulatedMission
from masonry.observe.mcap_log import McapLog, read_log

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blueprint", type=Path, default=ROOT / "blueprints" / "running_bond_small.yaml")
    ap.add_argument("--runs", type=int, default=2)
    args = ap.parse_args()
    bp = load_blueprint(args.blueprint)
    text = args.blueprint.read_text(encoding="utf-8")
    times: dict[str, list[float]] = {"no log": [], "log": []}
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "run.mcap"
        for _ in range(args.runs):
            for mode in times:
                mission = SimulatedMission.from_blueprint(bp)
                log = McapLog(path, mission.plan, text, title=bp.name or "") if mode == "log" else None
                t0 = time.perf_counter()
                if log is not None:
                    log.open()
                    mission.control.sink = log
                report = mission.run()
                if log is not None:
                    log.finish(report)
                    log.close()
                times[mode].append(time.perf_counter() - t0)
        size = path.stat().st_size
        with open(path, "rb") as f:
            summary = make_reader(f).get_summary()
        assert summary is not None and summary.statistics is not None
        counts: Counter[str] = Counter()
        for cid, n in summary.statistics.channel_message_counts.items():
            topic = summary.channels[cid].topic
            counts["/uav/NAME/" + topic.rsplit("/", 1)[-1] if topic.startswith("/uav/") else topic] += n
        t0 = time.perf_counter()
        recorded = read_log(path)
        read_s = time.perf_counter() - t0
    print(
        f"{args.blueprint.name}: {len(bp.bricks)} bricks, makespan {report.makespan_s:.0f} s, sim {report.sim_time_s:.0f} s"
    )
    for mode, ts in times.items():
        print(f"  {mode:<7} " + "  ".join(f"{t:6.2f} s" for t in ts))
    print(
        f"  log: {size / 1e6:.2f} MB, {summary.statistics.message_count} messages "
        f"({size / summary.statistics.message_count:.0f} B each, zstd chunks)"
    )
    for topic, n in counts.most_common():
        print(f"    {topic:<22} {n}")
    print(f"  read back (read_log): {read_s:.2f} s, {len(recorded.events)} events")


if __name__ == "__main__":
    main()
