"""The parts of a video frame beside the world picture: where each lies, and the text.

A frame is the world picture on the left, full height, and a panel on its right: the close-up inset
(a square at the panel's top, :mod:`sim.viz.replay`) and the text below it. Nothing is drawn over
the world picture.

The text is the clock and each run's name and current position error, in the run's colour. Its
labels are drawn once; its numbers are stamped every frame from glyphs drawn once, so each frame
prints its own simulation time and errors (a text renderer every frame would cost more than the
robots' passes).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from sim.viz.scene import FloatArray, Frame, Track

Rect = tuple[int, int, int, int]  # x0, y0, x1, y1 [px], image coordinates, end exclusive

#: Share of the frame's width the panel takes (the inset is a square of that width).
PANEL_FRACTION = 0.3

#: Background of the panel (RGB).
PANEL_RGB = (28, 30, 34)

#: Colour of the clock and the labels that are no run's.
TEXT_RGB = (235, 235, 235)

#: Characters the number fields print.
DIGITS = "0123456789.-"


@dataclass(frozen=True)
class FrameLayout:
    """Where the parts of a frame lie (rectangles in image coordinates, end exclusive).

    Attributes:
        width: Frame width [px].
        height: Frame height [px].
        world: The world picture: the left of the frame, full height.
        inset: The close-up: a square at the top of the panel on the right.
        text: The text: the panel below the inset.
    """

    width: int
    height: int
    world: Rect
    inset: Rect
    text: Rect

    @staticmethod
    def of(width: int, height: int) -> FrameLayout:
        """The layout of a ``width`` x ``height`` frame [px]: a panel of :data:`PANEL_FRACTION` of the
        width on the right."""
        panel = max(1, round(PANEL_FRACTION * width))
        left = width - panel
        side = min(panel, 2 * height // 3)  # a third of the height at least for the text (a wide, low frame)
        return FrameLayout(width, height, (0, 0, left, height), (left, 0, width, side), (left, side, width, height))

    @staticmethod
    def size(rect: Rect) -> tuple[int, int]:
        """(width, height) [px] of a rectangle."""
        return rect[2] - rect[0], rect[3] - rect[1]


def region(frame: Frame, rect: Rect) -> Frame:
    """The pixels of ``rect`` in ``frame`` (a view: writing to it writes the frame)."""
    x0, y0, x1, y1 = rect
    return frame[y0:y1, x0:x1]


def run_rgb(rgba: tuple[float, ...]) -> tuple[int, int, int]:
    """A run's colour lightened for text on the dark panel."""
    r, g, b = (int(min(255, 80 + 175 * c)) for c in rgba[:3])
    return (r, g, b)


def widest(number: str) -> str:
    """``number`` with every digit an 8: as wide as any number of its shape (digits share one width)."""
    return "".join("8" if ch.isdigit() else ch for ch in number)


def load_font(size: int) -> Any:
    """Pillow's default font at ``size`` [px] (its bitmap font where Pillow has no FreeType)."""
    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow without FreeType
        return ImageFont.load_default()


class Glyphs:
    """The characters of :data:`DIGITS` drawn once in one colour on the panel, stamped into images.

    Args:
        font: The font.
        rgb: Text colour.
        height: Line height [px].
    """

    def __init__(self, font: Any, rgb: tuple[int, int, int], height: int) -> None:
        self.height = height
        self.cells: dict[str, Frame] = {}
        for ch in DIGITS:
            w = max(1, round(float(font.getlength(ch))))
            img = Image.new("RGB", (w, height), PANEL_RGB)
            ImageDraw.Draw(img).text((0, 0), ch, fill=rgb, font=font)
            self.cells[ch] = np.asarray(img)

    def width(self, text: str) -> int:
        """Width [px] of ``text`` as stamped."""
        return sum(self.cells[ch].shape[1] for ch in text)

    def stamp(self, img: Frame, field: Rect, text: str) -> None:
        """Clear ``field`` of ``img`` to the panel colour and stamp ``text`` right-aligned in it
        (clipped to the image)."""
        x0, y0, x1, y1 = field
        h, w = img.shape[:2]
        img[max(0, y0) : min(h, y1), max(0, x0) : min(w, x1)] = PANEL_RGB
        x = x1 - self.width(text)
        for ch in text:
            cell = self.cells[ch]
            cw = cell.shape[1]
            a, b = max(0, x0, x), min(w, x + cw, x1)
            rows = min(h, y0 + self.height) - max(0, y0)
            if b > a and rows > 0:
                img[max(0, y0) : max(0, y0) + rows, a:b] = cell[max(0, -y0) : max(0, -y0) + rows, a - x : b - x]
            x += cw


#: Smallest font of the panel's text [px]: a frame too small for it clips the text rather than shrink it further.
MIN_FONT_PX = 7


