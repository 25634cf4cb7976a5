"""The pre-flight check of one UAV's adapters (:func:`preflight`): what is connected, and whether it may arm.

Opened by :func:`masonry.adapters.wiring.open_adapters`; ``masonry fly`` prints the report and refuses to arm
with a clear reason when a blocking check fails.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from masonry.errors import CommandRejected, HardwareError, InputError
from masonry.ports import UavPorts

if TYPE_CHECKING:
    from masonry.adapters.wiring import HardwareConfig


@dataclass(frozen=True)
class CheckItem:
    """One line of the pre-flight report."""

    name: str
    ok: bool
    detail: str
    blocking: bool = True
    options: tuple[str, ...] = ()  # parameters the detail names (``MasonryError.options``), for the CLI


@dataclass(frozen=True)
class PreflightReport:
    """What is connected and whether the UAV may arm."""

    items: tuple[CheckItem, ...]

    @property
    def ok(self) -> bool:
        return all(item.ok or not item.blocking for item in self.items)

    @property
    def options(self) -> tuple[str, ...]:
        """The parameters the report's lines name (each in backticks), for a front end to translate."""
        return tuple(dict.fromkeys(o for item in self.items for o in item.options))

    @property
    def reasons(self) -> list[str]:
        return [f"{item.name}: {item.detail}" for item in self.items if item.blocking and not item.ok]

    def lines(self) -> list[str]:
        out = ["pre-flight check:"]
        for item in self.items:
            mark = "ok  " if item.ok else ("FAIL" if item.blocking else "warn")
            out.append(f"  [{mark}] {item.name}: {item.detail}")
        out.append("  -> ready to arm" if self.ok else "  -> refusing to arm")
        return out

    def raise_if_failed(self) -> None:
        """Raises CommandRejected("arm", ...) naming every blocking failure."""
        if not self.ok:
            raise CommandRejected(
                "arm", "pre-flight check failed: " + "; ".join(self.reasons), options=self.options
            )


def preflight(
    adapters: UavPorts,
    hw: HardwareConfig,
    *,
    role: str = "brick",
    progress: Callable[[str], None] | None = None,
    site: Any = None,
) -> PreflightReport:
    """Check the opened adapters: link, position estimate, battery, disarmed, actuators answer, camera frames,
    and, with a ``site`` (``Blueprint.site``), its fence uploaded to the autopilot (a refusal refuses to arm).

    ``progress`` gets the countdown of the wait for the position estimate (what is missing, seconds left).
    """
    items: list[CheckItem] = []
    items.append(CheckItem("flight controller", True, adapters.descriptions.get("flight controller", "?")))
    fc: Any = adapters.fc  # a MAVLink adapter when not simulated (its estimate wait)
    if not hw.sim_fc:
        try:
            fc.wait_for_estimate(hw.estimate_wait_s, progress=progress)
            items.append(
                CheckItem("position estimate", True, "usable (EKF reports horizontal and vertical position)")
            )
        except HardwareError as exc:
            detail = exc.reason if isinstance(exc, CommandRejected) else str(exc)
            items.append(CheckItem("position estimate", False, detail, options=exc.options))
        ground = getattr(fc, "ground_m", None)
        if ground is not None and not fc.telemetry().armed:
            up = fc.measure_ground(ground)
            items.append(
                CheckItem(
                    "ground",
                    up is not None,
                    f"the EKF reads the ground {up:+.2f} m up: taken as z {ground[2]:.2f} m (world), measured "
                    "again at each arming at home"
                    if up is not None
                    else "not measured (no position reports): altitudes are the EKF's own",
                    False,
                )
            )
        deadline = time.monotonic() + 1.5
        while math.isnan(fc.telemetry().battery_fraction) and time.monotonic() < deadline:
            time.sleep(0.02)  # SYS_STATUS comes at 2 Hz
        tel = fc.telemetry()
        items.append(
            CheckItem(
                "link",
                tel.link_ok,
                "heartbeat and telemetry flowing"
                if tel.link_ok
                else f"silent for more than {hw.heartbeat_timeout_s:.1f} s",
            )
        )
        items.append(
            CheckItem(
                "disarmed on the ground",
                not tel.armed and tel.on_ground,
                f"mode {tel.mode}, {'armed' if tel.armed else 'disarmed'}, "
                f"{'on the ground' if tel.on_ground else 'in the air'}",
            )
        )
        items.append(
            CheckItem(
                "position", True, "x {:.2f}, y {:.2f}, z {:.2f} m (world ENU)".format(*tel.position_m), False
            )
        )
        battery = tel.battery_fraction
        if math.isnan(battery):
            items.append(
                CheckItem("battery", False, "charge unknown (no battery monitor configured?)", False)
            )
        else:
            items.append(
                CheckItem(
                    "battery", battery >= hw.min_battery, f"{battery:.0%} (minimum {hw.min_battery:.0%})"
                )
            )
        if site is not None:
            items.append(_check_fence(fc, site))
    items.append(_check_actuators(adapters, hw, role))
    items.append(_check_camera(adapters, hw))
    return PreflightReport(tuple(items))


def _check_fence(fc: Any, site: Any) -> CheckItem:
    """The site's fence uploaded as the autopilot's (``masonry.adapters.mavlink_fence``): accepted, or why not."""
    try:
        up = fc.upload_fence(site)
    except HardwareError as exc:
        detail = exc.reason if isinstance(exc, CommandRejected) else str(exc)
        return CheckItem("geofence", False, detail)
    if not up.supported:
        return CheckItem("geofence", False, f"{up.detail}; masonry's own fence still holds", blocking=False)
    return CheckItem("geofence", True, up.detail)


def _check_actuators(adapters: UavPorts, hw: HardwareConfig, role: str) -> CheckItem:
    if hw.sim_actuators:
        return CheckItem("actuators", True, "simulated")
    try:
        board: Any = adapters.gripper  # the Arduino board when not simulated
        status = board.status()
    except HardwareError as exc:
        return CheckItem("actuators", False, f"not answering: {exc}")
    detail = (
        f"{adapters.descriptions.get('actuators')}: magnet {'on' if status.magnet_on else 'off'}, "
        f"joint {'locked' if status.joint_locked else 'unlocked'}, valve {'open' if status.valve_open else 'closed'}, "
        f"brick {'attached' if status.attached else 'not attached'}"
    )
    if role == "adhesion" and status.valve_open:
        return CheckItem("actuators", False, detail + " (the valve must be closed before take-off)")
    return CheckItem("actuators", True, detail)


def _check_camera(adapters: UavPorts, hw: HardwareConfig, wait_s: float = 3.0) -> CheckItem:
    description = adapters.descriptions.get("camera", "?")
    if hw.sim_camera:
        return CheckItem("camera", True, description)
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline:
        try:
            frame = adapters.camera.read()
        except InputError as exc:
            return CheckItem("camera", False, str(exc))
        if frame is not None and frame.image is not None:
            h, w = frame.image.shape[:2]
            return CheckItem("camera", True, f"{description}: {w}x{h} frames")
        time.sleep(0.02)
    return CheckItem("camera", False, f"{description}: no frame within {wait_s:.0f} s")
