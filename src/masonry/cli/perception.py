"""``masonry estimate``, ``masonry markers``, ``masonry calibrate``: the vision pipeline from the command line."""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from masonry.blueprint import DEFAULT_BRICK_SIZE_M, MarkerSpec
from masonry.cli.app import command
from masonry.cli.options import check_all, help_text, plural
from masonry.cli.outputs import atomic_path, check_output_path
from masonry.errors import DeviceNotFound, InputError

_MARKERS = MarkerSpec()  # the options' defaults are the blueprint's marker defaults

if TYPE_CHECKING:
    import numpy as np

    from masonry.perception.types import CameraIntrinsics

VIDEO_SUFFIXES = (".avi", ".mp4", ".mkv", ".mov", ".webm", ".mpg", ".mpeg", ".m4v", ".wmv")


def parse_floats(option: str, text: str, count: int | tuple[int, ...], what: str) -> tuple[float, ...]:
    """Parse ``a,b,c`` into finite floats, ``count`` of them (or one of the counts given).

    Raises:
        InputError: naming the option, what was expected and what was given.
    """
    counts = (count,) if isinstance(count, int) else count
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) not in counts or not all(math.isfinite(v) for v in values):
        n = " or ".join(str(c) for c in counts)
        raise InputError(f"{option}: expected {what} ({n} comma-separated numbers), got {text!r}")
    return values


def build_intrinsics(
    intrinsics: str | None, distortion: str | None, calibration: Path | None
) -> CameraIntrinsics:
    """Camera intrinsics from ``--calibration`` and/or ``--intrinsics`` / ``--distortion`` (these override it)."""
    from dataclasses import replace

    from masonry.perception.calibration import read_calibration
    from masonry.perception.types import CameraIntrinsics

    if intrinsics is None and calibration is None:
        raise InputError("give the camera: --intrinsics fx,fy,cx,cy or --calibration FILE")
    base = read_calibration(calibration) if calibration is not None else None
    if intrinsics is not None:
        fx, fy, cx, cy = parse_floats("--intrinsics", intrinsics, 4, "fx,fy,cx,cy in pixels")
        if fx <= 0 or fy <= 0:
            raise InputError(f"--intrinsics: fx and fy must be > 0, got {intrinsics!r}")
        if base is None:
            base = CameraIntrinsics(fx, fy, cx, cy)
        else:
            base = replace(base, fx=fx, fy=fy, cx=cx, cy=cy)
    assert base is not None
    if distortion is not None:
        coeffs = parse_floats("--distortion", distortion, (4, 5, 8), "k1,k2,p1,p2[,k3[,k4,k5,k6]]")
        base = replace(base, distortion=coeffs)
    return base


def _frames(
    inputs: list[Path], camera: int | None, max_frames: int | None
) -> Iterator[tuple[Any, np.ndarray]]:
    """(label, image) pairs: image files by path, a video's frames by index, or a live camera's frames."""
    import cv2

    if camera is not None:
        if inputs:
            raise InputError("give either INPUT files or --camera INDEX, not both")
        cap = _quietly(lambda: cv2.VideoCapture(camera))
        if not cap.isOpened():
            raise DeviceNotFound(f"camera {camera}: cannot open it (is it connected and free?)")
        yield from _capture_frames(cap, max_frames)
        return
    if not inputs:
        raise InputError("give INPUT image files, a video file, or --camera INDEX")
    for p in inputs:
        if not p.is_file():
            raise InputError(f"{p}: no such file")
    videos = [p for p in inputs if p.suffix.lower() in VIDEO_SUFFIXES]
    if videos:
        if len(inputs) > 1:
            raise InputError(f"{videos[0]}: a video must be the only INPUT")
        cap = _quietly(lambda: cv2.VideoCapture(str(videos[0])))
        if not cap.isOpened():
            raise InputError(f"{videos[0]}: cannot open as a video (unsupported codec or not a video)")
        first = True
        for label, image in _capture_frames(cap, max_frames):
            first = False
            yield label, image
        if first:
            raise InputError(f"{videos[0]}: the video holds no readable frame")
        return
    for n, p in enumerate(inputs):
        if max_frames is not None and n >= max_frames:
            return
        still = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        if still is None:
            raise InputError(f"{p}: cannot read the image (not an image file, or an unsupported format)")
        yield str(p), still


def _quietly(open_capture: Any) -> Any:
    """Run ``open_capture`` with OpenCV's warnings silenced: a failure becomes our one-line error instead."""
    import cv2

    previous = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    try:
        return open_capture()
    finally:
        cv2.utils.logging.setLogLevel(previous)


