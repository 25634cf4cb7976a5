"""``--log FILE.mcap``, ``--serve [HOST:]PORT`` and ``--foxglove [HOST:]PORT`` of a running mission (``masonry
sim``, ``masonry mission-control``): the log, the live page and the live Foxglove server, event sinks of mission
control (docs/observe.md)."""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from masonry.cli.foxglove_options import loopback
from masonry.errors import InputError
from masonry.mission.table_events import watch_table

if TYPE_CHECKING:  # (the observe extra's modules load only when a mission is watched)
    from masonry.blueprint import UavSpec
    from masonry.cli.foxglove_options import FoxgloveAt
    from masonry.mission.control import MissionControl
    from masonry.mission.report import MissionReport
    from masonry.mission.view import MissionView
    from masonry.observe.live import FoxgloveLive
    from masonry.observe.mcap_log import McapLog
    from masonry.observe.web import ViewServer
    from masonry.planner.tasks import Plan

#: An operator's command (``masonry ctl``'s fields) to its acknowledgement.
Commands = Callable[[Mapping[str, Any]], Mapping[str, Any]]


def check_log_option(log: Path | None) -> Path | None:
    """``--log``, if given, must name a ``.mcap`` file (returned as given)."""
    if log is not None and log.suffix.lower() != ".mcap":
        raise InputError(f"--log {log}: the file must end in .mcap")
    return log


def open_log(path: Path, plan: Plan, blueprint: Path, name: str, command: str) -> McapLog:
    """The MCAP log of a mission (``--log``), to open: it records the blueprint file's text for ``masonry replay``."""
    try:
        from masonry.observe.mcap_log import McapLog
    except ImportError as exc:  # the `observe` extra is not installed
        raise InputError(f"--log needs the mcap package (pip install 'masonry[observe]'): {exc}") from None
    from masonry.blueprint_yaml import read_text_limited

    return McapLog(
        path, plan, read_text_limited(blueprint), title=name, command=f"masonry {command} {blueprint}"
    )


