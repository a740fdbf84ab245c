"""The automatic size choice: features from images, and the rule's direction on plain vs detailed
clothing (fake projects without fits, so no body model or OpenGL is needed)."""

from pathlib import Path

import numpy as np

from morf.sizing.choose import SizingRule, choose_from_features, choose_train_config
from morf.sizing.features import CaptureFeatures, image_features
from morf.train.config import preset


class FakeProject:
    """Just what capture_features reads: frames, masks, decisions; no fits, no ground truth."""

    def __init__(self, root: Path, pattern: str, n: int = 4, size: int = 128):
        self.root = root
        self.num_frames = n
        self.image_size = (size, size)
        self.fits_path = root / "fits" / "fits.npz"
        self.ground_truth_dir = root / "ground_truth"
        self.ground_truth_path = self.ground_truth_dir / "gt.npz"
        y, x = np.mgrid[0:size, 0:size]
        k = size / 128
        self.mask = (abs(x - size / 2) < 20 * k) & (y > 14 * k) & (y < 114 * k)  # a person 99 px tall at 128 px
        body = np.full((size, size, 3), 140, np.uint8)
        on = {"print": ((x // (2 * k)) + (y // (2 * k))) % 2,  # 2 px squares at 128 px, 8 at 512
              "hairline": (x + y) % 2,  # 1 px squares at any size: finer than a 256 px training crop holds
              "colour": (y // (4 * k)) % 2}.get(pattern)  # red / green stripes of equal luminance
        if pattern in ("print", "hairline"):
            body = np.where(on[..., None] == 1, 230, 40).astype(np.uint8) * np.ones(3, np.uint8)
        elif pattern == "colour":
            body = np.where(on[..., None] == 1, np.array([200, 60, 60], np.uint8), np.array([60, 131, 60], np.uint8))
        self.frame = np.where(self.mask[..., None], body, 90).astype(np.uint8)

    def training_frames(self):
        return list(range(self.num_frames))

    def load_frame(self, i):
        return self.frame

    def load_mask(self, i):
        return self.mask


def test_image_features_detail_and_height(tmp_path):
    plain, fine = FakeProject(tmp_path, "plain"), FakeProject(tmp_path, "print")
    h, d_plain, _ = image_features([plain.frame], [plain.mask])
    _, d_fine, _ = image_features([fine.frame], [fine.mask])
    assert h == 99
    assert d_plain < 1e-3 < d_fine


def test_detail_is_measured_at_the_training_scale_and_in_colour(tmp_path):
    rule, person_px = SizingRule(), 256 / 1.16  # the cpu preset's 256 px crop holds about 221 px of person
    hair = FakeProject(tmp_path, "hairline", size=512)  # 398 px of person, shrunk to 221 before measuring
    assert image_features([hair.frame], [hair.mask])[1] > rule.detail_high  # busy at the capture's scale
    assert image_features([hair.frame], [hair.mask], person_px)[1] < rule.detail_low  # gone at training scale
    colour = FakeProject(tmp_path, "colour", size=512)
    gray = (colour.frame.astype(np.float32) @ np.array([0.299, 0.587, 0.114], np.float32))[..., None].repeat(3, 2)
    assert image_features([gray.astype(np.uint8)], [colour.mask], person_px)[1] < rule.detail_low  # no luminance edge
    assert image_features([colour.frame], [colour.mask], person_px)[1] >= rule.detail_low
    cfg, why = choose_train_config(colour, "cpu")
    assert (cfg.texture_size, cfg.texture_channels) == (256, 8)
    assert any("training scale" in r for r in why)
    assert choose_train_config(hair, "cpu")[0].texture_size == 64


def test_auto_picks_larger_texture_for_detailed_clothing(tmp_path):
    # a person 398 px tall, capped at the 221 px the 256 px training crop holds: 0.9 * 221 / 0.82
    # = 243 -> 256^2 when detailed; 0.22 * 221 / 0.82 = 59 -> 64^2 when plain
    cfg_plain, why_plain = choose_train_config(FakeProject(tmp_path, "plain", size=512), "cpu")
    cfg_fine, why_fine = choose_train_config(FakeProject(tmp_path, "print", size=512), "cpu")
    assert (cfg_fine.texture_size, cfg_plain.texture_size) == (256, 64)
    # calibrated at default size: 8 channels cost plain clothing 0.7 dB and the print nothing at 256^2
    assert (cfg_fine.texture_channels, cfg_plain.texture_channels) == (8, 16)
    fine_dense, _ = choose_train_config(FakeProject(tmp_path, "print", size=512), "cpu",
                                        rule=SizingRule(density_high=1.0, density_low=0.5))
    plain_dense, _ = choose_train_config(FakeProject(tmp_path, "plain", size=512), "cpu",
                                         rule=SizingRule(density_high=1.0, density_low=0.5))
    assert fine_dense.texture_size > plain_dense.texture_size
    size = (lambda r: (r.stem, r.width, r.max_width))  # calibrated: the preset's renderer
    assert size(cfg_fine.renderer) == size(cfg_plain.renderer) == size(preset("cpu").renderer)
    assert cfg_plain.renderer.in_channels == cfg_plain.texture_channels
    assert cfg_fine.preset == "auto" and any("texture" in r for r in why_fine) and why_plain


def test_rule_follows_person_height_and_looseness():
    base = preset("cpu")
    f = CaptureFeatures(frames=200, person_height_px=400, image_height_px=512, detail=0.05, detail_coarse=0.1,
                        yaw_coverage_deg=360, pose_spread_rad=0.1, silhouette_excess=0.05)
    small = CaptureFeatures(**{**f.to_dict(), "person_height_px": 60})
    loose = CaptureFeatures(**{**f.to_dict(), "silhouette_excess": 0.3})
    big_cfg, _ = choose_from_features(f, base, "cpu")
    small_cfg, _ = choose_from_features(small, base, "cpu")
    loose_cfg, reasons = choose_from_features(loose, base, "cpu")
    stepping = SizingRule(plain_renderer_step=-1, loose_renderer_step=1)
    loose_step, _ = choose_from_features(loose, base, "cpu", stepping)
    # 256 px training crop -> about 221 px of person -> 0.9 * 221 / 0.82 = 243 texels -> 256;
    # 60 px -> 66 texels -> 128, the smallest texture the rule allows detailed clothing
    assert big_cfg.texture_size == 256 and small_cfg.texture_size == SizingRule().min_texture_by_detail[2] == 128
    denser, _ = choose_from_features(f, base, "cpu", SizingRule(density_high=1.0))
    assert denser.texture_size == 512
    lower = SizingRule(density_high=0.45, min_texture_by_detail=(64, 64, 64))  # 0.45 * 60 / 0.82 = 33 texels
    assert choose_from_features(small, base, "cpu", lower)[0].texture_size == 64
    assert loose_cfg.renderer.width == big_cfg.renderer.width and any("loose" in r for r in reasons)
    # loose garments get plain clothing's texel density (0.22 * 221 / 0.82 = 59 -> 64^2) and floor
    assert loose_cfg.texture_size == 64 < big_cfg.texture_size
    medium = CaptureFeatures(**{**f.to_dict(), "detail": 0.03})
    # medium detail is sized like detailed clothing (the striped print), a loose garment of the same
    # detail like plain clothing with 8 channels
    loose_medium = CaptureFeatures(**{**medium.to_dict(), "silhouette_excess": 0.3})
    assert [(c.texture_size, c.texture_channels) for c in (choose_from_features(m, base, "cpu")[0]
                                                           for m in (loose_medium, medium))] == [(64, 8), (256, 8)]
    assert choose_from_features(medium, base, "cpu", SizingRule(channels_by_detail=(16, 16, 8)))[0] \
        .texture_channels == 16
    assert (loose_cfg.texture_channels, big_cfg.texture_channels) == (8, 8)  # detailed clothing: 8 too
    assert choose_from_features(loose, base, "cpu", SizingRule(channels_loose=16))[0].texture_channels == 16
    assert any("loose garments -> 8 texture channels" in r for r in reasons)
    assert choose_from_features(loose, base, "cpu", SizingRule(density_loose=0.45))[0].texture_size == 128
    assert loose_step.renderer.width > big_cfg.renderer.width  # the ladder still works when asked
    assert SizingRule().quality_margin_db > 0
    plain = CaptureFeatures(**{**f.to_dict(), "detail": 0.01})
    assert choose_from_features(plain, base, "cpu")[0].texture_size == 64  # plain clothing's own floor
    assert choose_from_features(plain, base, "cpu", SizingRule(channels_by_detail=(8, 16, 16)))[0] \
        .texture_channels == 8
