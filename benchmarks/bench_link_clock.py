"""``LinkClock`` against a SITL whose speed changes: the extrapolation's error and the rate it measures.

A simulated link, no SITL and no sleeping: an autopilot stamps a message every 1/30 s of its own clock
(``time_boot_ms``), which arrives on this computer's clock after a latency of 2-20 ms (uniform, seeded); its speed
follows a schedule (x5 for 60 s of wall, then x2 for 30 s, by default; ``--standstill`` adds a 1.5 s stand-still,
its clock still, 20 s after the change). A fly loop reads ``now_s`` every 50 ms of wall; each reading is compared
with the autopilot's true time then. Prints, per phase (before the change, the 10 s after it, the rest), the
mean and largest error of ``now_s`` (ms of autopilot time), the mean rate measured, and how long after the change
the rate is within 5 % of the new speed; asserts nothing.

Usage: python benchmarks/bench_link_clock.py [--speeds 5,2] [--phase-s 60,30] [--standstill] [--seed 1]

Before/after: ``PYTHONPATH=/work/main/src python benchmarks/bench_link_clock.py`` (main's ``LinkClock``) and
``PYTHONPATH=src python benchmarks/bench_link_clock.py`` (a worktree's).
"""

from __future__ import annotations

import argparse
import random
import statistics

from masonry.adapters.link_values import LinkClock

MESSAGE_PERIOD_S = 1 / 30  # of the autopilot's clock
LOOP_PERIOD_S = 0.05  # of this computer's clock


def _segments(speeds: list[float], phases_s: list[float], standstill_at_s: float | None) -> list[tuple[float, float, float]]:  # fmt: skip
    """(wall start, wall end, speed) of each stretch."""
    out, t = [], 0.0
    for speed, length_s in zip(speeds, phases_s):
        out.append((t, t + length_s, speed))
        t += length_s
    if standstill_at_s is not None:
        cut = []
        for a, b, v in out:
            if a <= standstill_at_s < b:
                cut += [(a, standstill_at_s, v), (standstill_at_s, standstill_at_s + 1.5, 0.0)]
                cut.append((standstill_at_s + 1.5, b + 1.5, v))
            elif a > standstill_at_s:
                cut.append((a + 1.5, b + 1.5, v))
            else:
                cut.append((a, b, v))
        out = cut
    return out


def _boot_at(segments: list[tuple[float, float, float]], wall_s: float) -> float:
    boot = 0.0
    for a, b, v in segments:
        boot += v * (min(wall_s, b) - a) if wall_s > a else 0.0
    return boot


def _wall_at(segments: list[tuple[float, float, float]], boot_s: float) -> float:
    boot = 0.0
    for a, b, v in segments:
        if v > 0.0 and boot + v * (b - a) >= boot_s:
            return a + (boot_s - boot) / v
        boot += v * (b - a)
    return segments[-1][1]


def run(speeds: list[float], phases_s: list[float], standstill: bool, seed: int) -> None:
    rng = random.Random(seed)
    change_s = phases_s[0]
    segments = _segments(speeds, phases_s, change_s + 20.0 if standstill else None)
    end_s = segments[-1][1]
    arrivals = []  # (local arrival s, boot s)
    boot = MESSAGE_PERIOD_S
    while (sent := _wall_at(segments, boot)) < end_s:
        arrivals.append((sent + rng.uniform(0.002, 0.020), boot))
        boot += MESSAGE_PERIOD_S
    arrivals.sort()
    local = [0.0]
    clock = LinkClock(lambda: local[0])
    rows: dict[str, list[tuple[float, float, float, float]]] = {"before": [], "10 s after": [], "rest": []}
    settled_s = None
    i, t = 0, LOOP_PERIOD_S
    while t < end_s:
        while i < len(arrivals) and arrivals[i][0] <= t:
            local[0] = arrivals[i][0]
            clock.observe(arrivals[i][1], arrivals[i][0])
            i += 1
        local[0] = t
        true_s = _boot_at(segments, t)
        now_s, rate = clock.now_s(), clock.rate
        speed = next(v for a, b, v in segments if a <= t < b)
        # the extrapolation's own part: against the last time heard run on at the true speed (its latency aside)
        heard_local_s, heard_boot_s = arrivals[i - 1] if i else (0.0, 0.0)
        extrapolated_s = heard_boot_s + min(
            true_s - _boot_at(segments, heard_local_s), speed * (t - heard_local_s)
        )
        # how much autopilot time a sleep of 50 ms of it (clock.sleep: 50 ms / rate of wall) lets pass
        slept_ms = 1000.0 * LOOP_PERIOD_S / rate * speed
        phase = "before" if t < change_s else "10 s after" if t < change_s + 10.0 else "rest"
        rows[phase].append(((now_s - true_s) * 1000.0, (now_s - extrapolated_s) * 1000.0, rate, slept_ms))
        if t >= change_s and settled_s is None and abs(rate / speeds[1] - 1.0) < 0.05:
            settled_s = t - change_s
        t += LOOP_PERIOD_S
    what = f"x{speeds[0]:g} for {phases_s[0]:g} s, then x{speeds[1]:g} for {phases_s[1]:g} s"
    print(f"{what}{', a 1.5 s stand-still 20 s after the change' if standstill else ''} (seed {seed})")
    for phase, got in rows.items():
        errs = [e for e, _, _, _ in got]
        extra = [abs(x) for _, x, _, _ in got]
        rates = [r for _, _, r, _ in got]
        slept = [s for _, _, _, s in got if s > 0.0]
        print(
            f"  {phase:>10}: now_s - true {statistics.fmean(errs):+6.1f} ms mean, {max(map(abs, errs)):5.1f} max; "
            f"extrapolation error {statistics.fmean(extra):5.1f} ms mean, {max(extra):5.1f} max; "
            f"rate {statistics.fmean(rates):.2f} ({min(rates):.2f}-{max(rates):.2f}); "
            f"a 50 ms sleep lets {statistics.fmean(slept):.0f} ms ({min(slept):.0f}-{max(slept):.0f}) pass"
        )
    print(
        f"  rate within 5 % of x{speeds[1]:g}: {'never' if settled_s is None else f'{settled_s:.2f} s'} after the change"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speeds", default="5,2")
    ap.add_argument("--phase-s", default="60,30")
    ap.add_argument("--standstill", action="store_true")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    speeds = [float(v) for v in args.speeds.split(",")]
    phases_s = [float(v) for v in args.phase_s.split(",")]
    run(speeds, phases_s, args.standstill, args.seed)


if __name__ == "__main__":
    main()
