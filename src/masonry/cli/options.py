"""The sane range of every numeric command-line option, in one table, and the helpers the commands use.

A value outside its range can only be a mistake (``--dt 1e-6`` ran for minutes and grew to 1.2 GB, ``--wait -1``
waited for nothing): :func:`check` turns it into one line naming the option, the value and the range (exit 2),
and :func:`help_text` appends the range to the option's help so ``--help`` shows it. The ranges are documented
in docs/cli.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from masonry.errors import InputError


@dataclass(frozen=True)
class Bound:
    """A closed range ``[low, high]`` (``low_open``: ``(low, high]``) of an option's value, in ``unit``."""

    low: float
    high: float
    unit: str = ""
    low_open: bool = False
    integer: bool = False

    def text(self) -> str:
        """The range as help and errors show it: ``0.001 to 1 s``, ``> 0 to 100``."""

        def fmt(v: float) -> str:
            return f"{int(v):d}" if self.integer or (float(v).is_integer() and abs(v) < 1e15) else f"{v:g}"

        unit = f" {self.unit}" if self.unit else ""
        low = f"> {fmt(self.low)}" if self.low_open else fmt(self.low)
        return f"{low} to {fmt(self.high)}{unit}"

    def contains(self, value: float) -> bool:
        if not math.isfinite(value):
            return False
        above = value > self.low if self.low_open else value >= self.low
        return above and value <= self.high


_SEED = Bound(0, 2**32 - 1, integer=True)
_UAVS = Bound(0, 100, integer=True)
_TIME_SCALE = Bound(0.0, 100.0, low_open=True)

#: Every numeric option of every command. A key is ``--option`` (the same meaning wherever it appears) or
#: ``command --option`` (an option whose meaning differs between commands); :func:`bound` tries the latter first.
RANGES: dict[str, Bound] = {
    # sim and fly
    "--seed": _SEED,
    "sim --dt": Bound(0.001, 0.2, "s"),  # the physics step: below 1 ms a mission takes hours and gigabytes
    "fly --dt": Bound(0.005, 0.5, "s"),  # the control tick (an autopilot link streams at 10-50 Hz)
    "sim --brick-uavs": _UAVS,
    "sim --adhesion-uavs": _UAVS,
    "schedule --brick-uavs": _UAVS,
    "schedule --adhesion-uavs": _UAVS,
    "schedule --time-limit": Bound(0.0, 86_400.0, "s", low_open=True),
    "schedule --workers": Bound(1, 64, integer=True),
    "sim --time-scale": _TIME_SCALE,  # with --serve
    "fly --timeout": Bound(0.0, 86_400.0, "s", low_open=True),
    "fly --time-scale": _TIME_SCALE,
    "fly --wait": Bound(0.0, 3600.0, "s", low_open=True),
    "fly --heartbeat-timeout": Bound(0.1, 600.0, "s"),
    "fly --estimate-wait": Bound(0.0, 600.0, "s", low_open=True),
    # mission-control
    "mission-control --time-scale": _TIME_SCALE,
    "mission-control --heartbeat-timeout": Bound(0.1, 600.0, "s"),
    "mission-control --startup-timeout": Bound(0.0, 3600.0, "s"),
    "mission-control --max-time": Bound(0.0, 10 * 86_400.0, "s", low_open=True),
    "mission-control --tick": Bound(0.005, 1.0, "s"),
    "--stall-timeout": Bound(0.0, 10 * 86_400.0, "s"),  # 0: no watchdog
    # blueprint generators
    "--courses": Bound(1, 1000, integer=True),
    "--bricks-per-course": Bound(1, 1000, integer=True),
    "--towers": Bound(1, 1000, integer=True),
    "--height": Bound(1, 1000, integer=True),
    "--base": Bound(1, 1000, integer=True),
    "blueprint --spacing": Bound(0.0, 1000.0, "m", low_open=True),
    "--brick-size": Bound(0.01, 2.0, "m"),
    "--joint": Bound(0.0, 0.5, "m"),
    "--yaw": Bound(-2 * math.pi, 2 * math.pi, "rad"),
    "--origin": Bound(-10_000.0, 10_000.0, "m"),
    "--placed-courses": Bound(0, 1000, integer=True),
    "--pallet-columns": Bound(0, 1000, integer=True),
    "--spares": Bound(0, 1000, integer=True),
    "blueprint --brick-uavs": Bound(1, 100, integer=True),
    "blueprint --adhesion-uavs": Bound(1, 100, integer=True),
    "--clearance": Bound(0.0, 50.0, "m", low_open=True),
    "--cruise-altitude": Bound(0.0, 500.0, "m", low_open=True),
    # markers, estimate
    "--marker-size": Bound(0.0, 1.0, "m", low_open=True),
    "--spacing": Bound(0.0, 10.0, "m", low_open=True),
    "--dpi": Bound(30, 2400, integer=True),
    "--frames": Bound(1, 10_000_000, integer=True),
    "estimate --camera": Bound(0, 255, integer=True),
    "ctl --timeout": Bound(0.0, 3600.0, "s", low_open=True),
    # sitl
    "--port": Bound(0, 65535, integer=True),
    "sitl --time-scale": _TIME_SCALE,
}

#: Most bricks a generated blueprint may hold (the planner handles 20,000-brick walls in seconds).
MAX_GENERATED_BRICKS = 100_000


def bound(command: str, option: str) -> Bound:
    """The range of ``option`` in ``command`` (``blueprint`` for its generators)."""
    found = RANGES.get(f"{command} {option}") or RANGES.get(option)
    if found is None:
        # builtin raise: a lookup miss in a static table, as the dict's own (callers and tests expect KeyError)
        raise KeyError(f"no range for {command} {option}")
    return found


def help_text(command: str, option: str, text: str) -> str:
    """``text`` with the option's range appended (what ``--help`` shows)."""
    return f"{text} Range {bound(command, option).text()}."


def check(command: str, option: str, value: float | tuple[float, ...] | None) -> None:
    """Raise InputError (one line, exit 2) if ``value`` (or any of a tuple's) lies outside the option's range."""
    if value is None:
        return
    b = bound(command, option)
    for v in value if isinstance(value, tuple) else (value,):
        if not b.contains(float(v)):
            shown = " ".join(f"{x:g}" for x in value) if isinstance(value, tuple) else f"{value:g}"
            raise InputError(f"{option} {shown}: out of range, expected {b.text()}")


def check_all(command: str, values: dict[str, float | tuple[float, ...] | None]) -> None:
    """:func:`check` for each ``--option: value`` of ``values``, in order."""
    for option, value in values.items():
        check(command, option, value)


def check_choice(option: str, value: str, choices: tuple[str, ...]) -> None:
    """``value`` is one of ``choices``, else one clear line naming ``option`` (exit 2)."""
    if value not in choices:
        raise InputError(f"{option} must be {' or '.join(choices)}, got {value!r}")


def plural(n: int, word: str, many: str | None = None) -> str:
    """``1 task``, ``2 tasks`` (``many``: the irregular plural)."""
    return f"{n} {word if n == 1 else (many or word + 's')}"
