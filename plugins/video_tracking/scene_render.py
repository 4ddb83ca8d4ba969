"""Drawing a :class:`~belief_tracking.scene_config.SceneConfig` into frames and exact ground truth, and writing them.

:func:`render` draws the frames, the ground-truth rows and the visibilities;
:func:`write_gt` and :func:`write_video` write them as MOTChallenge text and Motion-JPEG.
The conventions are those of :mod:`belief_tracking.scenes`, which re-exports every public
name of this module.  OpenCV is used only by :func:`write_video`.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .errors import TrackingError
from .extras import require
from .scene_config import Scene, SceneConfig, StaticShape, Walker, round_half_up

__all__ = ["render", "write_gt", "write_video"]

# Body layout as fractions of the box height: the head is the top fifth and the shirt
# runs down to 60 % of the height.  The head is narrower than the body, so the head rows
# of a box also contain background, as they would for a real person.
_HEAD_HEIGHT_FRACTION = 0.2
_SHIRT_BOTTOM_FRACTION = 0.6
_HEAD_WIDTH_FRACTION = 0.45

# Owner value of the pixels covered by a static occluder.  Walker ids are positive and 0
# means background, so a negative value can belong to no walker.
_OCCLUDER_OWNER = -1


# -- rendering ----------------------------------------------------------------------------------------------

def _bilinear_noise(height: int, width: int, cell: int, rng: np.random.Generator) -> np.ndarray:
    """Smooth colour noise of shape (height, width, 3) with unit standard deviation at the grid nodes."""
    rows, cols = height // cell + 2, width // cell + 2
    grid = rng.standard_normal((rows, cols, 3))
    ys = np.arange(height) / cell
    xs = np.arange(width) / cell
    y0, x0 = ys.astype(int), xs.astype(int)
    fy, fx = (ys - y0)[:, None, None], (xs - x0)[None, :, None]
    top = grid[y0][:, x0] * (1 - fx) + grid[y0][:, x0 + 1] * fx
    bottom = grid[y0 + 1][:, x0] * (1 - fx) + grid[y0 + 1][:, x0 + 1] * fx
    return top * (1 - fy) + bottom * fy


def _clip_rectangle(x: int, y: int, w: int, h: int, width: int, height: int) -> tuple[slice, slice] | None:
    """Row and column slices of the part of a rectangle inside the image, or None if it is outside."""
    x0, y0, x1, y1 = max(x, 0), max(y, 0), min(x + w, width), min(y + h, height)
    if x1 <= x0 or y1 <= y0:
        return None
    return slice(y0, y1), slice(x0, x1)


def _paint_rectangle(image: np.ndarray, shape: StaticShape) -> None:
    region = _clip_rectangle(shape.x, shape.y, shape.w, shape.h, image.shape[1], image.shape[0])
    if region is not None:
        image[region] = shape.colour


def _render_background(config: SceneConfig, rng: np.random.Generator) -> np.ndarray:
    """The static background, float32 of shape (H, W, 3)."""
    style = config.background
    height, width = config.height, config.width
    image = np.empty((height, width, 3), dtype=np.float64)
    image[:] = style.base_colour
    # Every texture is drawn even when its strength is 0.  This keeps the random stream,
    # and so the random shapes, the same whatever the strengths.
    image += style.smooth_variation * _bilinear_noise(height, width, style.smooth_cell, rng)
    grain = rng.standard_normal((height, width, 1))
    for _ in range(style.n_random_shapes):
        w = int(rng.integers(12, max(13, width // 4)))
        h = int(rng.integers(12, max(13, height // 3)))
        x = int(rng.integers(-w // 2, width - w // 2))
        y = int(rng.integers(-h // 2, height - h // 2))
        grey = rng.uniform(50, 160)
        tint = rng.normal(0, 12, size=3)
        colour = tuple(int(c) for c in np.clip(np.rint(grey + tint), 0, 255))
        _paint_rectangle(image, StaticShape(x, y, w, h, colour))
    for shape in style.shapes:
        _paint_rectangle(image, shape)
    # The grain is added after the shapes so that the shapes are textured too.
    image += style.grain * grain
    return image.astype(np.float32)


def _body_template(w: int, h: int, walker: Walker) -> tuple[np.ndarray, np.ndarray]:
    """The walker drawn in a box of size (h, w): a colour patch (h, w, 3) and a mask (h, w) of covered pixels."""
    patch = np.zeros((h, w, 3), dtype=np.float32)
    mask = np.zeros((h, w), dtype=bool)
    head_rows = round_half_up(_HEAD_HEIGHT_FRACTION * h)
    shirt_end = max(head_rows, round_half_up(_SHIRT_BOTTOM_FRACTION * h))
    head_width = max(1, round_half_up(_HEAD_WIDTH_FRACTION * w))
    head_left = (w - head_width) // 2
    patch[:head_rows, head_left:head_left + head_width] = walker.head
    mask[:head_rows, head_left:head_left + head_width] = True
    patch[head_rows:shirt_end] = walker.shirt
    patch[shirt_end:] = walker.trousers
    mask[head_rows:] = True
    return patch, mask


def _shadow_map(config: SceneConfig) -> np.ndarray:
    """Static per-pixel light factor (H, W, 1) of the shadows; 1 outside every shadow."""
    factor = np.ones((config.height, config.width, 1), dtype=np.float32)
    for shadow in config.lighting.shadows:
        region = _clip_rectangle(shadow.x, shadow.y, shadow.w, shadow.h, config.width, config.height)
        if region is not None:
            factor[region] *= shadow.darkening
    return factor


class _DrawnWalker(NamedTuple):
    """A walker drawn in one frame: the extent of their pixels in the image, ``[x0, x1) x [y0, y1)``."""

    id: int
    x0: int
    y0: int
    x1: int
    y1: int
    pixels: int  # pixels drawn in the image, hidden later or not


def _occluder_layer(config: SceneConfig) -> tuple[np.ndarray, np.ndarray] | None:
    """The occluders' colours (H, W, 3) and the mask (H, W) of their pixels, or None if none is in the image."""
    layer = np.zeros((config.height, config.width, 3), dtype=np.float32)
    mask = np.zeros((config.height, config.width), dtype=bool)
    for shape in config.occluders:
        region = _clip_rectangle(shape.x, shape.y, shape.w, shape.h, config.width, config.height)
        if region is not None:
            layer[region] = shape.colour
            mask[region] = True
    return (layer, mask) if mask.any() else None


