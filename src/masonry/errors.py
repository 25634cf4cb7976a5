"""The one error tree of masonry.

::

    MasonryError
    ├── BlueprintError          a blueprint file or value is invalid (names file, field or id)
    ├── PlanningError           the planner or dispatcher was asked something impossible
    ├── InputError              a command-line input (image, intrinsics, calibration, option) is unusable
    ├── PerceptionError         the vision pipeline cannot run (unknown dictionary, bad calibration)
    ├── InvalidArgument         a library call got a value outside its domain (also a ValueError): a
    │                           VehicleConfig time constant <= 0, a non-finite state to follow
    ├── HardwareError           a port's device failed
    │   ├── DeviceNotFound      the device or endpoint is absent or is not the expected device
    │   ├── CommandRejected     the device answered "no" to a command (carries the reason)
    │   ├── CommandTimeout      the device did not answer in time
    │   └── LinkLost            the link went silent past its watchdog
    └── MissionError            mission control or its transport/journal failed
        ├── ProtocolError       a message is malformed, of another version, or from an unknown UAV
        └── JournalError        the journal cannot be read, written or resumed
            └── JournalUnusable the journal file given cannot serve this mission (corrupt, another
                                program's, read-only, of another wall or fleet, already holding a mission)

Adapters translate library failures at the boundary with ``raise ... from exc``; the CLI
prints ``str(error)`` as one line and exits with status 2 (bad input) or 1 (runtime failure).

Library errors name no command-line flag: an error about a parameter writes its Python name in backticks
(```key_file` /etc/k: not a regular file``) and lists it in ``options``; the CLI translates each into its flag
(``--key-file /etc/k: not a regular file``, :func:`masonry.cli.app.cli_message`).
"""

from __future__ import annotations


class MasonryError(Exception):
    """Base of every error masonry raises on purpose.

    Args:
        options: the parameters the message names, each written in backticks (```key_file```), so a front end
            can name them in its own terms (the CLI's flags).
    """

    def __init__(self, *args: object, options: tuple[str, ...] = ()) -> None:
        super().__init__(*args)
        self.options = tuple(options)


class BlueprintError(MasonryError):
    """A blueprint is invalid: the message names the file, the field or brick id, and the problem."""

    def __init__(self, source: str, where: str, problem: str) -> None:
        self.source = source
        self.where = where
        self.problem = problem
        location = f"{source}: {where}" if where else source
        super().__init__(f"{location}: {problem}")


class PlanningError(MasonryError):
    """The planner or the dispatcher cannot do what was asked."""


class InputError(MasonryError):
    """A command-line input is unusable (unreadable image, malformed intrinsics, bad option)."""


class PerceptionError(MasonryError):
    """The perception pipeline cannot run with the given configuration."""


class InvalidArgument(MasonryError, ValueError):
    """A library call or configuration value is outside its domain (non-finite, non-positive, negative time).

    Also a :class:`ValueError`, so code that caught the ``ValueError`` raised before keeps working.
    """


class HardwareError(MasonryError):
    """A hardware port failed."""


class DeviceNotFound(HardwareError):
    """The device or endpoint is missing, or it is not the device expected."""


class CommandRejected(HardwareError):
    """The device refused a command; ``reason`` says why, ``temporary`` whether the device said to try again."""

    def __init__(
        self, command: str, reason: str, *, options: tuple[str, ...] = (), temporary: bool = False
    ) -> None:
        self.command = command
        self.reason = reason
        self.temporary = temporary
        super().__init__(f"{command} rejected: {reason}", options=options)


class CommandTimeout(HardwareError):
    """The device did not answer a command in time."""


class LinkLost(HardwareError):
    """The link to a device or peer went silent past its watchdog time."""


class MissionError(MasonryError):
    """Mission control, its transport or its journal failed."""


class ProtocolError(MissionError):
    """A message is malformed, of an unsupported version, or from an unknown sender."""


class JournalError(MissionError):
    """The mission journal cannot be read, written or resumed."""


class JournalUnusable(JournalError):
    """The journal file the user gave cannot serve this mission: a bad input (exit 2), not a runtime failure.

    Corrupt or not a journal, a database of another program, read-only or in a location that cannot be
    written, written for another wall or fleet, already holding a mission (without ``--resume``), or missing
    (with ``--resume``). The message names the file.
    """
