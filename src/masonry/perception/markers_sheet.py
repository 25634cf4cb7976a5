"""Printable marker sheets at true scale: one page per brick with its top-face outline and its two markers.

Each page shows, at 1:1, the brick's top face seen from above (length along the page's width), its centre and
+x arrow, and markers 2k (at +spacing/2 along +x) and 2k+1 (at -spacing/2), each on a white sticker one cell
wider than the marker on every side (the same sticker the renderer draws), with a thin cut line. A 100 mm scale
bar lets you check the print: print at 100 % ("actual size"), never "fit to page".

PDF: one page per brick, page size = the paper in inches (matplotlib figure size), so the vector geometry is
exact. PNG: the same pages rasterised at ``dpi``; one file when one brick, else ``<stem>-brick<k>.png``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from masonry.blueprint import DEFAULT_BRICK_SIZE_M, MarkerSpec
from masonry.errors import InputError, PerceptionError

__all__ = ["PAPER_SIZES_MM", "parse_id_ranges", "write_marker_sheets"]

#: Landscape paper sizes (width, height) in millimetres.
PAPER_SIZES_MM: dict[str, tuple[float, float]] = {
    "a4": (297.0, 210.0),
    "a3": (420.0, 297.0),
    "letter": (279.4, 215.9),
}
_MARGIN_MM = 8.0
_MM_PER_INCH = 25.4


def parse_id_ranges(text: str) -> list[int]:
    """Parse brick ids like ``0-9``, ``3``, ``0-3,7,10-12`` into a sorted list without duplicates.

    Raises:
        InputError: malformed text, a negative id, or a range that runs backwards.
    """
    ids: set[int] = set()
    for part in text.split(","):
        part = part.strip()
        try:
            if "-" in part:
                lo_text, hi_text = part.split("-", 1)
                lo, hi = int(lo_text), int(hi_text)
                if hi < lo:
                    raise InputError(f"`bricks`: range {part!r} runs backwards", options=("bricks",))
                if (
                    hi - lo >= 100_000
                ):  # no ArUco dictionary has 200,000 markers: fail before building the set
                    raise InputError(
                        f"`bricks`: range {part!r} holds more than 100000 bricks", options=("bricks",)
                    )
                ids.update(range(lo, hi + 1))
            else:
                ids.add(int(part))
        except ValueError:
            raise InputError(
                f"`bricks`: expected ids like 0-9 or 0,2,5-7; got {text!r}", options=("bricks",)
            ) from None
    if any(i < 0 for i in ids):
        raise InputError(f"`bricks`: ids must be >= 0; got {text!r}", options=("bricks",))
    return sorted(ids)


def _marker_bits(dictionary: str, marker_id: int) -> np.ndarray:
    """The marker as a (cells, cells) 0/255 image, one pixel per cell (black border included)."""
    import cv2

    from masonry.perception.aruco import aruco_dictionary

    d = aruco_dictionary(dictionary)
    count = d.bytesList.shape[0]
    if not 0 <= marker_id < count:
        raise PerceptionError(f"marker id {marker_id} is not in {dictionary} (ids 0..{count - 1})")
    cells = d.markerSize + 2
    return cv2.aruco.generateImageMarker(d, marker_id, cells, borderBits=1)


def _draw_page(
    fig: object,
    brick_id: int,
    markers: MarkerSpec,
    brick_size_m: tuple[float, float, float],
    paper_mm: tuple[float, float],
) -> None:
    from matplotlib.patches import FancyArrow, Rectangle

    pw, ph = paper_mm
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))  # type: ignore[attr-defined]
    ax.set_xlim(0.0, pw)
    ax.set_ylim(0.0, ph)
    ax.set_aspect("equal")
    ax.axis("off")
    length, width = brick_size_m[0] * 1000.0, brick_size_m[1] * 1000.0
    cx, cy = pw / 2.0, ph / 2.0 + 8.0
    # The brick's top face, clipped to the printable area (a 300 mm brick overhangs A4 a little).
    x0, x1 = max(_MARGIN_MM, cx - length / 2.0), min(pw - _MARGIN_MM, cx + length / 2.0)
    y0, y1 = max(_MARGIN_MM + 22.0, cy - width / 2.0), min(ph - _MARGIN_MM, cy + width / 2.0)
    ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, lw=0.6, ec="0.35", ls=(0, (4, 3))))
    clipped = (
        x0 > cx - length / 2.0 or x1 < cx + length / 2.0 or y0 > cy - width / 2.0 or y1 < cy + width / 2.0
    )
    ax.plot([cx - 6, cx + 6], [cy, cy], color="0.3", lw=0.5)
    ax.plot([cx, cx], [cy - 6, cy + 6], color="0.3", lw=0.5)
    ax.add_patch(
        FancyArrow(cx + 12, cy - 20, 25, 0, width=0.6, head_width=4, head_length=5, color="0.3", lw=0)
    )
    ax.text(cx + 12, cy - 26, "+x (brick length)", fontsize=6, color="0.3", va="top")
    size = markers.size_m * 1000.0
    spacing = markers.spacing_m * 1000.0
    for marker_id, along in ((2 * brick_id, 0.5), (2 * brick_id + 1, -0.5)):
        bits = _marker_bits(markers.dictionary, marker_id)
        cells = bits.shape[0]
        mx = cx + along * spacing
        sticker = size / 2.0 + size / cells
        ax.add_patch(
            Rectangle((mx - sticker, cy - sticker), 2 * sticker, 2 * sticker, fc="white", ec="0.6", lw=0.3)
        )
        # Image row 0 at the top (+y): origin="upper" with the extent below puts the marker image upright.
        ax.imshow(
            bits,
            cmap="gray",
            vmin=0,
            vmax=255,
            interpolation="none",
            origin="upper",
            zorder=3,
            extent=(mx - size / 2.0, mx + size / 2.0, cy - size / 2.0, cy + size / 2.0),
        )
        ax.text(mx, cy - sticker - 2.0, f"id {marker_id}", ha="center", va="top", fontsize=6, color="0.3")
    title = (
        f"brick {brick_id}: markers {2 * brick_id} (+x) and {2 * brick_id + 1} (-x), {markers.dictionary}, "
        f"marker {size:g} mm, spacing {spacing:g} mm, brick {length:g} x {width:g} mm"
        + (" (outline clipped to the page)" if clipped else "")
    )
    ax.text(_MARGIN_MM, _MARGIN_MM + 12.0, title, fontsize=7, va="bottom")
    ax.text(
        _MARGIN_MM,
        _MARGIN_MM + 7.0,
        "print at 100 % (actual size); the bar below must measure 100 mm",
        fontsize=6,
        va="bottom",
        color="0.3",
    )
    ax.plot([_MARGIN_MM, _MARGIN_MM + 100.0], [_MARGIN_MM + 3.0] * 2, color="black", lw=1.0)
    for x in (_MARGIN_MM, _MARGIN_MM + 50.0, _MARGIN_MM + 100.0):
        ax.plot([x, x], [_MARGIN_MM + 1.5, _MARGIN_MM + 4.5], color="black", lw=0.8)


def write_marker_sheets(
    path: str | Path,
    brick_ids: Sequence[int],
    markers: MarkerSpec | None = None,
    *,
    brick_size_m: tuple[float, float, float] = DEFAULT_BRICK_SIZE_M,
    paper: str = "a4",
    dpi: int = 300,
) -> list[Path]:
    """Write true-scale marker sheets for ``brick_ids`` to ``path`` (.pdf or .png); return the files written.

    Raises:
        InputError: unknown paper or extension, no ids, or markers that do not fit on the brick.
        PerceptionError: unknown dictionary, or a marker id outside the dictionary.
    """
    from matplotlib.backends.backend_pdf import PdfPages
    from matplotlib.figure import Figure

    markers = markers or MarkerSpec()
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in (".pdf", ".png"):
        raise InputError(f"{p}: output must end in .pdf or .png")
    if paper not in PAPER_SIZES_MM:
        raise InputError(
            f"`paper`: unknown paper {paper!r}; use one of {', '.join(PAPER_SIZES_MM)}", options=("paper",)
        )
    if not brick_ids:
        raise InputError("`bricks`: no brick ids given", options=("bricks",))
    if not 30 <= dpi <= 2400:
        raise InputError(f"`dpi`: {dpi} is out of range 30..2400", options=("dpi",))
    if markers.size_m <= 0 or markers.spacing_m <= 0:
        raise InputError("marker size and spacing must be > 0")
    from masonry.perception.aruco import aruco_dictionary

    dictionary = aruco_dictionary(markers.dictionary)
    count = dictionary.bytesList.shape[0]
    too_big = [b for b in brick_ids if 2 * b + 1 >= count]
    if too_big:
        raise PerceptionError(
            f"brick {too_big[0]} needs marker ids {2 * too_big[0]} and {2 * too_big[0] + 1}, but "
            f"{markers.dictionary} holds ids 0..{count - 1} (bricks 0..{count // 2 - 1}); use a larger dictionary"
        )
    cells = dictionary.markerSize + 2
    sticker = markers.size_m + 2 * markers.size_m / cells
    if markers.spacing_m < sticker:
        raise InputError(
            f"spacing {markers.spacing_m} m is less than a sticker's side ({sticker:.4f} m): markers overlap"
        )
    if markers.spacing_m + sticker > brick_size_m[0] or sticker > brick_size_m[1]:
        raise InputError(
            f"markers of {markers.size_m} m at spacing {markers.spacing_m} m do not fit on a "
            f"{brick_size_m[0]} x {brick_size_m[1]} m brick top"
        )
    paper_mm = PAPER_SIZES_MM[paper]
    figsize = (paper_mm[0] / _MM_PER_INCH, paper_mm[1] / _MM_PER_INCH)
    written: list[Path] = []
    try:
        if suffix == ".pdf":
            with PdfPages(p) as pdf:
                for brick_id in brick_ids:
                    fig = Figure(figsize=figsize)
                    _draw_page(fig, brick_id, markers, brick_size_m, paper_mm)
                    pdf.savefig(fig)
            written.append(p)
        else:
            for brick_id in brick_ids:
                out = p if len(brick_ids) == 1 else p.with_name(f"{p.stem}-brick{brick_id}{p.suffix}")
                fig = Figure(figsize=figsize)
                _draw_page(fig, brick_id, markers, brick_size_m, paper_mm)
                fig.savefig(out, dpi=dpi)
                written.append(out)
    except OSError as exc:
        raise InputError(f"{p}: cannot write ({exc.strerror or exc})") from exc
    return written
