"""Which control preset a UAV flies, and why: the user's ``control_preset:``, else its autopilot's (issue 29).

A real autopilot names itself in its HEARTBEAT (``MAV_AUTOPILOT_ARDUPILOTMEGA`` or ``MAV_AUTOPILOT_PX4``): the
preset fitted to it (:data:`AUTOPILOT_PRESETS`) is the tuning a new user gets without writing one. A simulated
autopilot flies the preset of its simulated vehicle (``--vehicle``). The user's ``control_preset:`` wins over
both; ``control:`` and ``pid:`` are laid over whichever preset is chosen (:func:`masonry.fsm.tuning.uav_settings`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

#: uav.yaml's ``tuning:``: ``identify`` the position gains on the first hover (masonry.fsm.first_hover), or fly the
#: ``preset``'s. The default: see :data:`DEFAULT_TUNING`.
TUNINGS = ("preset", "identify")
DEFAULT_TUNING = "preset"

#: The preset fitted to each autopilot (docs/hardware.md "Control on ArduCopter", "PX4 on GNSS").
AUTOPILOT_PRESETS: Mapping[str, str] = {"ardupilot": "arducopter", "px4": "px4"}
_AUTOPILOT_NAMES: Mapping[str, str] = {"ardupilot": "ArduPilot", "px4": "PX4"}


@dataclass(frozen=True)
class TuningChoice:
    """The preset a UAV flies, why, and the user's settings laid over it."""

    preset: str
    reason: str
    overrides: tuple[str, ...] = ()  # the uav.yaml keys laid over the preset (control, pid, velocity_lag_s)
    identify: bool = False  # the position gains are identified on the first hover (the preset's if unusable)
    identify_note: str = ""  # why (not): ``tuning: identify`` of uav.yaml, or what won over it

    def detail(self) -> str:
        """One line for the pre-flight check: ``arducopter (ArduPilot autopilot, from its HEARTBEAT)``."""
        over = (
            f"; {', '.join(f'`{k}:`' for k in self.overrides)} of uav.yaml over it" if self.overrides else ""
        )
        line = f"control preset {self.preset} ({self.reason}){over}"
        if self.identify:
            return line + (
                f"; position gains identified on the first hover ({self.identify_note}), the preset's if unusable"
            )
        return line + (f"; {self.identify_note}" if self.identify_note else "")


def choose_tuning(
    control_preset: str | None,
    *,
    autopilot: str | None,
    vehicle: str = "ideal",
    autopilot_setting: str = "auto",
    overrides: tuple[str, ...] = (),
    tuning: str = DEFAULT_TUNING,
) -> TuningChoice:
    """The preset to fly: ``control_preset`` when the user names one, else the autopilot's, else ``vehicle``'s.

    Args:
        control_preset: uav.yaml's ``control_preset:`` (None when it names none).
        autopilot: the connected autopilot (``"ardupilot"``, ``"px4"``), None for a simulated one.
        vehicle: the simulated vehicle's preset (``--vehicle``), flown on a simulated autopilot.
        autopilot_setting: uav.yaml's ``autopilot:`` (``"auto"``: read from the HEARTBEAT).
        overrides: the uav.yaml keys laid over the preset, for the line the pre-flight prints.
        tuning: uav.yaml's ``tuning:`` (:data:`TUNINGS`): ``identify`` unless ``control_preset`` or a ``pid``
            override is given (the user's gains win: no identification then).
    """
    if control_preset is not None:
        choice = TuningChoice(control_preset, "`control_preset:` of uav.yaml", overrides)
    elif autopilot is not None and autopilot in AUTOPILOT_PRESETS:
        source = "from its HEARTBEAT" if autopilot_setting == "auto" else "`autopilot:` of uav.yaml"
        choice = TuningChoice(
            AUTOPILOT_PRESETS[autopilot], f"{_AUTOPILOT_NAMES[autopilot]} autopilot, {source}", overrides
        )
    else:
        choice = TuningChoice(vehicle, f"the simulated vehicle's (--vehicle {vehicle})", overrides)
    if tuning != "identify":
        return choice
    won = [
        k
        for k, given in (("control_preset", control_preset is not None), ("pid", "pid" in overrides))
        if given
    ]
    if won:
        return replace(choice, identify_note=f"`{'`/`'.join(won)}:` of uav.yaml wins over `tuning: identify`")
    return replace(choice, identify=True, identify_note="`tuning: identify` of uav.yaml")
