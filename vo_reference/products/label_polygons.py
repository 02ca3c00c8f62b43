"""Polygons of a label image that redraw it exactly: Cityscapes' ``_polygons.json``.

Cityscapes' tools (``cityscapesscripts``: ``json2labelImg``, ``csCreateTrainIdLabelImgs``)
turn an annotation's polygons back into label images by filling each polygon, in the
order listed, with Pillow's ``ImageDraw.polygon`` (later polygons paint over earlier
ones; no holes). :func:`label_polygons` writes polygons that make exactly our label image
that way:

- one polygon per 8-connected region of one object id: the region's outer boundary
  through its boundary pixels' centres (OpenCV's contour, integer vertices as in
  Cityscapes). Filled, it covers the region and its holes;
- ordered so that a polygon comes after every polygon whose fill covers one of its
  pixels (the objects seen through a hole are drawn after the object around it);
- then the result is drawn with the same rasteriser the tools use (Pillow) and any pixel
  that still differs (a cycle of such covers, a shape Pillow fills otherwise) gets a
  one-pixel polygon at the end: the redrawn image is always the label image.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import VoError

__all__ = ["Polygon", "label_polygons", "draw_polygons"]


@dataclass(frozen=True)
class Polygon:
    region: int                       # the region value (object id) it belongs to
    points: tuple[tuple[int, int], ...]  # (x, y) pixel centres, in drawing order


def _pillow():
    try:
        from PIL import Image, ImageDraw
    except ImportError:
        raise VoError("the cityscapes export needs Pillow (pip install pillow) to check its polygons") from None
    return Image, ImageDraw


def draw_polygons(polygons, value_of: dict[int, int], shape: tuple[int, int], background: int = 0) -> np.ndarray:
    """int32 (H, W): ``polygons`` filled in order with Pillow, as cityscapesscripts draws them
    (each with ``value_of[region]``; regions missing from it are not drawn)."""
    Image, ImageDraw = _pillow()
    img = Image.new("I", (shape[1], shape[0]), int(background))
    draw = ImageDraw.Draw(img)
    for p in polygons:
        if p.region in value_of:
            draw.polygon(list(p.points), fill=int(value_of[p.region]))
    return np.asarray(img, dtype=np.int32)


def _components(regions: np.ndarray):
    """[(region value, bool mask (H, W), points)] of every 8-connected component, by value."""
    import cv2
    out = []
    for value in np.unique(regions):
        n, lab = cv2.connectedComponents((regions == value).astype(np.uint8), connectivity=8)
        for c in range(1, n):
            mask = lab == c
            contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
            pts = tuple((int(x), int(y)) for x, y in max(contours, key=len)[:, 0, :])
            out.append((int(value), mask, pts if len(pts) > 1 else pts * 2))
    return out


def _order(comps, shape) -> list[int]:
    """Drawing order: X before Y when X's fill covers a pixel of Y (Kahn's algorithm, ties by
    index; a cycle is broken at its lowest index, the check afterwards repairs it)."""
    index = np.full(shape, -1, np.int32)
    for i, (_, mask, _) in enumerate(comps):
        index[mask] = i
    after: list[set[int]] = [set() for _ in comps]
    before_count = [0] * len(comps)
    for i, (value, mask, pts) in enumerate(comps):
        xy = np.array(pts)
        (x0, y0), (x1, y1) = xy.min(axis=0), xy.max(axis=0)
        local = [Polygon(value, tuple((x - x0, y - y0) for x, y in pts))]
        fill = draw_polygons(local, {value: 1}, (y1 - y0 + 1, x1 - x0 + 1)) > 0   # within its bounding box
        box = (slice(y0, y1 + 1), slice(x0, x1 + 1))
        for j in np.unique(index[box][fill & ~mask[box]]).tolist():
            if j >= 0 and j != i and j not in after[i]:
                after[i].add(j)
                before_count[j] += 1
    order, done = [], [False] * len(comps)
    ready = sorted(i for i, c in enumerate(before_count) if c == 0)
    while len(order) < len(comps):
        if not ready:   # a cycle: take its lowest index
            ready = [min(i for i in range(len(comps)) if not done[i])]
        i = ready.pop(0)
        if done[i]:
            continue
        done[i] = True
        order.append(i)
        for j in sorted(after[i]):
            before_count[j] -= 1
            if before_count[j] == 0 and not done[j]:
                ready.append(j)
        ready.sort()
    return order


def label_polygons(regions: np.ndarray, drawn_value: dict[int, int]) -> list[Polygon]:
    """Polygons of the integer image ``regions`` (an object id per pixel) in drawing order.
    ``drawn_value`` {region: the value the reader's tool paints for it} (a label or train id):
    drawing the polygons with those values gives ``drawn_value[regions]`` at every pixel."""
    regions = np.asarray(regions)
    comps = _components(regions)
    polygons = [Polygon(comps[i][0], comps[i][2]) for i in _order(comps, regions.shape)]
    values, inverse = np.unique(regions, return_inverse=True)
    want = np.array([drawn_value[int(v)] for v in values], np.int32)[inverse].reshape(regions.shape)
    got = draw_polygons(polygons, drawn_value, regions.shape, background=-1)
    for y, x in np.argwhere(got != want):   # the rest: one pixel each, drawn last
        polygons.append(Polygon(int(regions[y, x]), ((int(x), int(y)), (int(x), int(y)))))
    if not np.array_equal(draw_polygons(polygons, drawn_value, regions.shape, background=-1), want):
        raise VoError("polygons do not redraw the label image (Pillow fills single pixels otherwise?)")
    return polygons
