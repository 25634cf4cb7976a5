"""How still the real PX4 v1.16 SITL holds a point: PX4's velocity loop against masonry's own (issue 29).

masonry's adapter takes off on ``../shared/px4/run.sh`` (SIH quadrotor), then a PI position loop (``--kp``,
``--ki``, as the ``px4`` tuning's) sends velocity setpoints for ``--hold`` seconds: with ``--loop autopilot`` PX4's
velocity loop flies them (it closes on EKF2's velocity), with ``--loop own`` the adapter turns them into
acceleration setpoints (:mod:`masonry.motion.velocity_loop`, on the reported position; ``--kv`` and
``--observer`` its gains, ``--observer-input tilt`` its observer driven by the acceleration PX4's attitude gives
rather than the commanded one: the adapter's ``velocity_observer_input``), with ``--loop position`` PX4's own
position controller holds the point (position setpoints). Prints per run the reported position's rms error about
the point, its swing about its own mean point per axis (x east, y north) beside SIH's ground truth's (HIL_STATE_QUATERNION) and the estimate's distance from it,
the swing's period (twice the lag of the velocity's autocorrelation's first minimum), the share of 1.5 s windows
whose mean lies within the brick alignment's 1.5 cm and 2.8 cm, the speeds, and how often PX4's log says a sensor
timed out (SIH runs in real time: on a machine too loaded for it EKF2 diverges, whichever loop flies), and the lean
held one way (``masonry.fsm.wind_lean.WindLean``, what the brick UAV's wind judgement reads) of the reported attitude
beside SIH's true one (in calm air the reported one's is EKF2's tilt error, issue 29); then a JSON summary. ``BENCH_PX4_HOLD_SAVE=DIR`` writes every run's ticks there (JSON).

    python benchmarks/bench_px4_hold.py --run-sh ../shared/px4/run.sh --loop own --runs 2 --hold 40
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from masonry.adapters.mavlink import MavlinkFlightController
from masonry.adapters.mavlink_protocol import MAV_CMD_SET_MESSAGE_INTERVAL, MAV_FRAME_LOCAL_NED
from masonry.errors import CommandRejected
from masonry.fsm.wind_lean import WindLean
from masonry.motion.velocity_loop import VelocityLoop, VelocityLoopGains, tilt_acceleration_mps2
from masonry.ports import Telemetry
from px4_sitl import ENV, px4

# PX4's position controller holds the point (``--loop position``): position + yaw rate kept, the rest ignored
TYPE_MASK_POSITION_YAW_RATE = 8 | 16 | 32 | 64 | 128 | 256 | 1024


def hold_on_position(fc: MavlinkFlightController) -> None:
    """From now on the adapter's stream sends PX4 the held point as a position setpoint (PX4's loops hold it)."""
    with fc._lock:
        target_ned = fc._state.position_ned or (0.0, 0.0, 0.0)
        fc.velocity_loop_engaged = False
    target_ned = (target_ned[0], target_ned[1], -1.2)

    def send(v_ned: tuple[float, float, float], yaw_rate_ned: float) -> None:
        with fc._send_lock:
            fc._conn.mav.set_position_target_local_ned_send(
                int(fc._monotonic() * 1000) & 0xFFFFFFFF, fc.target_system, fc.target_component,
                MAV_FRAME_LOCAL_NED, TYPE_MASK_POSITION_YAW_RATE,
                *target_ned, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, float(yaw_rate_ned),
            )  # fmt: skip
        fc.setpoints_sent += 1

    fc._send_position_target = send  # type: ignore[method-assign]


def watch_the_truth(fc: MavlinkFlightController) -> list[float]:
    """SIH's ground truth (HIL_STATE_QUATERNION at 30 Hz), east and north of its first sample (m), then its roll,
    pitch and yaw (rad, NED as the telemetry's), kept current in the list returned as the adapter reads its
    messages."""
    latest = [0.0, 0.0, 0.0, 0.0, 0.0]
    origin: list[float] = []
    handle = fc._handle

    def watch(msg: object, now: float) -> None:
        if msg.get_type() == "HIL_STATE_QUATERNION":  # type: ignore[attr-defined]
            lat, lon = msg.lat * 1e-7, msg.lon * 1e-7  # type: ignore[attr-defined]
            if not origin:
                origin.extend((lat, lon))
            latest[0] = (lon - origin[1]) * 111_319.5 * math.cos(math.radians(origin[0]))
            latest[1] = (lat - origin[0]) * 111_319.5
            w, x, y, z = msg.attitude_quaternion  # type: ignore[attr-defined]
            latest[2] = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
            latest[3] = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
            latest[4] = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        handle(msg, now)

    fc._handle = watch  # type: ignore[method-assign]
    fc._send_command(MAV_CMD_SET_MESSAGE_INTERVAL, (115, 1e6 / 30, 0, 0, 0, 0, 0), 0)
    return latest


def record_tilt(fc: MavlinkFlightController) -> list[tuple[float, float, float, float]]:
    """Beside each position the own loop observes, the horizontal acceleration PX4's attitude gives (NED, m/s^2:
    :func:`~masonry.motion.velocity_loop.tilt_acceleration_mps2`) and the one the loop commanded. Returns the list
    it fills (commanded north, east, tilt's north, east). What drives the observer is the adapter's
    ``velocity_observer_input`` (``--observer-input``), not this."""
    loop = fc.velocity_loop
    pairs: list[tuple[float, float, float, float]] = []
    if loop is None:
        return pairs
    observe = loop.observe

    def on_tilt(
        t_s: float, position_m: tuple[float, float, float], tilt: tuple[float, float] | None = None
    ) -> None:
        a_n, a_e = tilt_acceleration_mps2(*fc._state.attitude)
        pairs.append((loop._a[0], loop._a[1], a_n, a_e))
        observe(t_s, position_m, tilt)

    loop.observe = on_tilt  # type: ignore[method-assign]
    return pairs


def tilt_lag_s(pairs: list[tuple[float, float, float, float]], dt_s: float) -> tuple[float, float]:
    """How long after the command the tilt's acceleration follows it best (s), and that correlation (both axes)."""
    a = np.array(pairs[len(pairs) // 4 :])
    best = (0.0, -1.0)
    for k in range(16):
        c = [np.corrcoef(a[: len(a) - k, i], a[k:, i + 2])[0, 1] for i in (0, 1)]
        if float(np.mean(c)) > best[1]:
            best = (round(k * dt_s, 2), round(float(np.mean(c)), 2))
    return best


def period_s(v: np.ndarray, dt_s: float) -> float:
    """The swing's period: twice the lag of the velocity's autocorrelation's first minimum (nan: none)."""
    v = v - v.mean()
    ac = np.correlate(v, v, "full")[len(v) - 1 :]
    ac = ac / ac[0]
    for k in range(1, len(ac) - 1):
        if ac[k] < 0.0 and ac[k] <= ac[k - 1] and ac[k] <= ac[k + 1]:
            return round(2.0 * k * dt_s, 2)
    return math.nan


def hold(
    url: str,
    *,
    loop: str,
    hold_s: float,
    kp: float,
    ki: float,
    kv: float,
    observer: tuple[float, float],
    rates_hz: tuple[float, float] = (20.0, 30.0),
    observer_input: str = "command",
) -> dict[str, float]:
    """One flight: take off to 1.2 m, hold the point reached for ``hold_s`` (the first 8 s not counted)."""
    fc = MavlinkFlightController(
        url,
        estimate_timeout_s=120.0,
        ground_m=(0.0, 0.0, 0.0),
        setpoint_rate_hz=rates_hz[0],
        telemetry_rate_hz=rates_hz[1],
    )
    fc.own_velocity_loop = loop == "own"
    fc.connect()
    if fc.velocity_loop is not None:
        fc.velocity_loop = VelocityLoop(
            VelocityLoopGains(
                kv_per_s=kv,
                observer_position_rate_per_s=observer[0],
                observer_velocity_rate_per_s2=observer[1],
            )
        )
    truth = watch_the_truth(fc)
    fc.velocity_observer_input = observer_input
    pairs = record_tilt(fc)
    try:
        for attempt in range(20):  # PX4 refuses to arm for a few seconds after boot (its checks settle)
            try:
                fc.arm()
                break
            except CommandRejected:
                if attempt == 19:
                    raise
                time.sleep(2.0)
        fc.takeoff(1.2)
        t0 = time.monotonic()
        while fc._takeoff_target_m is not None and time.monotonic() - t0 < 60.0:
            time.sleep(0.05)
        target = np.array(fc.telemetry().position_m[:2])
        if loop == "position":
            hold_on_position(fc)
        integral = np.zeros(2)
        rows = []
        start = last = time.monotonic()
        while time.monotonic() - start < hold_s:
            time.sleep(0.05)
            now = time.monotonic()
            dt, last = now - last, now
            tel = fc.telemetry()
            p = np.array(tel.position_m)
            e = target - p[:2]
            integral = np.clip(integral + e * dt, -0.5, 0.5)
            v = np.clip(kp * e + ki * integral, -1.5, 1.5)
            fc.send_velocity((float(v[0]), float(v[1]), float(np.clip(1.5 * (1.2 - p[2]), -0.7, 0.7))), 0.0)
            rows.append((now - start, p[0], p[1], *tel.velocity_mps[:2], *truth, *tel.attitude_rad))
        fc.land()
    finally:
        fc.close()
    # every tick (t, reported x, y, velocity x, y, truth x, y, roll, pitch, yaw, reported roll, pitch, yaw)
    save = os.environ.get("BENCH_PX4_HOLD_SAVE")
    if save:
        Path(save).mkdir(parents=True, exist_ok=True)
        out = Path(save) / f"hold-{time.time():.0f}.json"
        out.write_text(json.dumps([[round(float(c), 4) for c in r] for r in rows]))
    a = np.array([r for r in rows if r[0] > 8.0])
    err = a[:, 1:3] - target
    n = max(1, round(1.5 / 0.05))
    windows = np.array([np.hypot(*err[i : i + n].mean(axis=0)) for i in range(0, len(err) - n, 3)])
    dev = err - err.mean(axis=0)  # the swing about its own mean point, per axis (x east, y north)
    true_dev = a[:, 5:7] - a[:, 5:7].mean(axis=0)  # SIH's truth about its own mean point (x east, y north)
    estimate_off = dev - true_dev
    return {
        "rms_error_m": round(math.sqrt(float((err**2).sum(axis=1).mean())), 4),
        "swing_x_m": round(float(np.sqrt((dev[:, 0] ** 2).mean())), 4),
        "swing_y_m": round(float(np.sqrt((dev[:, 1] ** 2).mean())), 4),
        "truth_swing_x_m": round(float(np.sqrt((true_dev[:, 0] ** 2).mean())), 4),
        "truth_swing_y_m": round(float(np.sqrt((true_dev[:, 1] ** 2).mean())), 4),
        "estimate_off_truth_m": round(float(np.sqrt((estimate_off**2).sum(axis=1).mean())), 4),
        "tilt_lag_s": tilt_lag_s(pairs, 1.0 / rates_hz[1])[0] if len(pairs) > 40 else math.nan,
        "period_s": period_s(np.diff(a[:, 1]) / np.maximum(np.diff(a[:, 0]), 1e-3), 0.05),
        "windows_within_15mm": round(float((windows < 0.015).mean()), 2),
        "windows_within_28mm": round(float((windows < 0.028).mean()), 2),
        "speed_rms_mps": round(math.sqrt(float((a[:, 3:5] ** 2).sum(axis=1).mean())), 3),
        **held_leans_mrad(a),
    }


def held_leans_mrad(a: np.ndarray) -> dict[str, float]:
    """The lean held one way (``masonry.fsm.wind_lean.WindLean``, a 3 s mean from the count's start) over the
    counted hold, of the reported attitude and of SIH's truth: its largest value and its mean (mrad), and the
    tilt's magnitude so averaged, largest (what the brick UAV's wind judgement reads in a calm hover)."""
    out: dict[str, float] = {}
    for name, cols in (("reported", slice(10, 13)), ("truth", slice(7, 10))):
        lean, held, tilt = WindLean(), [], []
        for i in range(1, len(a)):
            roll, pitch, yaw = (float(c) for c in a[i, cols])
            tel = Telemetry(float(a[i, 0]), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (roll, pitch, yaw), True, "", 1.0,
                            True, True, False)  # fmt: skip
            lean.follow(tel, float(a[i, 0] - a[i - 1, 0]))
            held.append(lean.held_rad)
            tilt.append(lean.tilt_rad)
        out[f"held_lean_{name}_max_mrad"] = round(1e3 * max(held), 1)
        out[f"held_lean_{name}_mean_mrad"] = round(1e3 * float(np.mean(held)), 1)
        out[f"tilt_{name}_max_mrad"] = round(1e3 * max(tilt), 1)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run-sh", type=Path, default=Path(__file__).resolve().parents[2] / "shared/px4/run.sh")
    ap.add_argument("--loop", choices=("own", "autopilot", "position"), default="own")
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--hold", type=float, default=30.0, help="seconds of hold (the first 8 not counted)")
    ap.add_argument("--kp", type=float, default=1.5)
    ap.add_argument("--ki", type=float, default=0.5)
    ap.add_argument("--kv", type=float, default=VelocityLoopGains().kv_per_s, help="own loop's kv (1/s)")
    g = VelocityLoopGains()
    ap.add_argument(
        "--observer",
        type=float,
        nargs=2,
        metavar=("POS_PER_S", "VEL_PER_S2"),
        default=(g.observer_position_rate_per_s, g.observer_velocity_rate_per_s2),
        help="the own loop's observer rates",
    )
    ap.add_argument("--setpoint-hz", type=float, default=20.0, help="the adapter's setpoint stream (Hz)")
    ap.add_argument("--telemetry-hz", type=float, default=30.0, help="LOCAL_POSITION_NED asked at (Hz)")
    ap.add_argument(
        "--observer-input",
        choices=("command", "tilt"),
        default="command",
        help="what drives the own loop's observer: the acceleration commanded (masonry's) or PX4's attitude's",
    )
    ap.add_argument("--instance", type=int, default=6, help="PX4 instance (offboard link on 14540 + N)")
    args = ap.parse_args()
    os.environ[ENV] = str(args.run_sh.resolve())
    rows = []
    for run in range(args.runs):
        with tempfile.TemporaryDirectory() as tmp:
            with px4(Path(tmp), args.instance) as url:
                row = {
                    "run": run,
                    **hold(
                        url,
                        loop=args.loop,
                        hold_s=args.hold,
                        kp=args.kp,
                        ki=args.ki,
                        kv=args.kv,
                        observer=tuple(args.observer),
                        rates_hz=(args.setpoint_hz, args.telemetry_hz),
                        observer_input=args.observer_input,
                    ),
                }
            # SIH runs in real time: a machine too loaded for it starves PX4's sensors (its log says so)
            log = (Path(tmp) / "px4.log").read_text(errors="replace")
            row["sensor_timeouts"] = log.count("fail:  TIMEOUT")
        rows.append(row)
        print(f"run {run} ({args.loop} loop, kp {args.kp}, ki {args.ki}, kv {args.kv}, observer {args.observer}): rms error {row['rms_error_m']} m, "
              f"swing x/y {row['swing_x_m']}/{row['swing_y_m']} m (truth {row['truth_swing_x_m']}/{row['truth_swing_y_m']}, "
              f"estimate off it {row['estimate_off_truth_m']}), period {row['period_s']} s, "
              f"tilt follows the command {row['tilt_lag_s']} s later, "
              f"1.5 s means within 1.5 cm {row['windows_within_15mm']:.0%}, within 2.8 cm "
              f"{row['windows_within_28mm']:.0%}, speed {row['speed_rms_mps']} m/s rms, lean held one way "
              f"{row['held_lean_reported_mean_mrad']} mean / {row['held_lean_reported_max_mrad']} max mrad (truth "
              f"{row['held_lean_truth_mean_mrad']} / {row['held_lean_truth_max_mrad']}), tilt averaged "
              f"{row['tilt_reported_max_mrad']} max (truth {row['tilt_truth_max_mrad']}) "
              f"(load {os.getloadavg()[0]:.1f}; PX4 sensor timeouts {row['sensor_timeouts']})")  # fmt: skip
    print(
        json.dumps(
            {
                "loop": args.loop,
                "kp": args.kp,
                "ki": args.ki,
                "kv": args.kv,
                "observer": args.observer,
                "observer_input": args.observer_input,
                "runs": rows,
            }
        )
    )


if __name__ == "__main__":
    main()
