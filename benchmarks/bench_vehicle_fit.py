"""The simulated ArduCopter (``--vehicle arducopter``) against ArduCopter SITL on the same commands (issue 19).

For each target (the SITL on ``--fc URL``, the simulated vehicle with a preset) and each control tuning (``ideal``,
the defaults; ``arducopter``, the preset of masonry.fsm.tuning) it takes off to 1.5 m, hovers, and flies what the
state machines fly: a 1 m minimum-jerk leg along x (the navigator's planned duration) and a hover at its end,
then the same back. Per leg it prints

- settle time: from the leg's planned end until the UAV is within the hover gate (3 cm, 0.08 m/s: the gate a
  transit request waits for) and stays so for 0.5 s; ``-`` when it never does within ``--hover`` seconds;
- hover error: the RMS horizontal distance to the leg's end over the last half of the hover;
- swing: the largest horizontal distance from the leg's end after its planned end.

Then, per tuning, the preset's settle time and hover error against the SITL's (target: within 25 %).

    .venv/bin/python benchmarks/bench_vehicle_fit.py                          # simulated presets only
    .venv/bin/python benchmarks/bench_vehicle_fit.py --fc tcp:127.0.0.1:5760  # and the SITL (started by you)
    .venv/bin/python benchmarks/bench_vehicle_fit.py --model px4 --tunings fly ideal --fc udpin:0.0.0.0:14540
                                                          # the px4 model against ../shared/px4's real PX4 (SIH)
    .venv/bin/python benchmarks/bench_vehicle_fit.py --model px4 --tunings fly ideal --seeds 5   # the model alone

``fly`` is the tuning ``masonry fly`` picks for the target when uav.yaml names none (on a real PX4: the px4 preset
with the gains of masonry's own velocity loop, which its adapter flies there); ``--seeds`` pools the simulated
vehicles' legs over seeds (the px4 model is noisy: docs/performance/autopilots.md, "The px4 model refitted").
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from masonry.blueprint import UavSpec
from masonry.fsm import UavConfig
from masonry.fsm.navigator import Navigator
from masonry.fsm.tuning import uav_settings

GATE_M, GATE_MPS, GATE_HOLD_S = 0.03, 0.08, 0.5


@dataclass(frozen=True)
class Leg:
    settle_s: float | None
    hover_error_m: float
    swing_m: float


def _ports(target: str, fc_url: str | None, seed: int = 0) -> Any:
    from masonry.adapters.wiring import hardware_config
    from masonry.blueprint import load_blueprint
    from masonry.cli.fly import select_adapters
    from masonry.sim import Faults

    bp = load_blueprint("blueprints/paper_case_study.yaml")
    spec = bp.fleet[0]
    if target == "sitl":
        hw = hardware_config({"fc": fc_url, "estimate_wait_s": 150.0})
        return select_adapters(
            sim=False, blueprint=bp, spec=spec, seed=0, camera="geometric", faults=Faults(), hardware=hw
        )
    return select_adapters(
        sim=True, blueprint=bp, spec=spec, seed=seed, camera="geometric", faults=Faults(), vehicle=target
    )


def settings_for(tuning: str, ports: Any, model: str) -> dict[str, Any]:
    """The UavConfig overrides of ``tuning``: a preset's, or for ``fly`` what ``masonry fly`` picks for these
    ports with no control_preset in uav.yaml (masonry.cli.fly_tuning: on a real PX4, the px4 preset and the gains
    of masonry's own velocity loop; in simulation, the ``--vehicle`` preset's)."""
    if tuning != "fly":
        return uav_settings(tuning)
    from masonry.adapters.wiring import HardwareConfig
    from masonry.cli.fly_tuning import fly_settings

    return fly_settings(HardwareConfig(), model, ports)


def fly_legs(ports: Any, tuning: str, hover_s: float, dt_s: float = 0.05, model: str = "ideal") -> list[Leg]:
    fc, clock, advance = ports.fc, ports.clock, ports.advance
    fc.connect()  # (before the tuning: ``fly`` asks the connected autopilot which it is)
    config = UavConfig.from_spec(UavSpec("u", "brick", (0.0, 0.0, 0.0)), **settings_for(tuning, ports, model))
    nav = Navigator(config)
    fc.arm()
    fc.takeoff(1.5)
    start = clock.now_s()
    asked = start
    while not (fc.telemetry().position_m[2] > 1.35 and abs(fc.telemetry().velocity_mps[2]) < 0.1):
        if not fc.telemetry().armed and clock.now_s() - asked > 3.0:  # as the take-off state does (issue 19)
            fc.arm()
            fc.takeoff(1.5)
            asked = clock.now_s()
        if clock.now_s() - start > 60:
            tel = fc.telemetry()
            texts = getattr(fc, "status_texts", list)()[-5:]
            raise SystemExit(f"take-off not done in 60 s: z {tel.position_m[2]:.2f} m, {tel.mode}, {texts}")
        advance(dt_s)
    tel = fc.telemetry()
    nav.hold(clock.now_s(), tel)
    _run(fc, clock, advance, nav, 3.0, dt_s)
    legs = []
    for dx in (1.0, -1.0):
        tel = fc.telemetry()
        target = np.array(nav.target_m) + np.array([dx, 0.0, 0.0])
        nav.fly_to(clock.now_s(), tel, target)
        samples = _run(fc, clock, advance, nav, (nav.end_s - clock.now_s()) + hover_s, dt_s)
        legs.append(_measure(samples, nav.end_s, target, hover_s))
    fc.land()
    while not fc.telemetry().on_ground and clock.now_s() - start < 200:
        advance(dt_s)
    return legs


def _run(
    fc: Any, clock: Any, advance: Any, nav: Navigator, seconds: float, dt_s: float
) -> list[tuple[float, Any, Any]]:
    out = []
    end = clock.now_s() + seconds
    while clock.now_s() < end:
        now = clock.now_s()
        tel = fc.telemetry()
        sp = nav.step(now, tel)
        fc.send_velocity(sp.velocity_mps, sp.yaw_rate_radps)
        out.append((now, np.array(tel.position_m), np.array(tel.velocity_mps)))
        advance(dt_s)
    return out


def _measure(samples: list[tuple[float, Any, Any]], end_s: float, target: np.ndarray, hover_s: float) -> Leg:
    after = [
        (t, float(np.linalg.norm(p[:2] - target[:2])), float(np.linalg.norm(v)))
        for t, p, v in samples
        if t >= end_s
    ]
    settle = None
    inside_since = None
    for t, d, s in after:
        if d <= GATE_M and s <= GATE_MPS:
            inside_since = t if inside_since is None else inside_since
            if t - inside_since >= GATE_HOLD_S:
                settle = inside_since - end_s
                break
        else:
            inside_since = None
    tail = [d for t, d, _ in after if t >= end_s + hover_s / 2.0]
    rms = math.sqrt(sum(d * d for d in tail) / len(tail)) if tail else math.nan
    return Leg(settle, rms, max((d for _, d, _ in after), default=math.nan))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fc", help="the SITL's MAVLink URL (tcp:127.0.0.1:5760); without it, presets only")
    ap.add_argument("--hover", type=float, default=10.0, help="seconds of hover after each leg")
    ap.add_argument(
        "--tunings",
        nargs="+",
        default=["ideal", "arducopter"],
        help="control presets, or fly: what `masonry fly` picks for the target with no control_preset",
    )
    ap.add_argument(
        "--seeds", type=int, default=1, help="fly the simulated vehicles with this many seeds (legs pooled)"
    )
    ap.add_argument("--only-sitl", action="store_true", help="fly the SITL only (the presets take seconds)")
    ap.add_argument(
        "--model",
        default="arducopter",
        choices=["arducopter", "px4"],
        help="the simulated vehicle compared with the SITL (px4 for ../shared/px4's SITL on --fc udpin:0.0.0.0:14540)",
    )
    args = ap.parse_args()
    targets = ["ideal", args.model] + (["sitl"] if args.fc else [])
    if args.only_sitl:
        targets = ["sitl"]
    table: dict[tuple[str, str], list[Leg]] = {}
    for tuning in args.tunings:
        for target in targets:
            legs = []
            for seed in range(1 if target == "sitl" else args.seeds):
                ports = _ports(target, args.fc, seed)
                try:
                    legs += fly_legs(ports, tuning, args.hover, model=target if target != "sitl" else "ideal")
                finally:
                    ports.close()
            table[(target, tuning)] = legs
            for i, leg in enumerate(legs):
                settle = "-" if leg.settle_s is None else f"{leg.settle_s:5.2f} s"
                print(
                    f"{target:<10} tuning {tuning:<10} leg {i + 1}: settle {settle:>8}, "
                    f"hover error {leg.hover_error_m * 100:5.2f} cm, swing {leg.swing_m * 100:5.1f} cm",
                    flush=True,
                )
            if len(legs) > 2:
                print(f"{target:<10} tuning {tuning:<10} {_summary(legs)}", flush=True)
    if "sitl" not in targets or args.only_sitl:
        return
    for tuning in args.tunings:
        sitl, sim = table[("sitl", tuning)], table[(args.model, tuning)]
        print(f"tuning {tuning}: SITL {_summary(sitl)}; preset {_summary(sim)}")
        a, b = _settle(sitl), _settle(sim)
        if a and b:
            print(f"tuning {tuning}: settle preset/SITL {np.mean(b) / np.mean(a):.2f} (legs that settled)")
        ma, mb = np.mean([x.hover_error_m for x in sitl]), np.mean([x.hover_error_m for x in sim])
        print(f"tuning {tuning}: hover error preset/SITL {mb / ma:.2f}")


def _settle(legs: list[Leg]) -> list[float]:
    return [leg.settle_s for leg in legs if leg.settle_s is not None]


def _summary(legs: list[Leg]) -> str:
    """Legs settled (and their mean settle time), mean hover error and swing."""
    settled = _settle(legs)
    mean = f" in {np.mean(settled):.2f} s" if settled else ""
    hover = np.mean([leg.hover_error_m for leg in legs]) * 100
    swing = np.mean([leg.swing_m for leg in legs]) * 100
    return f"{len(settled)}/{len(legs)} legs settled{mean}, hover error {hover:.2f} cm, swing {swing:.1f} cm"


if __name__ == "__main__":
    main()
