"""What the mission log (``--log FILE.mcap``) and the live Foxglove server (``--foxglove``) cost a simulated mission.

Flies the same mission, unserved (no pacing: as fast as it goes), ``--runs`` times in each mode, alternating:
no sink; the MCAP log (:class:`~masonry.observe.mcap_log.McapLog`); the live Foxglove server
(:class:`~masonry.observe.live.FoxgloveLive` on 127.0.0.1, no viewer); the same with one viewer subscribed to
every channel (a ``foxglove.sdk.v1`` WebSocket client in a thread, draining). Prints, for each run, the wall
time, the process's CPU time (``time.process_time``: every thread, the SDK's server threads too, and not the other
jobs of a shared machine) and the CPU time spent inside the sink's ``emit``/``finish`` (the mission's thread);
then the log's size, its messages per topic kind, and how long ``read_log`` takes to read it back (what
``masonry replay`` does first).

    .venv/bin/python benchmarks/bench_log.py
    .venv/bin/python benchmarks/bench_log.py --blueprint blueprints/running_bond_200.yaml --runs 1
    # the same modes on another checkout (e.g. before the Foxglove SDK): only the modes it has
    PYTHONPATH=/path/to/old/src .venv/bin/python benchmarks/bench_log.py --modes "no log,log"
    # with the reservation table (its changes on /mission/reservations; the watch's CPU time printed too)
    .venv/bin/python benchmarks/bench_log.py --airspace table --modes "no log,log"
"""

from __future__ import annotations

import argparse
import json
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from websockets.sync.client import connect

from masonry.blueprint import load_blueprint
from masonry.mission.simulate import SimulatedMission
from masonry.mission.table_events import watch_table
from masonry.observe.mcap_log import McapLog, read_log

ROOT = Path(__file__).resolve().parents[1]
MODES = ("no log", "log", "foxglove", "foxglove+viewer")


class Viewer(threading.Thread):
    """A Foxglove viewer: subscribes to every channel advertised and counts the messages it receives."""

    def __init__(self, url: str) -> None:
        super().__init__(daemon=True)
        self.ws = connect(url, subprotocols=["foxglove.sdk.v1"], max_size=None)
        self.received = 0
        self.subscribed = threading.Event()

    def run(self) -> None:
        subs = 0
        try:
            for frame in self.ws:
                if isinstance(frame, str):
                    msg = json.loads(frame)
                    if msg["op"] == "advertise":
                        chans = [
                            {"id": subs + i + 1, "channelId": c["id"]} for i, c in enumerate(msg["channels"])
                        ]
                        subs += len(chans)
                        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": chans}))
                        self.subscribed.set()
                else:
                    self.received += 1
        except Exception:  # the server stopped: the connection closes
            pass


class Timed:
    """An event sink around another that adds up the CPU time spent inside it (the calling thread's)."""

    def __init__(self, sink: Any) -> None:
        self.sink = sink
        self.cpu_s = 0.0

    def emit(self, event: Any) -> None:
        t0 = time.thread_time()
        self.sink.emit(event)
        self.cpu_s += time.thread_time() - t0


def fly(
    bp: Any, text: str, mode: str, path: Path, airspace: str = "columns"
) -> tuple[tuple[float, float, float, float], Any, int]:
    """One mission in ``mode``: ((wall s, process CPU s, sink CPU s, table watch CPU s), its report, messages a
    viewer received)."""
    mission = SimulatedMission.from_blueprint(bp, airspace=airspace)
    sink: Any = None
    viewer = None
    if mode == "log":
        sink = McapLog(path, mission.plan, text, title=bp.name or "")
    elif mode.startswith("foxglove"):
        from masonry.observe.live import FoxgloveLive

        sink = FoxgloveLive(
            "127.0.0.1", 0, mission.plan, text, title=bp.name or "", uavs=[u.name for u in mission.fleet]
        )
    t0, cpu0 = time.perf_counter(), time.process_time()
    timed = Timed(sink)
    if isinstance(sink, McapLog):
        sink.open()
    elif sink is not None:
        sink.start()
        if mode == "foxglove+viewer":
            viewer = Viewer(sink.url)
            viewer.start()
            viewer.subscribed.wait(10)
    mission.control.sink = timed if sink is not None else None
    watch = watch_table(mission.control) if sink is not None else None  # (as the CLI's Watchers.attach)
    watch_cpu = [0.0]
    if watch is not None:
        columns: Any = mission.control.columns

        def timed_watch(table: Any, now_s: float) -> None:
            c0 = time.thread_time()
            watch(table, now_s)
            watch_cpu[0] += time.thread_time() - c0

        columns.on_change = timed_watch
    report = mission.run()
    if sink is not None:
        c0 = time.thread_time()
        sink.finish(report)
        timed.cpu_s += time.thread_time() - c0
    wall_s, cpu_s = time.perf_counter() - t0, time.process_time() - cpu0
    if isinstance(sink, McapLog):
        sink.close()
    elif sink is not None:
        sink.stop()
    if viewer is not None:
        viewer.join(10)
    return (wall_s, cpu_s, timed.cpu_s, watch_cpu[0]), report, viewer.received if viewer is not None else 0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blueprint", type=Path, default=ROOT / "blueprints" / "running_bond_small.yaml")
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--modes", default=",".join(MODES), help=f"comma-separated, of: {', '.join(MODES)}")
    ap.add_argument("--airspace", default="columns", choices=("columns", "table"))
    args = ap.parse_args()
    modes = [m.strip() for m in args.modes.split(",")]
    if "log" not in modes or not set(modes) <= set(MODES):
        ap.error(f"--modes: some of {', '.join(MODES)}, with log (its file is read back)")
    bp = load_blueprint(args.blueprint)
    text = args.blueprint.read_text(encoding="utf-8")
    times: dict[str, list[tuple[float, float, float, float]]] = {m: [] for m in modes}
    received: list[int] = []
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "run.mcap"
        for _ in range(args.runs):
            for mode in modes:
                measured, report, got = fly(bp, text, mode, path, args.airspace)
                times[mode].append(measured)
                if mode == "foxglove+viewer":
                    received.append(got)
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
        f", airspace {args.airspace}"
    )
    table = args.airspace == "table"
    extra = " / CPU s inside the table watch" if table else ""
    print(f"  {'mode':<16} per run: wall s / process CPU s / CPU s inside the sink{extra}")
    for mode, ts in times.items():
        print(
            f"  {mode:<16} "
            + "   ".join(
                f"{w:6.2f} / {c:6.2f} / {s:5.2f}" + (f" / {t:5.2f}" if table else "") for w, c, s, t in ts
            )
        )
    if received:
        print(f"  the viewer received {', '.join(str(n) for n in received)} messages")
    print(
        f"  log: {size / 1e6:.2f} MB, {summary.statistics.message_count} messages "
        f"({size / summary.statistics.message_count:.0f} B each, zstd chunks)"
    )
    for topic, n in counts.most_common():
        print(f"    {topic:<22} {n}")
    print(f"  read back (read_log): {read_s:.2f} s, {len(recorded.events)} events")


if __name__ == "__main__":
    main()