def _draw_walker(image: np.ndarray, owner: np.ndarray, walker: Walker, t: int) -> _DrawnWalker | None:
    """Paint a present walker over ``image`` at frame index ``t`` and claim their pixels in ``owner``.

    Returns where the walker's pixels are, or None when none of them is in the image.
    """
    height, width = owner.shape
    x, y, w, h = walker.box_at(t)
    region = _clip_rectangle(x, y, w, h, width, height)
    if region is None:
        return None
    patch, mask = _body_template(w, h, walker)
    rows, cols = region
    local = (slice(rows.start - y, rows.stop - y), slice(cols.start - x, cols.stop - x))
    mask = mask[local]
    if not mask.any():
        return None  # only background columns of the head rows are in the image
    np.copyto(image[region], patch[local], where=mask[:, :, None])
    owner[region][mask] = walker.id
    # The box is the extent of the pixels actually drawn inside the image.  That is the
    # clipped box, except at a side border that cuts the narrow head out of view (the box
    # then starts at the shoulders) or leaves only the head in view.
    covered_rows = np.flatnonzero(mask.any(axis=1))
    covered_cols = np.flatnonzero(mask.any(axis=0))
    return _DrawnWalker(walker.id,
                        cols.start + int(covered_cols[0]), rows.start + int(covered_rows[0]),
                        cols.start + int(covered_cols[-1]) + 1, rows.start + int(covered_rows[-1]) + 1,
                        int(mask.sum()))


def _truth_row(t: int, drawn: _DrawnWalker, owner: np.ndarray) -> tuple[list[int], float]:
    """The ground-truth row of a drawn walker at frame index ``t`` and the visible fraction of their pixels."""
    visible = int(np.count_nonzero(owner[drawn.y0:drawn.y1, drawn.x0:drawn.x1] == drawn.id))
    row = [t + 1, drawn.id, drawn.x0 + 1, drawn.y0 + 1, drawn.x1 - drawn.x0, drawn.y1 - drawn.y0, 1, -1, -1, -1]
    return row, visible / drawn.pixels