class Watchers:
    """The log and the live view of one mission: :meth:`attach` to mission control, :meth:`finish`, :meth:`close`.

    Args:
        log: ``--log`` (None: no log).
        serve: ``--serve`` as (host, port) (None: no page).
        blueprint: the blueprint file (its text goes into the log), name: the mission's name.
        command: ``sim`` or ``mission-control``.
        commands: takes an operator's command from the page (None: the page has no buttons).
        foxglove: ``--foxglove`` (None: no Foxglove server).
    """

    def __init__(
        self,
        log: Path | None,
        serve: tuple[str, int] | None,
        blueprint: Path,
        name: str,
        command: str,
        commands: Commands | None = None,
        foxglove: FoxgloveAt | None = None,
    ) -> None:
        self.log_path = log
        self.serve = serve
        self.blueprint = blueprint
        self.name = name
        self.command = command
        self.commands = commands
        self.log: McapLog | None = None
        self.view: MissionView | None = None
        self.server: ViewServer | None = None
        self.foxglove = foxglove
        self.live: FoxgloveLive | None = None

    def attach(self, control: MissionControl, plan: Plan, fleet: Sequence[UavSpec]) -> None:
        """Open the log, start the page, and make them mission control's event sink."""
        from masonry.mission.events import EventFanout, EventSink

        sinks: list[EventSink] = []
        # the tasks a resumed mission did before (the plan's own done ones, bricks placed beforehand, aside)
        done = set(control.dispatcher.done) - {t.id for t in plan.tasks if t.done}
        if self.log_path is not None:
            self.log = open_log(self.log_path, plan, self.blueprint, self.name, self.command)
            self.log.done = done
            self.log.open()
            sinks.append(self.log)
        if self.serve is not None:
            from masonry.mission.view import MissionView, wall_layout
            from masonry.observe.web import ViewServer

            self.view = MissionView([t.id for t in plan.tasks if not t.done], done=done)
            view = self.view
            commands = self.commands
            if commands is None and loopback(self.serve[0]):
                # the page's buttons: on loopback only (the page is not authenticated; docs/observe.md)
                commands = operator_commands(control)
            self.server = ViewServer(
                *self.serve,
                layout=wall_layout(plan, fleet, self.name),
                state=lambda _t: {**view.snapshot(), "paused": bool(control.operator.paused)},
                version=lambda: view.events * 2 + int(bool(control.operator.paused)),
                commands=commands,
            ).start()
            sinks.append(self.view)
            typer.echo(f"serving the mission's page at {self.server.url}", err=True)
        if self.foxglove is not None:
            self.live = self._start_foxglove(self.foxglove, control, plan, fleet, done)
            sinks.append(self.live)
        control.sink = sinks[0] if len(sinks) == 1 else (EventFanout(*sinks) if sinks else None)
        if sinks:  # (--airspace table: its reservations as they are made, moved and released)
            watch_table(control)

    def _start_foxglove(
        self, at: FoxgloveAt, control: MissionControl, plan: Plan, fleet: Sequence[UavSpec], done: set[str]
    ) -> FoxgloveLive:
        """The live Foxglove server (``--foxglove``): the log's channels; on loopback the operator's services."""
        try:
            from masonry.observe.live import FoxgloveLive
        except ImportError as exc:  # the `observe` extra is not installed
            raise InputError(
                f"--foxglove needs the foxglove-sdk package (pip install 'masonry[observe]'): {exc}"
            ) from None
        from masonry.blueprint_yaml import read_text_limited

        live = FoxgloveLive(
            at.host,
            at.port,
            plan,
            read_text_limited(self.blueprint),
            title=self.name,
            command=f"masonry {self.command} {self.blueprint}",
            uavs=[u.name for u in fleet],
            commands=(self.commands or operator_commands(control)) if at.steer else None,
            tls=at.tls,
        )
        live.done = done
        live.start()
        typer.echo(f"serving the mission to Foxglove at {live.url} (Open connection)", err=True)
        return live

    def finish(self, result: MissionReport, extra: Mapping[str, Any] | None = None) -> None:
        """The mission's report into the log (and to Foxglove)."""
        if self.log is not None:
            self.log.finish(result, extra)
        if self.live is not None:
            self.live.finish(result, extra)

    def close(self) -> None:
        """Close the log (the page stays up until :meth:`linger` or :meth:`stop`)."""
        if self.log is not None:
            self.log.close()
            self.log = None
            typer.echo(f"wrote {self.log_path}", err=True)

    def linger(self, until: threading.Event | None = None) -> None:
        """With a page or Foxglove: keep serving the mission's last state until Ctrl-C (or ``until`` is set), then
        stop."""
        if self.server is None and self.live is None:
            return
        done = until or threading.Event()
        urls = " and ".join(x.url for x in (self.server, self.live) if x is not None)
        what = (
            "page stays"
            if self.live is None
            else "page and Foxglove server stay"
            if self.server
            else "Foxglove server stays"
        )
        try:  # (before the line: Ctrl-C may come as soon as it is read)
            typer.echo(f"the mission is over; its {what} up at {urls}: Ctrl-C to stop", err=True)
            while not done.wait(0.5):
                pass
        except KeyboardInterrupt:
            pass
        self.stop()

    def stop(self) -> None:
        if self.server is not None:
            self.server.stop()
            self.server = None
        if self.live is not None:
            self.live.stop()
            self.live = None


def operator_commands(control: MissionControl) -> Commands:
    """An operator's command from the page or Foxglove, to mission control's desk (as ``masonry ctl``'s)."""

    def commands(c: Mapping[str, Any]) -> Mapping[str, Any]:
        if control.ended_at_s is not None:
            return {"accepted": False, "reason": "the mission is over"}
        return dict(control.operator.ask(c).to_dict())

    return commands