def _capture_frames(cap: Any, max_frames: int | None) -> Iterator[tuple[int, np.ndarray]]:
    import cv2

    index = 0
    try:
        while max_frames is None or index < max_frames:
            ok, frame = cap.read()
            if not ok or frame is None:
                return
            yield index, cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if frame.ndim == 3 else frame
            index += 1
    finally:
        cap.release()


@command("estimate")
def estimate(
    inputs: list[Path] = typer.Argument(None, help="Image files, or one video file.", show_default=False),
    camera: int | None = typer.Option(
        None, "--camera", help=help_text("estimate", "--camera", "Live camera index (instead of INPUT).")
    ),
    intrinsics: str | None = typer.Option(None, "--intrinsics", help="fx,fy,cx,cy in pixels."),
    distortion: str | None = typer.Option(None, "--distortion", help="k1,k2,p1,p2,k3 (OpenCV model)."),
    calibration: Path | None = typer.Option(
        None, "--calibration", help="OpenCV FileStorage YAML from `masonry calibrate`."
    ),
    marker_size: float = typer.Option(
        _MARKERS.size_m,
        "--marker-size",
        help=help_text("estimate", "--marker-size", "Marker side (black border included), metres."),
    ),
    spacing: float = typer.Option(
        _MARKERS.spacing_m,
        "--spacing",
        help=help_text("estimate", "--spacing", "Distance between a brick's two marker centres, m."),
    ),
    dictionary: str = typer.Option(_MARKERS.dictionary, "--dictionary", help="OpenCV ArUco dictionary name."),
    up: str | None = typer.Option(
        None,
        "--up",
        help="x,y,z normal of the bricks' plane in the camera frame (default: the optical axis, 0,0,1).",
    ),
    fmt: str = typer.Option("text", "--format", help="text | json (one JSON object per frame and line)."),
    frames: int | None = typer.Option(
        None, "--frames", help=help_text("estimate", "--frames", "Stop after this many frames.")
    ),
) -> None:
    """Estimate brick poses (top-face centre, yaw) from ArUco markers, in the camera frame (x right, y down, z fwd)."""
    from masonry.blueprint import MarkerSpec
    from masonry.perception.aruco import aruco_dictionary, estimate_bricks
    from masonry.perception.estimation import EstimatorConfig, PoseWindow

    if fmt not in ("text", "json"):
        raise InputError(f"--format must be text or json, got {fmt!r}")
    check_all("estimate", {"--camera": camera, "--frames": frames})
    if not (0.0 < marker_size < 1.0):
        raise InputError(f"--marker-size: {marker_size} m is out of range (0, 1) m")
    if not (marker_size < spacing < 10.0):
        raise InputError(f"--spacing: {spacing} m must exceed the marker size ({marker_size} m)")
    if frames is not None and frames < 1:
        raise InputError(f"--frames must be >= 1, got {frames}")
    up_vec = (0.0, 0.0, 1.0)
    if up is not None:
        ux, uy, uz = parse_floats("--up", up, 3, "x,y,z")
        if math.hypot(ux, uy, uz) < 1e-9:
            raise InputError(f"--up: the vector must not be zero, got {up!r}")
        up_vec = (ux, uy, uz)
    aruco_dictionary(dictionary)  # unknown dictionary: fail before reading anything
    markers = MarkerSpec(dictionary=dictionary, size_m=marker_size, spacing_m=spacing)
    config = EstimatorConfig(spacing_m=spacing, up=up_vec)
    intr = build_intrinsics(intrinsics, distortion, calibration)
    windows: dict[int, PoseWindow] = {}
    for label, image in _frames(list(inputs or []), camera, frames):
        h, w = image.shape[:2]
        if (intr.width_px, intr.height_px) != (w, h):
            from dataclasses import replace

            intr = replace(intr, width_px=w, height_px=h)
        bricks = []
        for est in estimate_bricks(image, intr, markers, config):
            window = windows.setdefault(est.brick_id, PoseWindow())
            window.add(est.center_m, est.yaw_rad)
            confidence = window.confidence()
            bricks.append(
                {
                    "id": est.brick_id,
                    "center": [round(float(v), 5) for v in est.center_m],
                    "yaw": round(float(est.yaw_rad), 5),
                    "tags": list(est.tags),
                    "confidence": None if confidence is None else round(float(confidence), 4),
                }
            )
        if fmt == "json":
            typer.echo(json.dumps({"frame": label, "bricks": bricks}))
        else:
            typer.echo(_text_line(label, bricks))


def _text_line(label: Any, bricks: list[dict[str, Any]]) -> str:
    if not bricks:
        return f"{label}: no brick"
    parts = []
    for b in bricks:
        x, y, z = b["center"]
        conf = "-" if b["confidence"] is None else f"{b['confidence']:.2f}"
        tags = ",".join(str(t) for t in b["tags"])
        parts.append(
            f"brick {b['id']} at ({x:+.4f}, {y:+.4f}, {z:.4f}) m yaw {math.degrees(b['yaw']):+.2f} deg "
            f"tags {tags} confidence {conf}"
        )
    return f"{label}: " + "; ".join(parts)


