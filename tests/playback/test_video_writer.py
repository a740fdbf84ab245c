"""Videos that browsers play: H.264 .mp4 and VP9 .webm through PyAV, read back with PyAV itself;
OpenCV's mp4v when PyAV is missing."""

from __future__ import annotations

import numpy as np
import pytest

from morf.errors import InputError
from morf.playback.video_sink import VideoSink
from tests.conftest import require

av = require("av")


def gradient_frames(n: int, w: int, h: int) -> list[np.ndarray]:
    """Smooth colour ramps that move a little per frame (lossy codecs keep them close)."""
    yy, xx = np.mgrid[0:h, 0:w]
    return [np.stack([(xx * 255 // max(w - 1, 1) + 8 * i) % 256, yy * 255 // max(h - 1, 1),
                      np.full_like(xx, 60 + 20 * i)], -1).astype(np.uint8) for i in range(n)]


def write(path, frames, fps=24.0):
    h, w = frames[0].shape[:2]
    sink = VideoSink(path, fps, (w, h))
    for f in frames:
        sink.write(f)
    sink.close()
    return sink


def read_back(path):
    """(codec name, pixel format, frame rate, RGB frames, first decoded frame) as PyAV reads them."""
    with av.open(str(path)) as c:
        s = c.streams.video[0]
        decoded = list(c.decode(s))
        frames = [f.to_ndarray(format="rgb24") for f in decoded]
        return s.codec_context.name, s.codec_context.pix_fmt, float(s.average_rate), frames, decoded[0]


@pytest.mark.parametrize("name,codec,label", [("v.mp4", "h264", "H.264"), ("v.webm", "vp9", "VP9")])
def test_browser_codecs_read_back(tmp_path, name, codec, label):
    frames = gradient_frames(6, 64, 48)
    sink = write(tmp_path / name, frames)
    assert sink.codec.label == label and sink.count == 6
    got_codec, pix_fmt, rate, decoded, first = read_back(tmp_path / name)
    assert (got_codec, pix_fmt) == (codec, "yuv420p")
    assert rate == pytest.approx(24.0)
    assert len(decoded) == 6
    for a, b in zip(decoded, frames):
        assert a.shape == b.shape
        assert np.abs(a.astype(int) - b).mean() < 4  # lossy, but the same picture in the same colours
    assert first.colorspace == 1  # tagged BT.709, as converted
    assert not list(tmp_path.glob(".*")), "temporary file left behind"


def test_mp4_has_its_index_first_and_odd_sizes_are_padded(tmp_path):
    frames = gradient_frames(3, 63, 47)
    write(tmp_path / "odd.mp4", frames)
    data = (tmp_path / "odd.mp4").read_bytes()
    assert 0 <= data.find(b"moov") < data.find(b"mdat")  # a browser can start before the file has arrived
    _, _, _, decoded, _ = read_back(tmp_path / "odd.mp4")
    assert decoded[0].shape == (48, 64, 3)
    assert np.abs(decoded[1][:47, :63].astype(int) - frames[1]).mean() < 4


def test_without_pyav_mp4_falls_back_to_mp4v_and_webm_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr("morf.playback.video_writer.pyav_encoder", lambda name: False)
    sink = write(tmp_path / "v.mp4", gradient_frames(4, 64, 48))
    assert sink.codec.encoder == "mp4v"
    codec, _, _, decoded, _ = read_back(tmp_path / "v.mp4")
    assert codec == "mpeg4" and len(decoded) == 4
    with pytest.raises(InputError, match="needs PyAV"):
        VideoSink(tmp_path / "v.webm", 24.0, (64, 48))
    assert not (tmp_path / "v.webm").exists()


def test_play_command_says_which_codec(tiny_avatar, tmp_path, capsys):
    from morf.cli.main import main
    from morf.io import save_npz

    rng = np.random.default_rng(0)
    rot = (rng.normal(size=(4, 104, 3)) * 0.1).astype(np.float32)
    save_npz(tmp_path / "m.npz", rotvecs=rot, transl=np.zeros((4, 3), np.float32), fps=np.array(30.0))
    for name, codec, label in (("v.mp4", "h264", "H.264"), ("v.webm", "vp9", "VP9")):
        out = tmp_path / name
        argv = ["play", str(tiny_avatar), "--motion", str(tmp_path / "m.npz"), "--out", str(out), "--size", "64"]
        assert main(argv) == 0
        assert f"wrote 4 frames to {out} ({label}" in capsys.readouterr().out
        got, _, _, decoded, _ = read_back(out)
        assert got == codec and len(decoded) == 4 and decoded[0].std() > 1.0  # something was drawn
