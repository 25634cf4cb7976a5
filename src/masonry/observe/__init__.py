"""Watching a mission: its MCAP log (``mcap_log``, Foxglove's schemas), the live web view (``web``).

These are the only modules that import the ``mcap`` package (the ``observe`` extra); mission control hands them
its events through :class:`masonry.mission.events.EventSink` and imports none of them.
"""