def fitting_font(texts: Sequence[str], width: int, height: int, pad: int, layout: FrameLayout) -> Any:
    """The panel's font: 1/34 of the frame's height (10 px at least), made smaller until every one of ``texts``
    (a line each, ``pad`` px from the edges) fits in the ``width`` x ``height`` text panel, down to
    :data:`MIN_FONT_PX` (at 320 x 240 "odometry feedback (ghost)" ran past the frame's edge)."""
    size = max(10, round(layout.height / 34))
    while True:
        font = load_font(size)
        line_h = int(font.getbbox("Ag")[3]) + 3
        wide = max(float(font.getlength(text)) for text in texts) if texts else 0.0
        if size <= MIN_FONT_PX or (pad + wide <= width - pad and pad + len(texts) * line_h <= height):
            return font
        size -= 1


class TextPanel:
    """The text of a video: the clock, the close-up's magnification, each run's name and error.

    Args:
        layout: The frame's layout (the text goes into ``layout.text``).
        tracks: The runs, the solid one first.
        times: (n,) simulation time of each frame [s].
        magnification: The close-up's scale over the world picture's.
    """

    def __init__(self, layout: FrameLayout, tracks: Sequence[Track], times: FloatArray, magnification: float) -> None:
        self.tracks = list(tracks)
        self.times = times
        w, h = FrameLayout.size(layout.text)
        self.rect = layout.text
        # each field as wide as its longest number with every digit an 8 (digits share one width)
        lines: list[tuple[str, tuple[int, int, int], str, str]] = [
            ("t = ", TEXT_RGB, widest(f"{float(times[-1] - times[0]):.2f}"), " s"),
            (f"close-up x{magnification:.1f}", (150, 155, 165), "", ""),
        ]
        ends: dict[int, float] = {}  # the line saying a run ended early -> when it did [s]
        for i, tr in enumerate(self.tracks):
            rgb = run_rgb(tr.rgba)
            lines.append((tr.name if i == 0 else f"{tr.name} (ghost)", rgb, "", ""))
            lines.append(("  error ", rgb, widest(f"{float(np.max(tr.err)):.3f}"), " m"))
            if tr.ended is not None:  # shown from then on: the ghost stands still, its run over
                ends[len(lines)] = tr.ended
                lines.append((f"  ended at t = {tr.ended - float(times[0]):.2f} s", rgb, "", ""))
        pad = 6
        self.font = fitting_font(["".join((label, worst, unit)) for label, _, worst, unit in lines], w, h, pad, layout)
        self.line_h = int(self.font.getbbox("Ag")[3]) + 3
        img = Image.new("RGB", (w, h), PANEL_RGB)
        draw = ImageDraw.Draw(img)
        self.fields: list[tuple[Rect, Glyphs]] = []
        #: The text of each line but its number.
        self.labels: list[str] = []
        for row, (label, rgb, worst, unit) in enumerate(lines):
            y = pad + row * self.line_h
            self.labels.append(label)
            draw.text((pad, y), label, fill=rgb, font=self.font)
            if worst:
                glyphs = Glyphs(self.font, rgb, self.line_h)
                x0 = pad + round(float(self.font.getlength(label)))
                x1 = x0 + glyphs.width(worst)
                draw.text((x1, y), unit, fill=rgb, font=self.font)
                self.fields.append(((x0, y, x1, y + self.line_h), glyphs))
        self.image: Frame = np.asarray(img).copy()
        #: Each "ended at" line: its rectangle in the panel, when it shows [s], its pixels.
        self.endings: list[tuple[Rect, float, Frame]] = []
        for row, t_end in ends.items():
            rect = (0, pad + row * self.line_h, w, min(h, pad + (row + 1) * self.line_h))
            self.endings.append((rect, t_end, region(self.image, rect).copy()))
            region(self.image, rect)[:] = PANEL_RGB

    def texts(self, k: int) -> list[str]:
        """The numbers frame ``k`` prints: its simulation time [s] (from the first frame's) to 0.01 s,
        then each run's position error [m] at its log sample of the frame, to 1 mm."""
        out = [f"{float(self.times[k] - self.times[0]):.2f}"]
        out += [f"{float(tr.err[tr.idx[k]]):.3f}" for tr in self.tracks]
        return out

    def draw(self, k: int, frame: Frame) -> None:
        """Stamp frame ``k``'s numbers and copy the text into ``frame``."""
        for (field, glyphs), text in zip(self.fields, self.texts(k), strict=True):
            glyphs.stamp(self.image, field, text)
        for rect, t_end, pixels in self.endings:
            region(self.image, rect)[:] = pixels if self.times[k] >= t_end else PANEL_RGB
        np.copyto(region(frame, self.rect), self.image)
