"""Worlds from map images: dark connected regions of a PNG/JPEG become obstacles.

A map image is read as grey levels in [0, 1] (0 black, 1 white; transparent pixels count as
white). A pixel is an obstacle pixel when its grey level is below ``threshold``. Obstacle pixels are
grouped into 4-connected regions (``scipy.ndimage.label``) and each region becomes

* ``"box"``: its axis-aligned bounding rectangle (as the EduMIP planning report outlines detected
  obstacles with red dashed boxes): the whole extent of the region, so a thin diagonal wall, an L or
  a disc fills its box (a 6 px line drawn diagonally across 0.44 m becomes a 0.44 x 0.44 m
  square), or
* ``"polygon"``: the exact outline of its pixels (a rectilinear polygon along pixel edges; holes
  inside a region are filled): the shape for diagonal walls and any region that is not an upright
  rectangle.

Placement: the image's bottom-left corner sits at ``origin`` [m] and each pixel is a square of
side ``resolution`` [m/px]; image rows run downwards, world y upwards, so pixel (row i, column j)
of an H-row image covers x in [ox + j r, ox + (j + 1) r] and y in [oy + (H - 1 - i) r,
oy + (H - i) r].

A scenario names its map in an optional ``[world.map]`` table::

    [world.map]
    image = "../maps/edumip_map.png"   # relative to the scenario file
    resolution = 0.01                  # [m/px]
    origin = [0.0, 0.0]                # world position of the bottom-left corner [m] (default)
    threshold = 0.5                    # grey level below which a pixel is an obstacle (default)
    shape = "box"                      # "box" (default) or "polygon" (diagonal walls, non-rectangles)

The shipped ``models/maps/edumip_map.png`` is :func:`edumip_map_image` written as an 8-bit
greyscale PNG; regenerate it with
``python -c "from planning.core.maps import edumip_map_image as m; from PIL import Image;
Image.fromarray(m()).save('models/maps/edumip_map.png')"``.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from planning.core.tables import TableReader
from planning.core.world import Box, Obstacle, Polygon
from planning.errors import ScenarioError

FloatArray = NDArray[np.float64]
MapShape = Literal["box", "polygon"]

#: Largest map image read [pixels] (50 megapixels, e.g. 7071 x 7071); larger images are refused before
#: they are decoded.
MAX_MAP_PIXELS = 50_000_000
#: Memory a map image takes while it is read [bytes per pixel]: the decoded RGBA image (4), its grey
#: version (1) and the grey levels as float64 (8).
MAP_BYTES_PER_PIXEL = 13

_MAP_REQUIRED = {"image", "resolution"}
_MAP_OPTIONAL = {"origin", "threshold", "shape"}

#: The EduMIP planning report's map: 5 x 5 m at 1 cm per pixel (500 x 500 px), four obstacles. O1 is
#: the leftmost; O2, O3, O4 lie on the right from top to bottom. Rectangles as (x0, x1, y0, y1) in
#: metres within the map (origin at its bottom-left corner); every edge lies on a pixel edge.
EDUMIP_MAP_SIZE_PX = 500
EDUMIP_MAP_RESOLUTION = 0.01
EDUMIP_MAP_OBSTACLES: dict[str, tuple[float, float, float, float]] = {
    "O1": (0.90, 1.60, 1.20, 4.00),
    "O2": (3.00, 4.20, 4.00, 4.50),
    "O3": (2.70, 3.60, 2.20, 3.00),
    "O4": (3.10, 4.40, 0.50, 1.20),
}


def edumip_map_image() -> NDArray[np.uint8]:
    """The EduMIP map (the EduMIP planning report) as an 8-bit greyscale image: black obstacles on white.

    Returns:
        (500, 500) uint8 array, row 0 at the top (image convention).
    """
    n = EDUMIP_MAP_SIZE_PX
    img = np.full((n, n), 255, dtype=np.uint8)
    for x0, x1, y0, y1 in EDUMIP_MAP_OBSTACLES.values():
        j0, j1 = round(x0 / EDUMIP_MAP_RESOLUTION), round(x1 / EDUMIP_MAP_RESOLUTION)
        i0, i1 = n - round(y1 / EDUMIP_MAP_RESOLUTION), n - round(y0 / EDUMIP_MAP_RESOLUTION)
        img[i0:i1, j0:j1] = 0
    return img


def read_grey(path: str | Path) -> FloatArray:
    """Read an image file as grey levels.

    Args:
        path: PNG or JPEG file (any mode Pillow reads; alpha is composited over white).

    Returns:
        (H, W) grey levels in [0, 1], row 0 at the top.

    Raises:
        ScenarioError: The file is missing or is not a readable image.
    """
    from PIL import Image

    with decoded_image(path) as (p, im):
        if has_alpha(im):
            rgba = im.convert("RGBA")
            white = Image.new("RGBA", rgba.size, (255, 255, 255, 255))
            grey = np.asarray(Image.alpha_composite(white, rgba).convert("L"), dtype=float) / 255.0
        elif is_sixteen_bit(im):  # 16 bits a pixel (Pillow scales a PGM's maxval)
            grey = sixteen_bit(p, np.asarray(im, dtype=float))
        else:
            grey = np.asarray(im.convert("L"), dtype=float) / 255.0
    if grey.ndim != 2 or grey.size == 0:
        raise ScenarioError(f"map image {p} has no pixels")
    return grey


def has_alpha(im: Any) -> bool:
    """Whether the Pillow image ``im`` has an alpha channel (or a palette with a transparent entry)."""
    return bool(im.mode in ("RGBA", "LA", "PA") or (im.mode == "P" and "transparency" in im.info))


def is_sixteen_bit(im: Any) -> bool:
    """Whether the Pillow image ``im`` has more than 8 bits a pixel (a 16-bit PNG, a PGM of maxval above 255)."""
    return bool(im.mode == "I" or im.mode.startswith("I;16"))


@contextlib.contextmanager
def decoded_image(path: str | Path, relative_to: str = "the scenario file") -> Iterator[tuple[Path, Any]]:
    """``(path, image)``: the map image file decoded by Pillow, its size checked first (:func:`_check_map_size`).
    Errors raised while the caller reads its pixels are reported as the file's.

    Args:
        path: The image file.
        relative_to: What a relative path was resolved against, as the messages say it (a map YAML's image is
            relative to the YAML).

    Raises:
        ScenarioError: The file is missing, is a folder, is too large, or is not a readable image.
    """
    from PIL import UnidentifiedImageError

    p = Path(path)
    if p.is_dir():
        raise ScenarioError(
            f"map image {p} is a folder, not an image file; give the PNG or JPEG file's path (relative to "
            f"{relative_to})"
        )
    if not p.is_file():
        raise ScenarioError(f"map image {p} does not exist; check the path (relative to {relative_to})")
    try:
        with _open_header(p) as im:
            _check_map_size(p, im.size)
            im.load()
            yield p, im
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise ScenarioError(f"map image {p} is not a readable image (PNG, JPEG or PGM): {exc}") from exc


def sixteen_bit(p: Path, pixels: FloatArray) -> FloatArray:
    """Grey levels in [0, 1] of a 16-bit image's ``pixels`` (0..65535: a 16-bit PNG, a PGM of maxval above 255 as
    Pillow reads it). Pillow's conversion to 8 bits clips them at 255 instead of scaling: every pixel above 255 of
    65535 read as white, and a wall drawn in a dark grey vanished from the map."""
    if pixels.size and (pixels.min() < 0 or pixels.max() > 65535):
        raise ScenarioError(
            f"map image {p} has pixel values outside 0..65535 (a 32-bit image); save it with 8 or 16 bits a pixel"
        )
    return pixels / 65535.0


def _open_header(p: Path) -> Any:
    """The image file opened without decoding its pixels (Pillow reads only the header here).

    Pillow's own decompression-bomb limit is lifted for this call only: :func:`_check_map_size`
    applies a lower one before any pixel is decoded.
    """
    from PIL import Image

    limit = Image.MAX_IMAGE_PIXELS
    Image.MAX_IMAGE_PIXELS = None
    try:
        return Image.open(p)
    finally:
        Image.MAX_IMAGE_PIXELS = limit


def _check_map_size(p: Path, size: tuple[int, int]) -> None:
    """Refuse a map image of more than :data:`MAX_MAP_PIXELS` pixels. size: (width, height) [px]."""
    width, height = size
    if width * height > MAX_MAP_PIXELS:
        need_gb = width * height * MAP_BYTES_PER_PIXEL / 1e9
        raise ScenarioError(
            f"map image {p} is {width} x {height} px ({width * height / 1e6:.0f} megapixels); reading it would "
            f"need about {need_gb:.1f} GB of memory, and the limit is {MAX_MAP_PIXELS / 1e6:.0f} megapixels: "
            "save the map at a lower resolution (more metres per pixel, then raise world.map.resolution to "
            "match) or crop it to the area the robot uses"
        )


def _outline(region: NDArray[np.bool_]) -> FloatArray:
    """Outer outline of one 4-connected pixel region as polygon vertices in pixel-corner units.

    Corners are (column, row_from_bottom) of pixel corners; the region is hole-filled first. The
    boundary edges between region and non-region pixels are oriented with the region on their
    left and chained; at a corner touched twice the chain turns left (keeping the loop simple). The
    longest loop is the outer outline; collinear vertices are dropped.
    """
    from scipy import ndimage  # loaded when a map image is read

    filled = ndimage.binary_fill_holes(region)
    h, _ = filled.shape
    pad = np.pad(filled, 1)
    edges: dict[tuple[int, int], list[tuple[int, int]]] = {}
    rows, cols = np.nonzero(filled & ~ndimage.binary_erosion(filled))  # pixels with an open side
    for i, j in zip(rows.tolist(), cols.tolist(), strict=True):
        y0, y1, x0, x1 = h - 1 - i, h - i, j, j + 1  # pixel corners in (x right, y up)
        pi, pj = i + 1, j + 1
        if not pad[pi + 1, pj]:  # below: edge going +x
            edges.setdefault((x0, y0), []).append((x1, y0))
        if not pad[pi, pj + 1]:  # right: edge going +y
            edges.setdefault((x1, y0), []).append((x1, y1))
        if not pad[pi - 1, pj]:  # above: edge going -x
            edges.setdefault((x1, y1), []).append((x0, y1))
        if not pad[pi, pj - 1]:  # left: edge going -y
            edges.setdefault((x0, y1), []).append((x0, y0))
    loops: list[list[tuple[int, int]]] = []
    while edges:
        start = min(edges)
        loop = [start]
        prev_dir = (1, 0)
        cur = start
        while True:
            outs = edges[cur]
            if len(outs) == 1:
                nxt = outs.pop()
            else:  # turn left relative to the incoming direction
                outs.sort(key=lambda q: -(prev_dir[0] * (q[1] - cur[1]) - prev_dir[1] * (q[0] - cur[0])))
                nxt = outs.pop(0)
            if not outs:
                del edges[cur]
            prev_dir = (nxt[0] - cur[0], nxt[1] - cur[1])
            cur = nxt
            if cur == start:
                break
            loop.append(cur)
        loops.append(loop)
    pts = np.array(max(loops, key=len), dtype=float)
    before, after = np.roll(pts, 1, axis=0), np.roll(pts, -1, axis=0)
    cross = (pts[:, 0] - before[:, 0]) * (after[:, 1] - pts[:, 1]) - (pts[:, 1] - before[:, 1]) * (
        after[:, 0] - pts[:, 0]
    )
    return pts[cross != 0]


def obstacles_from_mask(
    mask: NDArray[np.bool_],
    resolution: float,
    origin: tuple[float, float] = (0.0, 0.0),
    shape: MapShape = "box",
) -> list[Obstacle]:
    """Obstacles from a boolean occupancy image.

    Args:
        mask: (H, W) True where a pixel is an obstacle, row 0 at the top.
        resolution: Pixel side [m/px], > 0.
        origin: World position of the image's bottom-left corner [m].
        shape: "box" (axis-aligned bounding rectangle per region) or "polygon" (exact outline).

    Returns:
        One obstacle per 4-connected region, ordered by the region's label (row-major scan order); a region that
        encloses free space a robot fits in (the walls around a room) gives several, which leave it free
        (:func:`_without_holes`).
    """
    if not resolution > 0:
        raise ValueError(f"resolution must be > 0 m/px, got {resolution}")
    if shape not in ("box", "polygon"):
        raise ValueError(f"shape must be 'box' or 'polygon', got {shape!r}")
    from scipy import ndimage  # loaded when a map image is read

    labels, _ = ndimage.label(mask)
    h = mask.shape[0]
    ox, oy = float(origin[0]), float(origin[1])
    most = max(0, math.floor(MAX_FILLED_HOLE_M2 / resolution**2 + 1e-9))  # pixels of a hole no robot fits in
    out: list[Obstacle] = []
    for k, sl in enumerate(ndimage.find_objects(labels), start=1):
        if sl is None:
            continue
        for piece, r0, c0 in _without_holes(labels[sl] == k, most, boxes=shape == "box"):
            rows, cols = piece.shape
            top, left = sl[0].start + r0, sl[1].start + c0  # the piece's first row and column in the image
            if shape == "box":
                x0, x1 = ox + left * resolution, ox + (left + cols) * resolution
                y0, y1 = oy + (h - top - rows) * resolution, oy + (h - top) * resolution
                out.append(Box((0.5 * (x0 + x1), 0.5 * (y0 + y1)), (x1 - x0, y1 - y0)))
            else:
                verts = _outline(piece)
                # piece corners -> world: column offset ``left``, rows counted from the bottom of the piece
                wx = ox + (verts[:, 0] + left) * resolution
                wy = oy + (verts[:, 1] + (h - top - rows)) * resolution
                out.append(Polygon(tuple((float(a), float(b)) for a, b in zip(wx, wy, strict=True))))
    return out


#: Largest area [m^2] of free space enclosed by one obstacle region that is filled into it (no robot's footprint
#: fits: the EduMIP's covers 0.014 m^2): a larger one (the room inside a map's walls) is kept free.
MAX_FILLED_HOLE_M2 = 0.01


def _without_holes(region: NDArray[np.bool_], most: int, *, boxes: bool) -> list[tuple[NDArray[np.bool_], int, int]]:
    """``region`` (one 4-connected region) as pieces that enclose no free space, each (its pixels, its first row,
    its first column within ``region``): holes of at most ``most`` pixels are filled in; a region enclosing a larger
    one (the walls around a room) is cut through that hole, recursively, into pieces whose outlines are exact
    (the halves share the column cut through: obstacles may overlap); with ``boxes``, into the rectangles of its
    rows' runs instead (a piece's bounding box would cover the hole again)."""
    from scipy import ndimage  # loaded when a map image is read

    holes, n = ndimage.label(ndimage.binary_fill_holes(region) & ~region)
    sizes = np.bincount(holes.ravel(), minlength=n + 1)[1:]
    if n == 0 or sizes.max() <= most:
        return [(region | (holes > 0), 0, 0)]
    if boxes:
        return _row_run_boxes(region | np.isin(holes, np.flatnonzero(sizes <= most) + 1))
    cols = np.sort(np.nonzero(holes == int(np.argmax(sizes)) + 1)[1])
    c = int(cols[cols.size // 2])  # a column through the largest hole
    out = []
    for half, first in ((region[:, : c + 1], 0), (region[:, c:], c)):
        parts, _ = ndimage.label(half)
        for j, sl in enumerate(ndimage.find_objects(parts), start=1):
            if sl is None:
                continue
            for piece, r0, c0 in _without_holes(parts[sl] == j, most, boxes=False):
                out.append((piece, sl[0].start + r0, first + sl[1].start + c0))
    return out


def _row_run_boxes(region: NDArray[np.bool_]) -> list[tuple[NDArray[np.bool_], int, int]]:
    """``region`` covered exactly by rectangles: each row's runs of pixels, a run continued by the same run in the
    rows below merged with them; each (an all-True block, its first row, its first column)."""
    rects: list[tuple[NDArray[np.bool_], int, int]] = []
    open_runs: dict[tuple[int, int], int] = {}  # (first column, end column) -> first row
    rows = region.shape[0]
    for i in range(rows + 1):
        line = np.zeros(region.shape[1] + 2, dtype=np.int8)
        if i < rows:
            line[1:-1] = region[i]
        edges = np.flatnonzero(np.diff(line))
        runs = set(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))
        for run in [r for r in open_runs if r not in runs]:
            start = open_runs.pop(run)
            rects.append((np.ones((i - start, run[1] - run[0]), dtype=bool), start, run[0]))
        for run in runs - open_runs.keys():
            open_runs[run] = i
    return rects


def load_image_obstacles(
    path: str | Path,
    resolution: float,
    origin: tuple[float, float] = (0.0, 0.0),
    threshold: float = 0.5,
    shape: MapShape = "box",
) -> list[Obstacle]:
    """Obstacles from a map image file.

    Args:
        path: PNG or JPEG file.
        resolution: Pixel side [m/px].
        origin: World position of the image's bottom-left corner [m].
        threshold: Grey level in (0, 1] below which a pixel is an obstacle.
        shape: "box" or "polygon".

    Returns:
        One obstacle per dark 4-connected region.
    """
    if not 0.0 < threshold <= 1.0:
        raise ValueError(f"threshold must be in (0, 1], got {threshold}")
    return obstacles_from_mask(read_grey(path) < threshold, resolution, origin, shape)


#: A ``[world.map]`` table's obstacles and the extent its image covers in the world, (xmin, xmax, ymin, ymax) [m].
MapObstacles = tuple[list[Obstacle], tuple[float, float, float, float]]


def map_shape(r: TableReader, table: Mapping[str, Any], ctx: str, default: MapShape = "box") -> MapShape:
    """A map table's ``shape`` field: "box" or "polygon" (``default`` when it gives none: an image's "box", a ROS
    map's "polygon", :func:`planning.core.nav2_map.load_map_yaml_table`)."""
    shape = table.get("shape", default)
    if shape not in ("box", "polygon"):
        raise r.fail(f"{ctx}shape", "'box' or 'polygon'", shape)
    return shape  # type: ignore[no-any-return]


