"""The tuning ``masonry fly`` flies on the chosen flight controller, and the pre-flight line that says why."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Any

from masonry.fsm.tuning_choice import AUTOPILOT_PRESETS, TuningChoice, choose_tuning

if TYPE_CHECKING:  # (the adapters load only when a UAV flies: masonry --help imports no pymavlink)
    from masonry.adapters.wiring import HardwareConfig, PreflightReport
    from masonry.ports import UavPorts


def tuning_preset(vehicle: str, adapters: UavPorts | None) -> str:
    """The control preset a UAV flies when its ``uav.yaml`` names none: the connected autopilot's
    (``arducopter`` on ArduPilot, issue 29; ``px4`` on PX4, issue 20), else the simulated vehicle's (``--vehicle``)."""
    fc = adapters.fc if adapters is not None else None
    return AUTOPILOT_PRESETS.get(str(getattr(fc, "autopilot", None)), vehicle)


def fly_settings(hardware: HardwareConfig, vehicle: str, adapters: UavPorts | None) -> dict[str, Any]:
    """The :class:`~masonry.fsm.UavConfig` overrides a UAV flies: :func:`tuning_preset`'s, and the gains of
    masonry's own velocity loop where its flight controller flies it (a real PX4, issue 29) or where the simulated
    vehicle models it (``--vehicle px4``: masonry.fsm.tuning.OWN_VELOCITY_LOOP_PRESETS). A MAVLink flight
    controller is told what drives its loop's observer (``velocity_observer_input``, issues 29/30)."""
    fc = adapters.fc if adapters is not None else None
    # a MAVLink flight controller says whether it flies masonry's loop; a simulated one leaves it to the preset
    own = getattr(fc, "velocity_loop", None) is not None if hasattr(fc, "velocity_loop") else None
    settings = hardware.uav_settings(tuning_preset(vehicle, adapters), own_velocity_loop=own)
    if tuning_choice(hardware, vehicle, adapters).identify:  # the first hover's (masonry.fsm.first_hover)
        settings["identify_first_hover"] = True
    if hasattr(fc, "velocity_observer_input"):
        fc.velocity_observer_input = settings.get("velocity_observer_input", "command")  # type: ignore[union-attr]
    return settings


def tuning_choice(hardware: HardwareConfig, vehicle: str, adapters: UavPorts | None) -> TuningChoice:
    """What :func:`tuning_preset` and ``hardware`` (a :class:`~masonry.adapters.wiring.HardwareConfig`) choose."""
    fc = adapters.fc if adapters is not None else None
    autopilot = getattr(fc, "autopilot", None)
    overrides = tuple(
        key
        for key, given in (
            ("control", bool(hardware.control)),
            ("pid", bool(hardware.pid)),
            ("velocity_lag_s", hardware.velocity_lag_s is not None),
        )
        if given
    )
    return choose_tuning(
        hardware.control_preset,
        autopilot=autopilot if autopilot in AUTOPILOT_PRESETS else None,
        vehicle=vehicle,
        autopilot_setting=hardware.autopilot,
        overrides=overrides,
        tuning=hardware.tuning,
    )


def with_tuning_line(
    report: PreflightReport, hardware: HardwareConfig, vehicle: str, adapters: UavPorts | None
) -> PreflightReport:
    """The pre-flight ``report`` with a last line naming the tuning flown and why (never blocking)."""
    from masonry.adapters.wiring import CheckItem

    item = CheckItem("tuning", True, tuning_choice(hardware, vehicle, adapters).detail(), blocking=False)
    return replace(report, items=(*report.items, item))
