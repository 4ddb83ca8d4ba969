"""Frame sources: a video file, a folder of images, an image pattern, a MOTChallenge sequence folder, frames."""

from __future__ import annotations

import tempfile
from pathlib import Path

import cv2
import numpy as np
import pytest

from belief_tracking import scenes, video
from belief_tracking.config import TrackerConfig
from belief_tracking.detections import Detections, read_detections, write_detections
from belief_tracking.errors import TrackingError, VideoError
from belief_tracking.initiation import init_from_gt
from belief_tracking.sources import FrameSource, open_source
from belief_tracking.tracker import Tracker

N_FRAMES = 15


@pytest.fixture(scope="module")
def short_scene(rendered_scene):
    scene = rendered_scene(scenes.crossing(0))
    gt = scene.ground_truth[scene.ground_truth[:, 0] <= N_FRAMES]
    return scene.frames[:N_FRAMES], gt


def write_images(folder: Path, frames, pattern: str = "{:06d}.png", start: int = 1) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for k, image in enumerate(frames, start=start):
        assert cv2.imwrite(str(folder / pattern.format(k)), image)
    return folder


def write_sequence(folder: Path, frames, info: str | None = None) -> Path:
    write_images(folder / "img1", frames, "{:06d}.png")
    height, width = frames[0].shape[:2]
    if info is None:
        info = (f"[Sequence]\nname=crossing\nimDir=img1\nframeRate=30\nseqLength={len(frames)}\n"
                f"imWidth={width}\nimHeight={height}\nimExt=.png\n")
    (folder / "seqinfo.ini").write_text(info)
    return folder


@pytest.fixture(scope="module")
def on_disk(short_scene, tmp_path_factory):
    frames, _ = short_scene
    root = tmp_path_factory.mktemp("sources")
    return {"folder": write_images(root / "folder", frames),
            "pattern": str(write_images(root / "zero_based", frames, "frame{:04d}.png",
                                        start=0) / "frame%04d.png"),
            "sequence": write_sequence(root / "SEQ-01", frames)}


def tracks_of(source, gt) -> np.ndarray:
    """The MOT rows of tracking ``source`` frame by frame with detections, as a user of the Python API does."""
    # Detections of walker 1 only, on every other frame, read from a file as a user would.
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "det.txt"
        write_detections(path, Detections({int(f): [[x - 1, y - 1, w, h, 0.8]]
                                           for f, i, x, y, w, h, *_ in gt if i == 1 and f % 2}))
        detections = read_detections(path, frame_count=N_FRAMES, image_size=(320, 240))
    tracker = Tracker(TrackerConfig(particles=30), init_from_gt(gt), np.random.default_rng(0))
    rows = []
    with open_source(source) as frames:
        assert (frames.width, frames.height) == (320, 240)
        for result in tracker.track(frames, detections=detections):
            rows += result.mot_rows()
    return np.array(rows)


# -- each kind gives the same frames and the same tracks -----------------------------------------------
@pytest.mark.parametrize("kind", ["folder", "pattern", "sequence"])
def test_each_kind_of_path_gives_the_frames_written(short_scene, on_disk, kind):
    frames, _ = short_scene
    source = open_source(on_disk[kind])
    assert source.kind == {"folder": "images"}.get(kind, kind)
    assert (source.width, source.height, source.count) == (320, 240, N_FRAMES)
    assert source.fps == (30.0 if kind == "sequence" else 25.0)
    read = list(source)
    assert len(read) == N_FRAMES and all(np.array_equal(a, b) for a, b in zip(read, frames))
    assert np.array_equal(next(iter(source)), frames[0])  # iterating again starts again


@pytest.mark.parametrize("kind", ["folder", "pattern", "sequence", "frames"])
def test_spread_picks_frames_over_the_whole_source(short_scene, on_disk, kind):
    frames, _ = short_scene
    source = open_source(frames if kind == "frames" else on_disk[kind])
    picked = list(source.spread(4))
    assert len(picked) == 4
    for image, k in zip(picked, [0, 5, 9, 14]):
        assert np.array_equal(image, frames[k])
    assert len(list(source.spread(100))) == N_FRAMES


@pytest.fixture(scope="module")
def tracks_in_memory(short_scene):
    frames, gt = short_scene
    tracks = tracks_of(frames, gt)
    assert tracks.shape == (2 * N_FRAMES, 10)
    return tracks


def test_every_kind_gives_the_same_tracks_as_the_frames_in_memory(short_scene, on_disk, tracks_in_memory):
    for kind in ("folder", "pattern", "sequence"):
        assert np.array_equal(tracks_of(on_disk[kind], short_scene[1]), tracks_in_memory), kind


