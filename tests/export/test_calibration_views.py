"""int8 calibration at the player's scale: mosaics of the training views, the same poses closer."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from morf.camera import PinholeCamera
from morf.export.avatar_folder import int8_check_db
from morf.export.calibration_views import CANVAS, closer_scales, mosaic, playback_zoom, zoomed_camera
from morf.raster.texture_quant import ZERO_POINT


def _camera(size=64, f=80.0):
    return PinholeCamera(fx=f, fy=f, cx=size / 2, cy=size / 2, width=size, height=size, R=np.eye(3), t=np.zeros(3))


def test_mosaic_puts_four_views_to_a_canvas_and_fills_the_rest_with_background():
    views = [np.full((1, 16, 4, 6), 10 * (k + 1), np.uint8) for k in range(5)]
    canvases = mosaic(views)
    assert [c.shape for c in canvases] == [(1, 16, 8, 12)] * 2
    first, second = canvases
    assert (first[:, :, :4, :6] == 10).all() and (first[:, :, :4, 6:] == 20).all()
    assert (first[:, :, 4:, :6] == 30).all() and (first[:, :, 4:, 6:] == 40).all()
    assert (second[:, :, :4, :6] == 50).all() and (second[:, :, :4, 6:] == ZERO_POINT).all()
    assert (second[:, :, 4:] == ZERO_POINT).all()


def test_a_zoomed_camera_shows_the_body_zoom_times_larger_around_the_canvas_centre():
    cam = _camera()
    z = zoomed_camera(cam, 1.7)
    assert (z.width, z.height) == (CANVAS * cam.width, CANVAS * cam.height)
    point = np.array([0.11, -0.07, 2.0])

    def project(c):
        return np.array([c.fx * point[0] / point[2] + c.cx, c.fy * point[1] / point[2] + c.cy])

    centre, zcentre = np.array([cam.cx, cam.cy]), np.array([z.width / 2, z.height / 2])
    np.testing.assert_allclose(project(z) - zcentre, 1.7 * (project(cam) - centre))


def test_playback_zoom_is_the_largest_trained_scale_over_the_views_median():
    cam = _camera(f=100.0)
    transls = [np.array([0, 0, d]) for d in (2.0, 2.5, 4.0)]  # 50, 40, 25 px/m: median 40
    assert playback_zoom(cam, transls, 100.0) == pytest.approx(2.5)
    assert playback_zoom(cam, transls, 20.0) == 1.0  # never less than the views themselves
    assert playback_zoom(cam, transls, None) == 1.0 and playback_zoom(cam, [], 100.0) == 1.0


def test_the_closer_scales_are_halfway_with_half_the_views_and_all_the_way():
    assert closer_scales(4.0) == ((2.0, 0.5), (4.0, 1.0))


def test_the_int8_check_is_the_lowest_of_every_scale_measured():
    q = {"psnr_db": 50.0, "psnr_person_db": 42.0}
    assert int8_check_db({"int8_quality": q}) == 42.0
    assert int8_check_db({"int8_quality": {**q, "playback_scale": {"psnr_db": 45.0, "psnr_person_db": 36.5}}}) == 36.5
    assert int8_check_db({"int8_quality": {"psnr_db": 38.0}}) == 38.0  # older folders: the image's alone
    assert int8_check_db({}) is None


def test_the_export_calibrates_and_checks_int8_on_views_as_close_as_the_player_draws(tmp_path, body_model,
                                                                                     monkeypatch):
    """The calibrator gets the training views four to a canvas plus the same poses sqrt(2) and twice
    as close (the body two and four times the pixels), and the manifest reports the check at the
    training views' scale and the player's."""
    import morf.export.export_avatar as ea
    from morf.export.synthetic import build_synthetic_avatar, coverage_renderer, coverage_texture

    seen = []
    real = ea.export_int8

    def spy(renderer, scales, path, calibration, layout):
        seen.extend(calibration)
        return real(renderer, scales, path, calibration, layout)

    monkeypatch.setattr(ea, "export_int8", spy)
    manifest = build_synthetic_avatar(tmp_path / "a", body_model=body_model, renderer=coverage_renderer(),
                                      texture=coverage_texture(), renderer_cfg=SimpleNamespace(in_channels=16),
                                      image_size=64, calibration_views=5, heldout_views=2, playback_zoom=2.0)
    assert [c.shape for c in seen] == [(1, 16, 128, 128)] * (2 + 5 + 5)  # 5 views on 2 canvases, 5 + 5 closer
    tiles = [c[:, :, y:y + 64, x:x + 64] for c in seen[:2] for y in (0, 64) for x in (0, 64)][:5]
    body = lambda r: int((r[0, 0] != ZERO_POINT).sum())  # noqa: E731  (coverage channel)
    for tile, halfway, close in zip(tiles, seen[2:7], seen[7:]):
        assert 1.5 < body(halfway) / body(tile) < 2.6  # sqrt(2) times as close: twice the pixels
        assert 3.0 < body(close) / body(tile) < 5.0  # twice as close: four times the pixels
    q = manifest["int8_quality"]
    assert q["playback_scale"]["zoom"] == 2.0 and q["playback_scale"]["views"] == 2
    checks = [q["psnr_db"], q["psnr_person_db"], q["playback_scale"]["psnr_db"], q["playback_scale"]["psnr_person_db"]]
    assert all(np.isfinite(checks)) and int8_check_db(manifest) == min(checks)
    assert manifest["renderer"]["int8"]["calibration_zoom"] == [1.0, 1.414, 2.0]
    assert manifest["renderer"]["int8"]["calibration_views"] == 15


def test_without_a_playback_zoom_the_export_calibrates_on_the_views_alone(tmp_path, body_model):
    from morf.export.synthetic import build_synthetic_avatar, coverage_renderer, coverage_texture

    manifest = build_synthetic_avatar(tmp_path / "a", body_model=body_model, renderer=coverage_renderer(),
                                      texture=coverage_texture(), renderer_cfg=SimpleNamespace(in_channels=16),
                                      image_size=64, calibration_views=3, heldout_views=1)
    assert "playback_scale" not in manifest["int8_quality"]
    assert manifest["renderer"]["int8"]["calibration_zoom"] == [1.0]
    assert manifest["renderer"]["int8"]["calibration_views"] == 3
