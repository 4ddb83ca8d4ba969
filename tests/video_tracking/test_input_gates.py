"""The gates of the media and settings inputs (issue 26, point 1): sizes checked before any work.

Each test replays one hostile input of the issue, or its class: an image whose header claims
20 000 x 20 000 pixels, a video over the pixel limit, particle counts over the memory estimate,
settings without a range, a seqinfo.ini of 10^7 frames, an image pattern of a 300-million-digit
width, an empty source, FIFOs and devices where a file is expected.  The files are tiny: a
header is enough to be refused.
"""

from __future__ import annotations

import os
import struct
import zlib
from dataclasses import fields, is_dataclass
from pathlib import Path

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

from belief.cli import main  # noqa: E402
from belief_tracking import limits  # noqa: E402
from belief_tracking.config import TrackerConfig  # noqa: E402
from belief_tracking.errors import TrackingError, VideoError  # noqa: E402
from belief_tracking.initiation import InitiationConfig  # noqa: E402
from belief_tracking.sources import open_source  # noqa: E402


def png_header(width: int, height: int) -> bytes:
    """A PNG whose header claims ``width`` x ``height`` pixels, with a few bytes of image data."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 100)) + \
        chunk(b"IEND", b"")


def write_video(path: Path, width: int = 64, height: int = 48, frames: int = 3) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 25, (width, height))
    for k in range(frames):
        writer.write(np.full((height, width, 3), 30 * k, np.uint8))
    writer.release()
    return path


def one_line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 1 and err.startswith("belief: error:"), err
    return err


@pytest.fixture
def no_decoding(monkeypatch):
    """Make any image decoding fail the test: a refusal must come from the header."""
    def refuse(*args, **kwargs):
        raise AssertionError("an image was decoded")
    monkeypatch.setattr(cv2, "imdecode", refuse)


# -- image files: the size from the header, before decoding -----------------------------------------
def test_a_20000_square_png_in_a_folder_is_refused_from_its_header(tmp_path, no_decoding):
    (tmp_path / "000001.png").write_bytes(png_header(20000, 20000))
    with pytest.raises(limits.TrackingLimitError, match=r"20000 x 20000 = 400,000,000 pixels.*--max-pixels N"):
        open_source(tmp_path)


def test_a_large_later_image_is_refused_before_it_is_decoded(tmp_path, monkeypatch):
    cv2.imwrite(str(tmp_path / "000001.png"), np.zeros((24, 32, 3), np.uint8))
    (tmp_path / "000002.png").write_bytes(png_header(30000, 30000))
    source = open_source(tmp_path)
    frames = iter(source)
    next(frames)
    decoded = []
    monkeypatch.setattr(cv2, "imdecode", lambda *a: decoded.append(1))
    with pytest.raises(limits.TrackingLimitError, match="30000 x 30000"):
        next(frames)
    assert not decoded


@pytest.mark.parametrize("extension", [".png", ".jpg", ".bmp", ".tif", ".webp", ".ppm", ".pgm", ".jp2"])
def test_the_header_gives_the_size_of_every_format_of_a_folder(extension):
    image = np.random.default_rng(0).integers(0, 255, (37, 53, 3), dtype=np.uint8)
    if extension == ".pgm":
        image = image[:, :, 0]
    ok, data = cv2.imencode(extension, image)
    if not ok:  # pragma: no cover - an OpenCV built without that codec
        pytest.skip(f"OpenCV cannot write {extension}")
    assert limits.image_size(data.tobytes()) == (53, 37)


def test_a_bmp_and_a_jpeg_header_over_the_limit_are_refused(tmp_path, no_decoding):
    bmp = b"BM" + b"\0" * 12 + struct.pack("<Iii", 40, 50000, -50000) + b"\0" * 40
    jpeg = b"\xff\xd8\xff\xe0" + struct.pack(">H", 16) + b"JFIF\0" + b"\0" * 9 + \
        b"\xff\xc0" + struct.pack(">HBHHB", 17, 8, 60000, 60000, 3) + b"\0" * 9
    for name, data in (("a.bmp", bmp), ("b.jpg", jpeg)):
        folder = tmp_path / name.split(".")[0]
        folder.mkdir()
        (folder / name).write_bytes(data)
        with pytest.raises(limits.TrackingLimitError, match="--max-pixels"):
            open_source(folder)


def test_a_raised_pixel_limit_lets_the_header_pass(tmp_path):
    (tmp_path / "000001.png").write_bytes(png_header(100, 100))
    with limits.applied({"max-pixels": 20_000}):
        # Past the header the file is broken: it is then refused as undecodable, not as too large.
        with pytest.raises(VideoError, match="OpenCV cannot decode it"):
            open_source(tmp_path)
    with limits.applied({"max-pixels": 9_999}), pytest.raises(limits.TrackingLimitError):
        open_source(tmp_path)


def test_an_image_file_larger_than_any_frame_is_refused_before_it_is_read(tmp_path, monkeypatch):
    image = tmp_path / "000001.png"
    image.write_bytes(png_header(10, 10))
    with open(image, "ab") as handle:       # a sparse tail: a large file of no data
        handle.truncate(limits.image_bytes_limit() + 10)
    monkeypatch.setattr(np, "fromfile", lambda *a, **k: pytest.fail("the file was read"))
    with pytest.raises(limits.TrackingLimitError, match="bytes"):
        open_source(tmp_path)


# -- video files: the size from the container, before a frame is decoded ------------------------------
def test_a_video_over_the_pixel_limit_is_refused_before_a_frame_is_decoded(tmp_path, monkeypatch):
    from belief_tracking.video import VideoReader

    video = write_video(tmp_path / "v.avi", 64, 48)
    monkeypatch.setattr(VideoReader, "_read", lambda self: pytest.fail("a frame was decoded"))
    with limits.applied({"max-pixels": 64 * 48 - 1}):
        with pytest.raises(limits.TrackingLimitError, match=r"64 x 48 = 3,072 pixels.*--max-pixels N"):
            open_source(video)


def test_a_video_within_the_limits_opens(tmp_path):
    with open_source(write_video(tmp_path / "v.avi")) as source:
        assert (source.width, source.height, len(list(source))) == (64, 48, 3)


def test_a_fifo_as_the_video_is_refused_without_opening_it(tmp_path):
    fifo = tmp_path / "v.avi"
    os.mkfifo(fifo)
    # Opening a FIFO with no writer blocks: the refusal must come from its type alone.
    with pytest.raises(VideoError, match="it is a FIFO, not a regular file"):
        open_source(fifo)


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero")
def test_a_device_as_the_video_is_refused():
    with pytest.raises(VideoError, match="it is a device, not a regular file"):
        open_source("/dev/zero")


def test_fifos_among_images_are_not_frames_and_a_fifo_seqinfo_is_refused(tmp_path):
    cv2.imwrite(str(tmp_path / "000001.png"), np.zeros((24, 32, 3), np.uint8))
    os.mkfifo(tmp_path / "000002.png")
    assert open_source(tmp_path).count == 1
    sequence = tmp_path / "SEQ"
    (sequence / "img1").mkdir(parents=True)
    os.mkfifo(sequence / "seqinfo.ini")
    with pytest.raises(VideoError, match="FIFO"):
        open_source(sequence)


# -- paths, patterns and sequences ----------------------------------------------------------------
@pytest.mark.parametrize("source", ["", "   ", "\t\n"])
def test_an_empty_source_is_refused_rather_than_the_working_folder(source):
    with pytest.raises(TrackingError, match="empty path"):
        open_source(source)


def test_belief_track_of_an_empty_path_is_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    cv2.imwrite(str(tmp_path / "000001.png"), np.zeros((24, 32, 3), np.uint8))   # would be tracked
    assert main(["track", "", "--out", str(tmp_path / "o"), "--no-progress"]) == 1
    assert "empty path" in one_line(capsys)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("pattern", ["%300000000d.png", "%.300000000d.png", "%0999999999999999999999d.png"])
def test_a_pattern_of_a_huge_width_is_refused_in_a_short_message(tmp_path, pattern):
    with pytest.raises(VideoError, match="more than 32 digits") as raised:
        open_source(str(tmp_path / pattern))
    assert len(str(raised.value)) < 600


@pytest.mark.parametrize("name", ["x" * 100_000 + "%s%s.png", "x" * 100_000 + ".avi", "x" * 200 + "%s.png",
                                  "a/" * 50_000 + "%06d.png"])
def test_a_long_source_is_quoted_shortened_in_one_line(tmp_path, name):
    with pytest.raises(VideoError) as raised:
        open_source(str(tmp_path / name))
    message = str(raised.value)
    assert len(message) < 600 and "\n" not in message and "characters)" in message, message[:600]


def sequence(tmp_path: Path, info: str) -> Path:
    folder = tmp_path / "SEQ"
    (folder / "img1").mkdir(parents=True)
    cv2.imwrite(str(folder / "img1" / "000001.png"), np.zeros((24, 32, 3), np.uint8))
    (folder / "seqinfo.ini").write_text("[Sequence]\nimDir=img1\nimExt=.png\n" + info)
    return folder


@pytest.mark.parametrize("length", ["10000000", "100000000000000000000", "9" * 90])
def test_a_seqlength_over_the_frame_limit_is_refused_before_any_file_is_looked_for(tmp_path, monkeypatch, length):
    folder = sequence(tmp_path, f"seqLength={length}\n")
    monkeypatch.setattr(Path, "is_file", lambda self: pytest.fail("a frame was looked for"))
    with pytest.raises(limits.TrackingLimitError, match=r"frames \(seqLength\).*--max-frames N"):
        open_source(folder)


@pytest.mark.parametrize("info, message", [
    ("seqLength=1_0\n", "seqLength must be a positive whole number, got '1_0'"),
    ("seqLength= 1e3\n", "seqLength must be a positive whole number"),
    ("frameRate=inf\n", "frameRate must be a positive number"),
    ("frameRate=nan\n", "frameRate must be a positive number"),
    ("frameRate=1e300\n", "frameRate = 1e300 is more than 1000"),
    ("seqLength=10000\n", r"seqLength=10000 but the frame .*000002\.png' is missing"),
])
def test_seqinfo_numbers_are_read_strictly_and_within_the_limits(tmp_path, info, message):
    with pytest.raises(VideoError, match=message):
        open_source(sequence(tmp_path, info))


def test_a_seqinfo_image_size_over_the_pixel_limit_is_refused(tmp_path):
    with pytest.raises(limits.TrackingLimitError, match="100000 x 100000.*--max-pixels N"):
        open_source(sequence(tmp_path, "imWidth=100000\nimHeight=100000\n"))


def test_a_large_seqinfo_is_refused_unread(tmp_path):
    folder = sequence(tmp_path, "")
    with open(folder / "seqinfo.ini", "ab") as handle:
        handle.truncate(limits.MAX_TEXT_BYTES + 1)
    with pytest.raises(VideoError, match="bytes, more than"):
        open_source(folder)


def test_a_folder_of_more_images_than_the_frame_limit_is_refused(tmp_path):
    for k in range(1, 6):
        (tmp_path / f"{k:06d}.png").write_bytes(png_header(8, 8))
    with limits.applied({"max-frames": 4}), pytest.raises(limits.TrackingLimitError, match="--max-frames"):
        open_source(tmp_path)
    with limits.applied({"max-frames": 4}), pytest.raises(limits.TrackingLimitError, match="--max-frames"):
        open_source(str(tmp_path / "%06d.png"))


# -- the tracker's settings ---------------------------------------------------------------------------
@pytest.mark.parametrize("particles", [10**6, 10**7, 10**9, 10**20])
def test_a_particle_count_over_the_memory_estimate_is_refused(particles):
    with pytest.raises(TrackingError, match="--max-memory N|64-bit"):
        TrackerConfig.from_settings({"particles": particles}, "belief track")
    if particles < 2**63:
        with pytest.raises(limits.TrackingLimitError, match=r"particles x 100 targets .*--particles N"):
            TrackerConfig(particles=particles)


def test_the_particle_bound_follows_max_targets_and_the_memory_limit():
    TrackerConfig(particles=1000)
    TrackerConfig(particles=100_000, max_targets=4)
    with limits.applied({"max-memory": 200 << 20}), pytest.raises(limits.TrackingLimitError):
        TrackerConfig(particles=100_000, max_targets=4)


@pytest.mark.parametrize("settings, message", [
    ({"colour": {"samples": [100000, 100000]}}, "sample points a box, more than 4,096"),
    ({"edges": {"samples": [1000, 5]}}, "sample points"),
    ({"background": {"mixtures": 100000}}, "mixtures must be at most 16"),
    ({"background": {"history": 2**31}}, "history must be at most 100,000"),
    ({"background": {"downscale": 10**6}}, "downscale must be at most"),
    ({"cues": 5}, "cues must be a list of cue names, got 5"),
    ({"cues": [5]}, "cues must be a list of cue names"),
    ({"cues": [["colour"]]}, "cues must be a list of cue names"),
    ({"fusion": ["belief"]}, "unknown fusion"),
    ({"resampling": {"a": 1}}, "unknown resampler"),
    ({"motion": {"sigma_pos": 1e308}}, "sigma_pos must be at most"),
    ({"motion": {"dt": 1e300}}, "dt must be positive and at most"),
    ({"init_sigma": 1e308}, "init_sigma must be at most"),
    ({"location": {"sigma": 1e300}}, "location.sigma must be at most"),
    ({"colour": {"sigma": 1e-300}}, "colour.sigma must be at least"),
    ({"warm_up": 10**9}, "warm_up must be an integer <="),
    ({"max_targets": 10**12}, "max_targets must be an integer <="),
    ({"initiation": {"opening": 2**31}}, "initiation.opening must be an integer <="),
    ({"cues": "x" * 10**6}, "characters, more than the 200"),
    ({"belief": {"rule": "x" * 10**6}}, "characters, more than the 200"),
])
def test_settings_without_a_sensible_range_are_refused(settings, message):
    with pytest.raises(TrackingError, match=message) as raised:
        TrackerConfig.from_settings(settings, "settings")
    assert len(str(raised.value)) < 800


def test_settings_nested_10000_deep_are_refused_without_recursion():
    deep: list = []
    for _ in range(10_000):
        deep = [deep]
    with pytest.raises(TrackingError, match="nests more than 8 deep"):
        TrackerConfig.from_settings({"cues": deep})
    with pytest.raises(TrackingError, match="nests more than 8 deep"):
        TrackerConfig.from_settings({"colour": {"samples": deep}})


def test_a_toml_nested_10000_deep_is_refused_without_recursion(tmp_path):
    file = tmp_path / "settings.toml"
    file.write_text("x = " + "[" * 10_000 + "]" * 10_000 + "\n")
    with pytest.raises(TrackingError, match="nest more than 8 deep"):
        limits.load_toml(file, "settings file")
    file.write_text("x = " + "{a = " * 10_000 + "1" + "}" * 10_000 + "\n")
    with pytest.raises(TrackingError, match="nest more than 8 deep"):
        limits.load_toml(file, "settings file")
    with pytest.raises(TrackingError, match="nest more than 8 deep"):
        limits.toml_value("[" * 10_000 + "]" * 10_000, "--set cues=...")


def test_a_toml_of_the_tracker_settings_reads_and_its_bad_values_are_refused(tmp_path):
    file = tmp_path / "settings.toml"
    file.write_text('particles = 50\ncues = ["colour", "location"]  # brackets [[ in a comment\n'
                    'note = "[[[[[[[[[[[["\n[motion]\nsigma_pos = 4\n')
    settings = limits.load_toml(file, "settings file")
    settings.pop("note")
    assert TrackerConfig.from_settings(settings).motion.sigma_pos == 4.0
    file.write_text("cues = 5\n")
    with pytest.raises(TrackingError, match="cues must be a list of cue names, got 5"):
        TrackerConfig.from_settings(limits.load_toml(file, "settings file"), str(file))
    os.unlink(file)
    os.mkfifo(file)
    with pytest.raises(TrackingError, match="FIFO"):
        limits.load_toml(file, "settings file")


HOSTILE = [10**20, 2**63, -1, 1e308, float("nan"), float("inf"), "x" * 5000, [], [[[]]], {"a": 1}, True, 2**31,
           1e-300, [10**6, 10**6]]


def test_no_hostile_value_of_any_setting_raises_anything_but_a_tracking_error():
    defaults = TrackerConfig()
    for field in fields(TrackerConfig):
        default = getattr(defaults, field.name)
        kind = InitiationConfig if field.name == "initiation" else type(default) if is_dataclass(default) else None
        cases = [{field.name: {inner.name: value}} for inner in fields(kind) for value in HOSTILE] if kind else \
            [{field.name: value} for value in HOSTILE]
        for settings in cases:
            try:
                TrackerConfig.from_settings(settings)
            except TrackingError as exc:
                assert len(str(exc)) < 800 and "\n" not in str(exc), settings
            except Exception as exc:  # pragma: no cover - the failure to report
                pytest.fail(f"{settings!r:.100}: {type(exc).__name__}: {exc}")


def test_the_command_line_refuses_a_huge_particle_count_in_one_line(tmp_path, capsys):
    assert main(["track", "--demo", "--out", str(tmp_path / "o"), "--particles", str(10**7),
                 "--no-progress"]) == 1
    assert "--max-memory N" in one_line(capsys)
    assert not (tmp_path / "o").exists()


def test_the_command_line_refuses_sigma_pos_1e308_in_one_line(tmp_path, capsys):
    assert main(["track", "--demo", "--out", str(tmp_path / "o"), "--set", "motion.sigma_pos=1e308",
                 "--no-progress"]) == 1
    assert "sigma_pos must be at most" in one_line(capsys)


# -- the run's estimate, from the sizes ---------------------------------------------------------------
class _Source:
    def __init__(self, width, height, count=100):
        self.width, self.height, self.count, self.name = width, height, count, "v.avi"


def test_the_memory_estimate_accepts_4k_and_refuses_a_long_warm_up_of_large_frames():
    estimate = limits.check_run(TrackerConfig(warm_up=50, initiation=InitiationConfig()), _Source(3840, 2160))
    assert estimate.total < limits.MAX_MEMORY
    config = TrackerConfig(warm_up=1000, initiation=InitiationConfig())
    with pytest.raises(limits.TrackingLimitError, match="--warm-up N"):
        limits.check_run(config, _Source(3840, 2160, count=5000))
    # The warm-up holds no more frames than the source has.
    limits.check_run(config, _Source(3840, 2160, count=20))


def test_a_spread_larger_than_the_frame_is_refused_for_the_run():
    config = TrackerConfig.from_settings({"motion": {"sigma_pos": 5000}})
    with pytest.raises(TrackingError, match="larger than the frame's diagonal"):
        limits.check_run(config, _Source(320, 240))
    limits.check_run(config, _Source(8000, 1000))


def test_a_long_run_states_its_estimated_time_and_memory_before_it_starts():
    config = TrackerConfig()
    assert limits.long_run_notice(config, _Source(320, 240, count=100), None) is None
    long = limits.long_run_notice(config, _Source(1920, 1080, count=20_000), None)
    assert long.startswith("v.avi: 20,000 frames of 1920 x 1080 with ")
    assert "with one target" in long and f"with {config.max_targets:,} at once (max_targets)" in long
    assert "of memory" in long
    planned = limits.long_run_notice(config, _Source(1920, 1080, count=20_000), 3)
    assert "with 3 targets at once" in planned
    # the time grows with the frames, the pixels and the particles
    small = limits.estimate_seconds(config, 320, 240, 1000, 2)
    assert limits.estimate_seconds(config, 320, 240, 2000, 2) > small
    assert limits.estimate_seconds(config, 640, 480, 1000, 2) > small
    assert limits.estimate_seconds(TrackerConfig(particles=1000), 320, 240, 1000, 2) > small


def test_the_command_line_announces_a_long_run_on_standard_error(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(limits, "LONG_RUN_SECONDS", 0.0)
    video = write_video(tmp_path / "v.avi")
    assert main(["track", str(video), "--out", str(tmp_path / "o"), "--no-progress", "--no-video"]) == 0
    err = capsys.readouterr().err
    assert "belief track: " in err and "3 frames of 64 x 48" in err and "of memory" in err


def test_messages_name_the_file_s_role_and_carry_one_prefix(tmp_path, capsys):
    tracks = tmp_path / "t.txt"
    tracks.write_text("1,1,10,10,20,40,1,-1,-1,-1\n", encoding="utf-8")
    assert main(["eval", str(tracks), str(tmp_path / "missing_gt.txt")]) == 1
    assert "cannot read ground-truth file" in one_line(capsys)
    assert main(["eval", str(tmp_path / "missing.txt"), str(tracks)]) == 1
    assert "cannot read tracks file" in one_line(capsys)
    assert main(["track", "--demo", "--out", str(tmp_path / "o"), "--cues", "sound", "--no-progress"]) == 1
    err = one_line(capsys)
    assert err.count("belief") == 1 and "unknown cue 'sound'" in err


def test_the_american_spelling_of_colour_names_the_colour_cue():
    assert TrackerConfig(cues=("color", "location")).cues == ("colour", "location")
