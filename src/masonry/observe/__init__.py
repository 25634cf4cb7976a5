"""Watching a mission: its MCAP log (``mcap_log``), the live Foxglove server (``live``), both writing the
messages of ``scene`` (Foxglove's own, from its SDK, and masonry's), and the live web view (``web``).

Only ``mcap_log`` imports the ``mcap`` package, and only ``scene``, ``mcap_log`` and ``live`` the Foxglove SDK
(the ``observe`` extra); mission control hands them its events through
:class:`masonry.mission.events.EventSink` and imports none of them.
"""
