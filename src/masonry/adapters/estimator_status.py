"""What an autopilot's estimator flags mean, per autopilot (pure values; issue 20).

ArduPilot reports EKF_STATUS_REPORT (``EKF_STATUS_FLAGS``, ardupilotmega.xml), PX4 ESTIMATOR_STATUS
(``ESTIMATOR_STATUS_FLAGS``, common.xml). The bits agree up to 512 (attitude 1, horizontal and vertical velocity
2 and 4, relative and absolute horizontal position 8 and 16, vertical position 32, height above ground 64,
constant-position mode 128, predicted relative and absolute horizontal position 256 and 512) and differ above
(ArduPilot: 1024 EKF_UNINITIALIZED, 32768 EKF_GPS_GLITCHING; PX4: 1024 GPS_GLITCH, 2048 ACCEL_ERROR).

They also differ in what constant-position mode (128) says:

- ArduPilot's EKF enters it when it has no position source: it does not know where it is (0xa7 while
  converging: attitude, velocities, vertical position, constant-position mode; 0x33f when ready).
- PX4's EKF2 sets it whenever the vehicle is at rest, even with GNSS fused: ``const_pos_mode = fake_pos ||
  valid_fake_pos || vehicle_at_rest`` (src/modules/ekf2/EKF/ekf_helper.cpp, PX4 v1.16; EKF2 fuses a zero
  position change at rest to align its tilt). PX4 v1.16 SITL on the ground reports 0x3FF, every bit up to 512;
  after arming 895 (0x37F) and 831 (0x33F): the bit clears once the vehicle moves. So on the ground it is no
  reason to refuse; in flight (no longer at rest) it means EKF2 is in fact flying on a fake position.

Absolute horizontal position (16) is never required: indoors, with motion capture, there is none.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = [
    "ARDUPILOT_EKF",
    "PX4_EKF2",
    "EstimatorSemantics",
    "describe_flags",
    "estimator_semantics",
    "flags_usable",
]

#: Attitude, horizontal and vertical velocity, relative horizontal position, vertical position.
REQUIRED = 1 | 2 | 4 | 8 | 32

_COMMON_NAMES = {
    1: "attitude",
    2: "horizontal velocity",
    4: "vertical velocity",
    8: "relative horizontal position",
    32: "vertical position",
    128: "constant-position mode",
}


@dataclass(frozen=True)
class EstimatorSemantics:
    """One autopilot's estimator flags: which must be set, which disqualify, which disqualify only in flight."""

    autopilot: str
    message: str
    required: int = REQUIRED
    bad: int = 0  # disqualifying always
    bad_in_flight: int = 0  # disqualifying off the ground only (PX4: constant-position mode is "at rest")
    names: dict[int, str] = field(default_factory=dict)

    def usable(self, flags: int, *, on_ground: bool = True) -> bool:
        """Whether ``flags`` describe a position estimate fit to fly on (``on_ground``: the vehicle is at rest)."""
        bad = self.bad if on_ground else self.bad | self.bad_in_flight
        return flags & self.required == self.required and not flags & bad

    def describe(self, flags: int, *, on_ground: bool = True) -> str:
        """What ``flags`` lack for flight, in words: ``EKF flags 0x00a7: missing relative horizontal ...``."""
        bad = self.bad if on_ground else self.bad | self.bad_in_flight
        missing = [name for bit, name in self.names.items() if bit & self.required and not flags & bit]
        wrong = [name for bit, name in self.names.items() if bit & bad and flags & bit]
        parts = []
        if missing:
            parts.append("missing " + ", ".join(missing))
        if wrong:
            parts.append(", ".join(wrong))
        return f"EKF flags 0x{flags:04x}" + (": " + "; ".join(parts) if parts else ": usable")


ARDUPILOT_EKF = EstimatorSemantics(
    "ardupilot",
    "EKF_STATUS_REPORT",
    bad=128 | 1024 | 32768,
    names={**_COMMON_NAMES, 1024: "not initialised", 32768: "GPS glitching"},
)
PX4_EKF2 = EstimatorSemantics(
    "px4",
    "ESTIMATOR_STATUS",
    bad=1024 | 2048,
    bad_in_flight=128,
    names={
        **_COMMON_NAMES,
        128: "constant-position mode in flight",
        1024: "GPS glitch",
        2048: "accelerometer error",
    },
)


def estimator_semantics(autopilot: str | None) -> EstimatorSemantics:
    """The semantics of ``autopilot`` (``"px4"``; anything else, and None before a heartbeat: ArduPilot's)."""
    return PX4_EKF2 if autopilot == "px4" else ARDUPILOT_EKF


def flags_usable(flags: int, autopilot: str | None = "ardupilot", *, on_ground: bool = True) -> bool:
    """Whether ``autopilot``'s estimator ``flags`` describe a position estimate fit to fly on."""
    return estimator_semantics(autopilot).usable(flags, on_ground=on_ground)


def describe_flags(flags: int, autopilot: str | None = "ardupilot", *, on_ground: bool = True) -> str:
    """What ``autopilot``'s estimator ``flags`` lack for flight, in words."""
    return estimator_semantics(autopilot).describe(flags, on_ground=on_ground)