def _expose(image: np.ndarray, t: int, config: SceneConfig, shadow_factor: np.ndarray,
            noise_rng: np.random.Generator) -> np.ndarray:
    """The camera's view of a drawn frame: shadows, the global gain and the sensor noise, rounded into 0..255."""
    image *= shadow_factor
    gain = config.lighting.gain(t)
    if gain != 1.0:
        image *= np.float32(gain)
    if config.noise_std > 0:
        image += np.float32(config.noise_std) * noise_rng.standard_normal(image.shape, dtype=np.float32)
    np.clip(np.rint(image), 0, 255, out=image)
    return image


def _read_only(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


def render(config: SceneConfig, rng: np.random.Generator | None = None) -> Scene:
    """Draw every frame of a scene and its ground truth.

    Parameters
    ----------
    config : SceneConfig
        The scene.
    rng : numpy.random.Generator, optional
        Source of the background texture, the random shapes and the sensor noise.  By
        default it is ``numpy.random.default_rng(config.seed)``, so a configuration alone
        fixes the scene byte for byte.

    Returns
    -------
    Scene
        Frames of shape (T, H, W, 3), uint8 BGR, with ground-truth rows of shape (M, 10)
        and visibilities of shape (M,).

    Notes
    -----
    For each frame, the renderer copies the background and draws the walkers from the
    farthest to the nearest, then the occluders.  It keeps a map of which walker owns
    each pixel.  Next it multiplies the image by the global gain and the shadow factors,
    adds the sensor noise, and rounds and clips to 0..255.  The background and the noise
    come from two independent child streams of ``rng``, so a longer scene begins with
    the same frames as a shorter one.

    Examples
    --------
    >>> from belief_tracking.scenes import crossing
    >>> scene = render(crossing(seed=0))
    >>> scene.frames.shape, scene.frames.dtype
    ((100, 240, 320, 3), dtype('uint8'))
    >>> scene.initial_boxes()
    {1: (0, (96, 128, 18, 52)), 2: (0, (190, 112, 30, 76))}
    >>> scene.ground_truth[:2].tolist()  # frame, id, x, y, w, h (1-based corner), flag, -1, -1, -1
    [[1, 1, 97, 129, 18, 52, 1, -1, -1, -1], [1, 2, 191, 113, 30, 76, 1, -1, -1, -1]]
    >>> min(scene.visibility_at(50).values())  # walker 1 is fully behind walker 2
    0.0
    """
    if rng is None:
        rng = np.random.default_rng(config.seed)
    background_rng, noise_rng = rng.spawn(2)
    background = _render_background(config, background_rng)
    occluders = _occluder_layer(config)
    shadow_factor = _shadow_map(config)
    # Farthest first, so that nearer walkers overwrite them; on equal depth the lower id
    # is drawn last and so ends up in front.
    drawing_order = sorted(config.walkers, key=lambda w: (-w.depth, -w.id))
    frames = np.empty((config.n_frames, config.height, config.width, 3), dtype=np.uint8)
    truth_rows: list[list[int]] = []
    visibility: list[float] = []
    owner = np.empty((config.height, config.width), dtype=np.int32)  # id of the walker seen at each pixel, 0 for none
    for t in range(config.n_frames):
        image = background.copy()
        owner.fill(0)
        drawn = [_draw_walker(image, owner, walker, t) for walker in drawing_order if walker.is_present(t)]
        if occluders is not None:
            layer, mask = occluders
            np.copyto(image, layer, where=mask[:, :, None])
            owner[mask] = _OCCLUDER_OWNER
        for walker in sorted(d for d in drawn if d is not None):
            row, seen = _truth_row(t, walker, owner)
            truth_rows.append(row)
            visibility.append(seen)
        frames[t] = _expose(image, t, config, shadow_factor, noise_rng)
    return Scene(config=config, frames=_read_only(frames),
                 ground_truth=_read_only(np.array(truth_rows, dtype=np.int64).reshape(-1, 10)),
                 visibility=_read_only(np.array(visibility, dtype=np.float64)))


# -- output --------------------------------------------------------------------------------------------------

def write_gt(path: str | Path, rows: np.ndarray, visibility: np.ndarray | None = None) -> None:
    """Write ground-truth (or tracker) rows as a MOTChallenge CSV file.

    Parameters
    ----------
    path : str or Path
        File to write (usually ``gt/gt.txt``).
    rows : array_like, shape (M, K), K >= 6
        ``frame, id, x, y, w, h, ...`` with 1-based frames and corners.  Integer arrays
        are written as integers; float arrays use ``%.6f`` with trailing zeros removed.
    visibility : array_like, shape (M,), optional
        Each row's visible fraction in [0, 1] (:attr:`Scene.visibility`).  With it, the
        file has the 9 columns of a MOTChallenge 17 ground truth,
        ``frame, id, x, y, w, h, flag, class, visibility``: the flag is the 7th column of
        ``rows`` (1 when ``rows`` has 6), the class is 1 (pedestrian), as evaluation tools
        that read MOT17 files expect.  Without it, ``rows`` are written as they are.

    Raises
    ------
    TrackingError
        If ``rows`` is not a table with at least 6 columns, or ``visibility`` does not give
        one value in [0, 1] per row.

    Examples
    --------
    >>> import tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "gt.txt")
    >>> write_gt(path, [[1, 1, 10, 20, 5, 8, 1, -1, -1, -1]])
    >>> open(path).read()
    '1,1,10,20,5,8,1,-1,-1,-1\\n'
    >>> from belief_tracking.scenes import crossing
    >>> scene = render(crossing(0))
    >>> write_gt(path, scene.ground_truth, visibility=scene.visibility)
    >>> open(path).read().splitlines()[0]
    '1,1,97,129,18,52,1,1,1'
    """
    table = np.asarray(rows)
    if table.ndim != 2 or (table.size and table.shape[1] < 6):
        raise TrackingError(f"rows must be a table of shape (M, K) with K >= 6, got shape {table.shape}")
    if visibility is not None:
        seen = np.asarray(visibility, dtype=np.float64).reshape(-1)
        if seen.shape != (len(table),) or not np.all((seen >= 0) & (seen <= 1)):
            raise TrackingError(f"visibility must give one value in [0, 1] per row ({len(table)}), "
                                f"got shape {np.shape(visibility)}")
        flags = table[:, 6] if table.shape[1] > 6 else np.ones(len(table), dtype=table.dtype)
        lines = [",".join([*(_format_number(float(v)) for v in row[:6]), _format_number(float(flag)), "1",
                           _format_number(float(v))])
                 for row, flag, v in zip(table, flags, seen)]
    elif np.issubdtype(table.dtype, np.integer):
        lines = [",".join(str(int(v)) for v in row) for row in table]
    else:
        lines = [",".join(_format_number(float(v)) for v in row) for row in table]
    with open(path, "w", encoding="ascii", newline="\n") as handle:
        handle.write("".join(line + "\n" for line in lines))


def _format_number(value: float) -> str:
    if value == int(value):
        return str(int(value))
    return f"{value:.6f}".rstrip("0")


def write_video(path: str | Path, scene: Scene | Iterable[np.ndarray], fps: float = 25.0) -> int:
    """Write frames to a Motion-JPEG ``.avi`` file with OpenCV.

    Parameters
    ----------
    path : str or Path
        Output file; ``.avi`` is the container that goes with Motion-JPEG.
    scene : Scene or iterable of ndarray of uint8, shape (H, W, 3)
        BGR frames, all of one size.
    fps : float
        Frame rate stored in the file.

    Returns
    -------
    int
        Number of frames written.

    Raises
    ------
    OSError
        If OpenCV cannot open the file for writing.
    TrackingError
        If a frame is not (H, W, 3) uint8 or differs in size from the first.
    """
    cv2 = require("cv2")  # OpenCV stays at the edges: out of the import path

    writer = None
    size = None
    count = 0
    try:
        for frame in scene:
            frame = np.asarray(frame)
            if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3:
                raise TrackingError(f"frames must be (H, W, 3) uint8 arrays, got {frame.shape} {frame.dtype}")
            if writer is None:
                size = frame.shape[:2]
                writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), float(fps),
                                         (frame.shape[1], frame.shape[0]))
                if not writer.isOpened():
                    raise OSError(f"OpenCV could not open {str(path)!r} for writing")
            elif frame.shape[:2] != size:
                raise TrackingError(f"frame {count} has size {frame.shape[:2]}, the first had {size}")
            writer.write(np.ascontiguousarray(frame))
            count += 1
    finally:
        if writer is not None:
            writer.release()
    return count