def load_map_table(table: Mapping[str, Any], base_dir: Path, where: str) -> MapObstacles:
    """The ``[world.map]`` loader of a map image, ``MAP_LOADERS["image"]``.

    Args:
        table: The parsed ``[world.map]`` table.
        base_dir: Directory of the scenario file; ``image`` is resolved against it.
        where: How to name the scenario in errors.

    Returns:
        The map's obstacles, and the extent of its image in the world.

    Raises:
        ScenarioError: Unknown or missing keys, bad values, a missing or unreadable image.
    """

    r, ctx = TableReader(where), "world.map."
    r.keys(table, ctx, _MAP_REQUIRED, _MAP_OPTIONAL)
    image = table["image"]
    if not isinstance(image, str) or not image:
        raise r.fail(f"{ctx}image", "a path to a PNG/JPEG file (relative to the scenario file)", image)
    resolution = r.number(table, "resolution", ctx, positive=True, expected="a pixel size > 0 [m/px]")
    threshold = r.number(table, "threshold", ctx, default=0.5)
    if not 0.0 < threshold <= 1.0:
        raise r.fail(f"{ctx}threshold", "a grey level in (0, 1] (0 black, 1 white)", threshold)
    ox, oy = 0.0, 0.0
    if "origin" in table:
        ox, oy = r.vector(table, "origin", ctx, 2, expected="[x, y] of the image's bottom-left corner [m]")
    shape = map_shape(r, table, ctx)
    path = Path(image) if Path(image).is_absolute() else base_dir / image
    try:
        grey = read_grey(path)
    except ScenarioError as exc:
        raise ScenarioError(f"{where}: field 'world.map.image': {exc}") from exc
    h, w = grey.shape
    extent = (ox, ox + w * resolution, oy, oy + h * resolution)
    return obstacles_from_mask(grey < threshold, resolution, (ox, oy), shape), extent