def test_a_losslessly_encoded_video_gives_the_same_tracks(short_scene, tmp_path, tracks_in_memory):
    frames, gt = short_scene
    path = tmp_path / "crossing.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), 25.0, (320, 240))
    if not writer.isOpened():
        pytest.skip("this OpenCV build cannot write FFV1 video")
    for image in frames:
        writer.write(image)
    writer.release()
    source = open_source(path)
    assert source.kind == "video" and source.count == N_FRAMES
    decoded = list(source)
    source.close()
    if len(decoded) != N_FRAMES or not all(np.array_equal(a, b) for a, b in zip(decoded, frames)):
        pytest.skip("this OpenCV build does not decode FFV1 losslessly")
    assert np.array_equal(tracks_of(path, gt), tracks_in_memory)
    with open_source(path) as again:
        assert [int(np.array_equal(a, frames[k])) for a, k in zip(again.spread(3), [0, 7, 14])] == [1, 1, 1]


def test_open_source_returns_an_open_source_as_it_is(short_scene):
    source = open_source(short_scene[0])
    assert open_source(source) is source and isinstance(source, FrameSource)


# -- a source's own bookkeeping, on frames in memory -----------------------------------------------------
def shades(count: int) -> np.ndarray:
    """``count`` frames of 4 x 6 pixels, frame k all of grey level k."""
    return np.arange(count, dtype=np.uint8)[:, None, None, None] * np.ones((1, 4, 6, 3), np.uint8)


def test_frames_in_memory_are_a_source_of_their_size_at_25_fps():
    source = open_source(shades(5))
    assert (source.kind, source.name, source.width, source.height, source.count, source.fps) == \
        ("frames", "frames", 6, 4, 5, 25.0)
    assert [int(image[0, 0, 0]) for image in source] == [0, 1, 2, 3, 4]
    assert source.decode_seconds == 0.0


def test_a_scene_is_named_by_its_configuration():
    class Scene:                                    # what open_source reads of a rendered scene
        frames = shades(2)

        class config:
            name = "walk"

    source = open_source(Scene())
    assert source.name == "scene 'walk'" and source.count == 2


def test_spread_picks_evenly_spaced_frames_including_the_first_and_the_last():
    source = open_source(shades(10))
    assert [int(image[0, 0, 0]) for image in source.spread(4)] == [0, 3, 6, 9]
    assert [int(image[0, 0, 0]) for image in open_source(shades(7)).spread(3)] == [0, 3, 6]
    assert [int(image[0, 0, 0]) for image in source.spread(1)] == [0]
    assert list(source.spread(0)) == []


def test_spread_takes_the_first_frames_when_the_length_is_unknown_and_asks_pick_when_given():
    unknown = FrameSource(shades(6), name="stream", width=6, height=4, fps=25.0, count=None)
    assert [int(image[0, 0, 0]) for image in unknown.spread(3)] == [0, 1, 2]
    assert len(list(unknown.spread(10))) == 6                  # no more than there are
    asked = []
    picked = FrameSource([], name="files", width=6, height=4, fps=25.0, count=10,
                         pick=lambda indices: asked.append(list(indices)) or iter(["frame"] * len(indices)))
    assert list(picked.spread(4)) == ["frame"] * 4 and asked == [[0, 3, 6, 9]]


def test_missing_counts_the_announced_frames_that_were_not_decoded():
    announced = FrameSource([], name="video", width=6, height=4, fps=25.0, count=10)
    assert [announced.missing(k) for k in (0, 7, 10, 12)] == [10, 3, 0, 0]
    unknown = FrameSource([], name="stream", width=6, height=4, fps=25.0, count=None)
    assert unknown.missing(3) == 0


def test_a_source_reports_its_reader_s_decoding_time_and_closes_it_on_leaving_a_with_block():
    class Reader:
        decode_seconds = 1.5
        closed = 0

        def close(self):
            self.closed += 1

    reader = Reader()
    with FrameSource([], name="video", width=6, height=4, fps=25.0, count=0, reader=reader) as source:
        assert source.decode_seconds == 1.5 and reader.closed == 0
    assert reader.closed == 1


@pytest.mark.parametrize("frames", [np.zeros((4, 6, 3), np.uint8), np.zeros((2, 4, 6), np.uint8),
                                    np.zeros((2, 4, 6, 3)), np.zeros((0, 4, 6, 3), np.uint8)])
def test_frames_that_are_no_video_are_refused(frames):
    with pytest.raises(TrackingError, match=r"frames must be a \(T, H, W, 3\) uint8 array"):
        open_source(frames)


# -- folders: order and laziness ------------------------------------------------------------------------
def test_a_folder_is_read_in_the_order_of_its_names_with_numbers_by_value(tmp_path):
    shades = {"frame10.png": 30, "frame2.png": 20, "frame1.jpg": 10, "notes.txt": None, ".hidden.png": 99}
    for name, shade in shades.items():
        if shade is None:
            (tmp_path / name).write_text("not a frame")
        else:
            cv2.imwrite(str(tmp_path / name), np.full((6, 8, 3), shade, np.uint8))
    (tmp_path / "sub.png").mkdir()  # a folder whose name looks like an image is not a frame
    assert [int(image[0, 0, 0]) for image in open_source(tmp_path)] == [10, 20, 30]