@command("markers")
def markers_cmd(
    bricks: str = typer.Option(
        ..., "--bricks", help="Brick ids, e.g. 0-9 or 0,2,5-7 (brick k: markers 2k, 2k+1)."
    ),
    output: Path = typer.Option(..., "-o", "--output", help="FILE.pdf (one page per brick) or FILE.png."),
    marker_size: float = typer.Option(
        _MARKERS.size_m, "--marker-size", help=help_text("markers", "--marker-size", "Marker side, metres.")
    ),
    spacing: float = typer.Option(
        _MARKERS.spacing_m,
        "--spacing",
        help=help_text("markers", "--spacing", "Distance between the two marker centres, metres."),
    ),
    dictionary: str = typer.Option(_MARKERS.dictionary, "--dictionary", help="OpenCV ArUco dictionary name."),
    brick_size: str = typer.Option(
        ",".join(f"{v:.2f}" for v in DEFAULT_BRICK_SIZE_M),
        "--brick-size",
        help="Brick length,width,height, metres.",
    ),
    paper: str = typer.Option("a4", "--paper", help="a4 | a3 | letter (landscape)."),
    dpi: int = typer.Option(300, "--dpi", help=help_text("markers", "--dpi", "Resolution of PNG output.")),
) -> None:
    """Write printable true-scale marker sheets: each brick's outline with its two markers in place."""
    from masonry.blueprint import MarkerSpec
    from masonry.perception.markers_sheet import parse_id_ranges, write_marker_sheets

    check_output_path(output, "--output")
    check_all("markers", {"--marker-size": marker_size, "--spacing": spacing, "--dpi": dpi})
    ids = parse_id_ranges(bricks)
    size = parse_floats("--brick-size", brick_size, 3, "length,width,height in metres")
    if min(size) <= 0:
        raise InputError(f"--brick-size: every dimension must be > 0, got {brick_size!r}")
    spec = MarkerSpec(dictionary=dictionary, size_m=marker_size, spacing_m=spacing)
    if output.suffix.lower() == ".pdf" or len(ids) == 1:
        with atomic_path(output, "--output") as tmp:
            write_marker_sheets(
                tmp, ids, spec, brick_size_m=(size[0], size[1], size[2]), paper=paper, dpi=dpi
            )
        written = [output]
    else:  # one PNG per brick, named after the output
        written = write_marker_sheets(
            output, ids, spec, brick_size_m=(size[0], size[1], size[2]), paper=paper, dpi=dpi
        )
    for p in written:
        typer.echo(f"wrote {p}")
    typer.echo(
        f"{plural(len(ids), 'brick')}, markers {2 * ids[0]}..{2 * ids[-1] + 1} of {dictionary}; print at 100 %"
    )


@command("calibrate")
def calibrate(
    images: list[Path] = typer.Argument(..., help="Images of the chessboard from varied angles."),
    board: str = typer.Option(
        "chessboard:9x6:0.025",
        "--board",
        help="chessboard:COLSxROWS:SQUARE_M (inner corners, square side in metres).",
    ),
    output: Path = typer.Option(
        ..., "-o", "--output", help="Calibration to write (OpenCV FileStorage YAML)."
    ),
) -> None:
    """Calibrate the camera from chessboard images; write OpenCV FileStorage YAML for `estimate --calibration`."""
    import cv2

    from masonry.perception.calibration import calibrate_chessboard, parse_board, write_calibration

    check_output_path(output, "--output")
    spec = parse_board(board)
    loaded = []
    for p in images:
        if not p.is_file():
            raise InputError(f"{p}: no such file")
        grey = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        if grey is None:
            raise InputError(f"{p}: cannot read the image (not an image file, or an unsupported format)")
        loaded.append((str(p), grey))
    result = calibrate_chessboard(loaded, spec)
    with atomic_path(output, "--output") as tmp:
        write_calibration(tmp, result.intrinsics, rms_px=result.rms_px, image_count=len(result.used))
    i = result.intrinsics
    typer.echo(
        f"board found in {len(result.used)} of {len(images)} images; RMS reprojection error "
        f"{result.rms_px:.3f} px"
    )
    for name in result.rejected:
        typer.echo(f"  skipped {name}: board not found")
    typer.echo(
        f"fx {i.fx:.2f} fy {i.fy:.2f} cx {i.cx:.2f} cy {i.cy:.2f} px, distortion "
        + ",".join(f"{k:.5f}" for k in i.distortion)
    )
    typer.echo(f"wrote {output}")
