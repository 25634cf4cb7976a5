"""A Foxglove layout for a mission (``docs/foxglove_layout.json``), built with the Foxglove SDK's own layout types
(``foxglove.layouts``): the 3-D panel (wall, airspace, UAVs, paths), the batteries' plot, the UAVs' states over
time, the log, and the mission events. It works for a log (``--log``) and a live connection (``--foxglove``)."""

from __future__ import annotations

from collections.abc import Sequence

import foxglove.layouts as fl

from masonry.observe.scene import WORLD_FRAME

#: The UAVs ``docs/foxglove_layout.json`` names (the case study's and running_bond_small's fleets).
DOC_UAVS = ("brick-1", "brick-2", "glue-1", "glue-2")


def foxglove_layout(uavs: Sequence[str] = DOC_UAVS) -> str:
    """The layout (Foxglove's layout JSON) for a fleet of ``uavs``."""
    scene = fl.BaseRendererSceneUpdateTopicSettings(visible=True)
    topics: dict[str, fl.BaseRendererTopicSettings] = {"/wall": scene, "/airspace": scene, "/paths": scene}
    for u in uavs:
        topics[f"/uav/{u}/pose"] = fl.BaseRendererPoseTopicSettings(visible=True, type="axis", axis_scale=0.5)
    three_d = fl.ThreeDeePanel(
        title="wall, airspace and UAVs",
        config=fl.ThreeDeeConfig(fixed_frame=WORLD_FRAME, follow_tf=WORLD_FRAME, topics=topics),
    )
    batteries = fl.PlotPanel(
        title="batteries (0..1)",
        config=fl.PlotConfig(paths=[fl.PlotSeries(value=f"/uav/{u}/state.battery", label=u) for u in uavs]),
    )
    phases = fl.StateTransitionsPanel(
        title="UAV states (phases)",
        config=fl.StateTransitionsConfig(
            paths=[fl.StateTransitionsSeries(value=f"/uav/{u}/state.state", label=u) for u in uavs]
        ),
    )
    log = fl.LogPanel(title="mission log", config=fl.LogConfig(topic_to_render="/log"))
    events = fl.RawMessagesPanel(
        title="mission events", config=fl.RawMessagesConfig(topic_path="/mission/events")
    )
    right = fl.SplitContainer(
        direction="column",
        items=[fl.SplitItem(content=batteries), fl.SplitItem(content=phases), fl.SplitItem(content=log)],
    )
    left = fl.SplitContainer(
        direction="column", items=[fl.SplitItem(proportion=3, content=three_d), fl.SplitItem(content=events)]
    )
    layout = fl.Layout(
        content=fl.SplitContainer(
            direction="row",
            items=[fl.SplitItem(proportion=3, content=left), fl.SplitItem(proportion=2, content=right)],
        )
    )
    return layout.to_json()


__all__ = ["DOC_UAVS", "foxglove_layout"]