def test_images_are_decoded_one_at_a_time(short_scene, on_disk, monkeypatch):
    decoded = []
    real = cv2.imdecode
    monkeypatch.setattr(video.cv2, "imdecode", lambda *a: decoded.append(1) or real(*a))
    frames = iter(open_source(on_disk["folder"]))
    assert len(decoded) == 1  # the first image, for the size
    next(frames), next(frames)
    assert len(decoded) == 3


def test_an_image_pattern_need_not_exist_as_a_file_and_counts_from_one(short_scene, tmp_path):
    write_images(tmp_path / "img1", short_scene[0][:3])
    source = open_source(str(tmp_path / "img1" / "%06d.png"))
    assert source.kind == "pattern" and source.count == 3
    assert np.array_equal(list(source)[2], short_scene[0][2])


def test_the_public_detections_of_a_sequence_are_not_read(short_scene, tmp_path):
    folder = write_sequence(tmp_path / "SEQ", short_scene[0][:2])
    (folder / "det").mkdir()
    (folder / "det" / "det.txt").write_text("this is not read\n")
    assert len(list(open_source(folder))) == 2


def test_a_sequence_without_seq_length_lists_its_image_folder(short_scene, tmp_path):
    folder = write_sequence(tmp_path / "SEQ", short_scene[0][:3], info="[Sequence]\nimDir=img1\nimExt=.png\n")
    source = open_source(folder)
    assert source.count == 3 and source.fps == 25.0


# -- bad sources: one line naming the file --------------------------------------------------------------
def garbage(path: Path) -> Path:
    path.write_bytes(b"\xff\xd8 this is not a JPEG " * 20)
    return path


def test_an_empty_folder_is_refused(tmp_path):
    with pytest.raises(VideoError, match="holds no image file"):
        open_source(tmp_path)


def test_an_unreadable_first_image_is_refused_at_once(tmp_path):
    garbage(tmp_path / "000001.jpg")
    with pytest.raises(VideoError, match=r"000001\.jpg'?: OpenCV cannot decode it"):
        open_source(tmp_path)


def test_an_unreadable_later_image_is_named_when_its_frame_comes(short_scene, tmp_path):
    write_images(tmp_path, short_scene[0][:2])
    garbage(tmp_path / "000003.png")
    source = open_source(tmp_path)
    frames = iter(source)
    next(frames), next(frames)
    with pytest.raises(VideoError, match=r"000003\.png'?: OpenCV cannot decode it") as info:
        next(frames)
    assert "\n" not in str(info.value)


def test_an_image_of_another_size_is_named(short_scene, tmp_path):
    write_images(tmp_path, short_scene[0][:2])
    cv2.imwrite(str(tmp_path / "000003.png"), short_scene[0][2][:100, :100])
    with pytest.raises(VideoError, match=r"000003\.png' has size 100x100, the earlier images .* 320x240"):
        list(open_source(tmp_path))


@pytest.mark.parametrize("info, message", [
    ("[Sequence]\nname=x\nframeRate=30\n", "no imDir"),
    ("name=x\n", "not a valid INI file"),
    ("[Other]\nimDir=img1\n", r"no \[Sequence\] section"),
    ("[Sequence]\nimDir=img1\nseqLength=ten\n", "seqLength must be a positive whole number, got 'ten'"),
    ("[Sequence]\nimDir=img1\nframeRate=0\n", "frameRate must be a positive number"),
    ("[Sequence]\nimDir=img2\n", "is not a folder"),
    ("[Sequence]\nimDir=img1\nimExt=.png\nseqLength=3\n", r"seqLength=3 but the frame .*000003\.png' is missing"),
    ("[Sequence]\nimDir=img1\nimExt=.png\nimWidth=640\nimHeight=480\n", "320x240, but .* says 640x480"),
])
def test_a_bad_seqinfo_is_refused_naming_the_problem(short_scene, tmp_path, info, message):
    folder = write_sequence(tmp_path / "SEQ", short_scene[0][:2], info=info)
    with pytest.raises(VideoError, match=message) as raised:
        open_source(folder)
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize("name, message", [("missing.avi", "no such file"),
                                           ("img%06d.png", "neither .*img000000.png' nor .*img000001.png' exists"),
                                           ("img%s%s.png", "not an image pattern")])
def test_a_path_that_is_nothing_is_refused(tmp_path, name, message):
    with pytest.raises(VideoError, match=message):
        open_source(str(tmp_path / name))
