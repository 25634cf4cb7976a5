"""The simulator's rendered-image camera (frames drawn, ArUco decodes them) and the ``mixed`` mode's sample.

``render`` draws every frame; ``mixed`` keeps the fast geometric camera model everywhere except over the pickups of
a sample of the bricks -- :data:`RENDER_SAMPLE_PICKS` of those still to place, evenly spread in blueprint order,
the first among them -- where the brick UAV's camera gives drawn images until the brick has left. So a big wall flies at the geometric camera's
speed while a sample of its picks is identified by decoding images, as on a real UAV (issue 30: a reused marker
number must be told apart from the image, not from the simulator's bookkeeping).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from masonry.ports import CameraFrame

if TYPE_CHECKING:
    from masonry.blueprint import Blueprint, MarkerSpec
    from masonry.sim.bricks import BrickField, SimBrick
    from masonry.sim.camera import CameraConfig

__all__ = ["RENDER_NEAR_M", "RENDER_SAMPLE_PICKS", "over_sampled_pickup", "render_sample", "rendered_frame"]

#: ``mixed``: this many bricks (of those still to place, evenly spread in blueprint order) are picked on drawn
#: images (a drawn frame of a wall's pallet costs ~0.1 s; a pick reads 20-60 of them).
RENDER_SAMPLE_PICKS = 10
#: ... while the camera is within this distance (horizontal, m) of that brick waiting at its pickup.
RENDER_NEAR_M = 0.5


def render_sample(blueprint: Blueprint) -> frozenset[int]:
    """The ids of the bricks picked on drawn images in ``mixed`` mode (the first brick to place among them)."""
    todo = [b.id for b in blueprint.bricks if not b.placed]
    step = max(1, -(-len(todo) // RENDER_SAMPLE_PICKS))
    return frozenset(todo[::step])


def over_sampled_pickup(field: BrickField, sample: frozenset[int], x_m: float, y_m: float) -> bool:
    """Whether a sampled brick still waits at its pickup within :data:`RENDER_NEAR_M` of (x, y)."""
    return any(b.id in sample and b.state == "pickup" for b in field.near(x_m, y_m, RENDER_NEAR_M))


def rendered_frame(
    now_s: float,
    T_wc: np.ndarray,
    bricks: Sequence[SimBrick],
    markers: MarkerSpec,
    config: CameraConfig,
    rng: np.random.Generator,
    hidden: Iterable[int],
) -> CameraFrame:
    """One drawn grey frame of ``bricks`` from the camera pose ``T_wc`` (``hidden``: marker ids not drawn)."""
    from masonry.perception.render import RenderedBrick, render_frame  # OpenCV: only when frames are drawn

    image = render_frame(
        config.intrinsics,
        T_wc,
        [RenderedBrick(b.id, b.position_m, b.yaw_rad, b.size_m, b.blueprint.marker) for b in bricks],
        markers,
        rng=rng,
        blur_sigma_px=config.blur_sigma_px,
        noise_sigma=config.noise_sigma,
        hidden_markers=frozenset(hidden),
    )
    return CameraFrame(time_s=now_s, image=image)
