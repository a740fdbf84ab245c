"""Training configuration and its named presets (tiny / cpu / gpu), all in one place.

The resolved config is saved as ``runs/<name>/config.json`` and read back on resume.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

from morf.avatar.network_configs import RendererConfig, WarpConfig
from morf.config_checks import apply_settings, check_field_kinds, check_keys, raise_first
from morf.errors import InputError
from morf.train.holdout import HOLDOUT_RULES

METHODS = ("morf", "stylepeople", "anr", "rgb")


LOSS_BACKGROUNDS = ("black", "random")


@dataclass(frozen=True)
class TrainConfig:
    """Everything that defines a training run."""

    method: str = "morf"  # morf (warping) | stylepeople (no warping) | anr (split optimisation)
    preset: str = "cpu"  # the preset this config started from (informational)
    resolution: int = 256  # side of the square working image the capture is cropped + resized to
    crop: int = 0  # side of random training crops inside it (0: whole image)
    # A second copy of the frames at this side (0: none); every other step trains on crops of
    # ``crop or resolution`` pixels from it, so the renderer also sees the body at the scale it is
    # played at. Trained at 256 px only, the renderer punched holes into the mask at 2x (neck, waist).
    zoom_resolution: int = 0
    # Every this-many-th step (0: none) trains on crops of the zoomed frames centred on the head
    # (half the images) or a hand (morf/train/detail.py), so the parts people look at are seen at
    # the player's scale in a fixed share of the steps; needs ``zoom_resolution``.
    detail_every: int = 0
    # Channels 0-2 of the texture (``renderer.rgb_skip``) projected from the zoomed frames rather
    # than the training frames: at 256 px a face is about 30 px high and its colours in the atlas
    # are that blurred whatever the texture's size.
    colour_from_zoom: bool = False
    # Each pixel's weight in that projection is its surface's facing |cos| to this power (0: the
    # plain mean over every frame that sees a texel, which blends frames misaligned by the fit's
    # error into a ghosted face; morf.train.inpaint.project_rgb_texture).
    colour_facing_power: float = 0.0
    # Passes of flow alignment before that projection (0: none): each pass warps every frame onto
    # the current projection as seen from it (optical flow, clamped to the fit's error) and
    # projects again, so frames the fit misaligns by a few pixels stop blurring each other's
    # detail (morf.train.colour_align). Needs ``renderer.rgb_skip``; ignored without it. Two
    # passes in the ``detail`` preset and in ``morf demo``, none in ``cpu``: on the synthetic capture
    # they sharpened the head, hands and shirt print (HF ratio and shift-tolerant SSIM up) but cost
    # 0.45 dB person PSNR; on a real clip every score but the HF ratio held or rose (docs/avatar.md,
    # "Flow-aligned colour projection").
    colour_align_passes: int = 0
    # How that projection spreads a pixel over the texels and treats a texel few pixels saw
    # (morf.train.texel_splat): ``colour_bilinear`` shares each pixel among the four texels
    # around its UV instead of giving it to one, closing the pinholes a texture denser than the
    # frames leaves; ``colour_prior_count`` > 0 draws a texel's colour towards its neighbourhood's
    # as if that many pixels of it had been seen, so a texel one pixel saw does not keep that
    # pixel's noise (the speckle on hair and faces at the player's size). Off: the plain mean.
    colour_bilinear: bool = False
    colour_prior_count: float = 0.0
    # Pixels of the projection's frames within this many pixels of the person mask's outline are
    # left out of it (0: none): they mix the person with the backdrop (morf.train.texel_splat).
    colour_edge_inset: int = 0
    # Passes of back-projection after that projection (morf.train.back_project): the frames'
    # residuals against the texture drawn back at their pixels, projected and added, which gives
    # back the detail the splat and the lookup blur away where the frames agree. -1: as many as the
    # capture supports (0 or 1), chosen on frames held aside from the projection; 0: none.
    colour_back_projections: int = 0
    # The image terms (L1, SSIM) leave out the pixels within this many pixels inside the person
    # mask's outline (0: none), where the frames mix the person with the backdrop; the mask terms
    # still see them (morf.train.objective.outline_weight).
    loss_edge_inset: int = 0
    # View-dependent colour (morf.avatar.view_colour): besides the one projected colour texture,
    # ``view_colours`` more (0: none), each projected from the ``view_colour_frames`` training frames
    # whose root orientation is nearest one of that many anchor orientations; the player draws
    # the blend of the anchors nearest each pose's own orientation. Needs colour channels
    # (renderer.rgb_skip).
    view_colours: int = 0
    view_colour_frames: int = 6
    # > 0: a view's colour only on texels its frames saw about as squarely as the best frames did
    # (within this much facing cos; morf.train.view_colours.project_view_colours), else the one texture's
    view_colour_margin: float = 0.0
    # The head's colour by the head's own orientation (morf.avatar.head_colour): ``head_view_colours``
    # more anchors (0: none) over the head bone's orientations, each projected from the
    # ``head_view_colour_frames`` training frames whose head was turned most like it, laid over the
    # view colours by each texel's head share. Needs ``view_colours``.
    head_view_colours: int = 0
    head_view_colour_frames: int = 4
    # back-projection passes of the head's colours: -1 chosen on the capture's heads
    # (morf.train.head_colours.choose_head_passes), 0 none, N that many
    head_view_colour_passes: int = -1
    batch_size: int = 4  # images per step
    steps: int = 3000  # optimisation steps of the main stage
    texture_channels: int = 16  # C of the neural texture
    texture_size: int = 256  # Ht = Wt of the neural texture
    texture_dilate: int = 4  # texels the spectral init is grown past the UV islands
    # Rasterize the body dressed by the fit's clothing offsets (morf.fitting.offsets), so loose
    # clothes the naked body lacks get texels; the export and morf eval then draw it dressed too.
    # false: the naked body, to compare. Fits without offsets (or the ground truth) are naked anyway.
    dressed: bool = True
    renderer: RendererConfig = field(default_factory=RendererConfig)  # U-Net size
    warp: WarpConfig = field(default_factory=WarpConfig)  # warp network sizes (method morf only)
    lr_texture: float = 2e-3  # small, so the spectral init is not washed out
    # With ``renderer.rgb_skip`` (ignored without it): texture channels 0-2 keep the projected frame colours they start
    # from (their gradient is zeroed); the renderer learns the mask, the fill and a residual. Trained,
    # Adam moved each colour texel by noise from misaligned frames: on the default capture's held-out
    # frames the trained colours scored 0.8 dB below the projected ones (docs/avatar.md).
    freeze_colour: bool = False
    # L1 on what the renderer adds over the texture's colour channels (``renderer.rgb_skip``), in
    # the units of ``w_l1``: the residual stays zero wherever the frames do not agree on a change
    # (at weight w, an L1-optimal residual moves only where more than (1 + w) / 2 of the frames
    # seeing a pixel agree on its sign), so it corrects consistent errors, not per-frame misfits.
    w_residual: float = 0.0
    lr_renderer: float = 1e-3  # Adam on the renderer
    lr_warp: float = 5e-4  # Adam on W, E, F (1e-4 left offsets at ~0.1 texel after 400 cpu steps)
    lr_latent: float = 1e-3  # Adam on the per-frame latents
    lr_discriminator: float = 4e-4  # Adam on the discriminator
    # Learning-rate decay: from this fraction of ``steps`` on, every learning rate (discriminator
    # included) follows a half cosine down to ``lr_decay_floor`` of its value at the last step
    # (1.0: constant rates to the end).
    lr_decay_start: float = 1.0
    lr_decay_floor: float = 0.1
    # Weight averaging: the avatar written at the end (baked texture, renderer) is made from an
    # exponential moving average of the avatar's weights with this decay per step (warm-up:
    # min(decay, (1 + step) / (10 + step))) instead of the last step's weights (0.0: off).
    ema_decay: float = 0.0
    # Warp fade (method morf): from ``warp_fade_start`` of the steps on, the warp's offsets are scaled
    # down linearly to zero at ``warp_fade_end``; after it the texture and renderer train on the
    # unwarped lookups the player uses, and the bake is skipped (nothing left to bake). 1.0 / 1.0:
    # the warp to the end and the paper's bake at the neutral pose.
    warp_fade_start: float = 1.0
    warp_fade_end: float = 1.0
    w_l1: float = 1.0  # L1 on premultiplied RGB
    w_perceptual: float = 1.0  # VGG-16 perceptual loss (when weights are available)
    w_feature_matching: float = 1.0  # discriminator feature matching (used when VGG weights are absent)
    w_ssim: float = 0.0  # 1 - SSIM around the person (structure without a pretrained network)
    # What the image terms (L1, SSIM, perceptual) compare: "black", the render and the frame
    # premultiplied by their masks (on black); "random", both composited over one random colour per
    # image, as the player composites over a backdrop. On black an edge pixel that is the person in
    # some frames and the backdrop in others has an L1-best colour darker than the person while the
    # Dice term holds its mask near 1: dark bands beside the body (docs/avatar.md).
    loss_background: str = "black"
    w_gan: float = 0.02  # non-saturating GAN loss
    w_dice: float = 1.0  # Dice on the mask
    # Binary cross-entropy on the mask's logits. Dice and the premultiplied image terms reach the
    # logit through the sigmoid, whose gradient vanishes once the logit is far below zero: a mask
    # pushed there everywhere (a wide renderer's large first steps, adversarial terms) never came
    # back (docs/benchmarks.md: stem x4 base 32 and 48). This term's gradient on a person pixel is
    # sigmoid(logit) - 1, about -1 there, so a dead mask is pulled back whatever its depth.
    w_mask_bce: float = 0.0
    w_tv_rgb: float = 0.01  # low-weight TV on the image
    w_warp_l2: float = 1.0  # offsets -> 0 (offsets in texture grid units)
    w_warp_tv: float = 1.0  # TV on the offset field (L1; at 10 it pinned local offsets to zero)
    gan_start: int = 0  # step from which the adversarial terms are on
    disc_width: int = 32  # first-layer channels of each PatchGAN
    disc_scales: int = 2  # number of PatchGAN scales
    disc_layers: int = 3  # strided layers per PatchGAN
    inpaint_steps: int = 200  # fine-tuning steps on unseen texels after training (0: off)
    inpaint_views: int = 16  # pseudo ground-truth renders in extreme poses / views
    inpaint_lr: float = 5e-3  # Adam on the unseen texels of the baked texture
    anr_texture_every: int = 2  # anr: steps alternate; every this-many-th step updates the texture only
    checkpoint_minutes: float = 5.0  # checkpoint period (and always at the end / on stop)
    # on NaN or a collapsed mask (health.py): roll back to the last checkpoint with the learning
    # rates halved, at most this many times, then stop with TrainingDiverged
    max_recoveries: int = 2
    report_every: int = 10  # steps between Progress reports (and preview images)
    log_every: int = 10  # steps between metrics.jsonl lines
    channels_last: bool = False  # renderer + discriminator in channels-last memory format (CPU speed)
    bf16: bool = False  # bfloat16 autocast for renderer + discriminator (weights and losses stay float32)
    # Hold-out: the usable frames numbered 0, K, 2K, ... (K = ``holdout``) are kept out of training
    # for ``morf eval`` (0: none); ``holdout_by`` "position" is the older rule, every K-th usable
    # frame (runs whose config.json has no holdout_by), see morf.train.data.split_holdout
    holdout: int = 0
    holdout_by: str = "frame"
    seed: int = 0  # RNG seed (frame order, crops, init)
    device: str = "auto"  # auto: CUDA when present, else CPU

    # ---- (de)serialisation ----------------------------------------------------------------
    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @staticmethod
    def from_dict(d: dict) -> "TrainConfig":
        d = check_keys(TrainConfig, dict(d), "training config")
        if "holdout_by" not in d and "holdout" in d and "device" in d and "seed" in d:
            d["holdout_by"] = "position"  # a whole config written before the frame rule (a run's config.json)
        if isinstance(d.get("renderer"), dict):
            d["renderer"] = RendererConfig(**check_keys(RendererConfig, d["renderer"], "renderer config"))
        if isinstance(d.get("warp"), dict):
            d["warp"] = WarpConfig(**check_keys(WarpConfig, d["warp"], "warp config"))
        cfg = TrainConfig(**d)
        cfg.validate()
        return cfg

    def with_settings(self, settings: list[str] | tuple[str, ...]) -> "TrainConfig":
        """This config with ``FIELD=VALUE`` settings applied (``renderer.width=24``: a nested field).

        VALUE is read as JSON when it parses (numbers, true/false, lists), else as a string; an
        unknown field is an InputError naming the known ones (:func:`morf.config_checks.apply_settings`).
        """
        d = apply_settings(self.to_dict(), settings)
        return TrainConfig.from_dict(d)

    def replace(self, **changes) -> "TrainConfig":
        """A copy with ``changes``; a method without a warp (anything but morf) gets the neutral
        warp fade (1.0, 1.0) unless the same call sets it, so a config reads the same whichever
        way it was made (the preset function, the registry and ``replace(method=...)``)."""
        check_keys(TrainConfig, changes, "training config")
        if changes.get("method", self.method) != "morf":
            changes = {"warp_fade_start": 1.0, "warp_fade_end": 1.0, **changes}
        cfg = dataclasses.replace(self, **changes)
        cfg.validate()
        return cfg

    def validate(self) -> None:
        """Raise one InputError naming the first setting that makes no sense: a value of the wrong
        kind (a config file may hold anything), a count, size or rate out of its range. Checked
        wherever a config is made (presets with overrides, ``--set``, config files, run configs read
        back on resume), so a run that would train nothing (``steps`` 0) or divide by zero never starts."""
        check_field_kinds(self, "training config")
        check_field_kinds(self.renderer, "training config", "renderer.")
        check_field_kinds(self.warp, "training config", "warp.")
        raise_first(self._range_checks())
        if self.method not in METHODS:
            raise InputError(f"unknown method {self.method!r}; choose one of {', '.join(METHODS)}")
        if self.loss_background not in LOSS_BACKGROUNDS:
            raise InputError(f"unknown loss_background {self.loss_background!r}; choose one of "
                             f"{', '.join(LOSS_BACKGROUNDS)}")
        m = self.renderer.multiple
        side = self.crop or self.resolution
        if side % m or self.resolution % m:
            raise InputError(f"resolution {self.resolution} and crop {self.crop} must be multiples of {m} for this renderer")
        if self.zoom_resolution and (self.zoom_resolution <= self.resolution or self.zoom_resolution % m):
            raise InputError(f"zoom resolution {self.zoom_resolution} must exceed resolution {self.resolution} "
                             f"and be a multiple of {m}")
        if (self.detail_every or self.colour_from_zoom) and not self.zoom_resolution:
            raise InputError("detail_every and colour_from_zoom need zoom_resolution (the frames they crop or "
                             "project); set zoom_resolution to a side above resolution")
        if self.crop > self.resolution:
            raise InputError("crop must not exceed resolution")
        if self.renderer.in_channels != self.texture_channels:
            raise InputError("renderer input channels must equal texture channels")
        if not (0.0 <= self.lr_decay_start <= 1.0 and 0.0 < self.lr_decay_floor <= 1.0):
            raise InputError("lr_decay_start must lie in [0, 1] and lr_decay_floor in (0, 1]")
        if self.holdout < 0 or self.holdout == 1:
            raise InputError(f"holdout must be 0 (none) or at least 2 (every K-th frame), got {self.holdout}")
        if self.holdout_by not in HOLDOUT_RULES:
            raise InputError(f"unknown holdout_by {self.holdout_by!r}; choose one of {', '.join(HOLDOUT_RULES)}")
        if not 0.0 <= self.ema_decay < 1.0:
            raise InputError(f"ema_decay must lie in [0, 1), got {self.ema_decay}")
        if not 0.0 <= self.warp_fade_start <= self.warp_fade_end <= 1.0:
            raise InputError("warp_fade_start and warp_fade_end must satisfy 0 <= start <= end <= 1, got "
                             f"{self.warp_fade_start} and {self.warp_fade_end}")

    def _range_checks(self) -> list[tuple[bool, str]]:
        """(ok, message) for every number with a range, in field order."""
        r, w = self.renderer, self.warp
        min_steps = 0 if self.method == "rgb" else 1  # the RGB floor records 0: it has nothing to train
        checks = [
            (self.resolution >= 1, f"resolution must be a positive number of pixels, got {self.resolution}"),
            (self.crop >= 0, f"crop must be 0 (whole image) or a positive number of pixels, got {self.crop}"),
            (self.zoom_resolution >= 0, f"zoom_resolution must be 0 (none) or a positive number of pixels, got "
                                        f"{self.zoom_resolution}"),
            (self.colour_facing_power >= 0, f"colour_facing_power must be >= 0, got {self.colour_facing_power}"),
            (self.colour_edge_inset >= 0, f"colour_edge_inset must be >= 0, got {self.colour_edge_inset}"),
            (self.colour_back_projections >= -1, f"colour_back_projections must be -1 (chosen on the capture), 0 "
                                                 f"(none) or a number of passes, got {self.colour_back_projections}"),
            (self.loss_edge_inset >= 0, f"loss_edge_inset must be >= 0, got {self.loss_edge_inset}"),
            (self.view_colours >= 0, f"view_colours must be >= 0 (0: none), got {self.view_colours}"),
            (self.view_colour_frames >= 1, f"view_colour_frames must be >= 1, got {self.view_colour_frames}"),
            (0.0 <= self.view_colour_margin <= 1.0, f"view_colour_margin must lie in [0, 1], got {self.view_colour_margin}"),
            (self.head_view_colours >= 0, f"head_view_colours must be >= 0 (0: none), got {self.head_view_colours}"),
            (self.head_view_colour_frames >= 1,
             f"head_view_colour_frames must be >= 1, got {self.head_view_colour_frames}"),
            (self.head_view_colour_passes >= -1, f"head_view_colour_passes must be -1 (chosen on the capture), 0 "
                                                  f"(none) or a number of passes, got {self.head_view_colour_passes}"),
            (not self.head_view_colours or self.view_colours > 0,
             "head_view_colours needs view_colours > 0 (the head's colour is laid over the view colours)"),
            (self.colour_prior_count >= 0, f"colour_prior_count must be >= 0 pixels, got {self.colour_prior_count}"),
            (self.colour_align_passes >= 0, f"colour_align_passes must be 0 (plain projection) or a number of "
                                            f"alignment passes, got {self.colour_align_passes}"),
            (self.detail_every >= 0, f"detail_every must be 0 (none) or a number of steps, got {self.detail_every}"),
            (self.batch_size >= 1, f"batch size must be at least 1 image per step, got {self.batch_size}"),
            (self.steps >= min_steps, f"steps must be at least 1, got {self.steps}: a run without training steps "
                                      "has nothing to export; give --steps 1 or more"),
            (self.texture_channels >= 1, f"texture_channels must be at least 1, got {self.texture_channels}"),
            (self.texture_size >= 1, f"texture_size must be a positive number of texels, got {self.texture_size}"),
            (self.texture_dilate >= 0, f"texture_dilate must be >= 0 texels, got {self.texture_dilate}"),
            (r.width >= 1 and r.max_width >= 1 and r.skip_hidden >= 1,
             f"renderer widths must be at least 1 channel, got width {r.width}, max_width {r.max_width}, "
             f"skip_hidden {r.skip_hidden}"),
            (r.depth >= 0 and r.stem >= 1 and r.head_stride >= 1 and r.fill_levels >= 0,
             f"renderer depth and fill_levels must be >= 0, stem and head_stride >= 1; got depth {r.depth}, "
             f"fill_levels {r.fill_levels}, stem {r.stem}, head_stride {r.head_stride}"),
            (self.method != "morf" or min(w.pose_dim, w.latent_dim, w.style_dim, w.mlp_layers, w.base_resolution,
                                          w.width) >= 1 and min(w.fourier_freqs, w.levels) >= 0,
             "warp sizes must be at least 1 (fourier_freqs and levels at least 0), got "
             + ", ".join(f"{k} {v}" for k, v in dataclasses.asdict(w).items())),
        ]
        for name in ("lr_texture", "lr_renderer", "lr_warp", "lr_latent", "lr_discriminator", "inpaint_lr"):
            checks.append((getattr(self, name) >= 0, f"{name} must be >= 0 (a learning rate), got {getattr(self, name)}"))
        for name in ("w_residual", "w_mask_bce", "w_l1", "w_perceptual", "w_feature_matching", "w_ssim", "w_gan", "w_dice",
                     "w_tv_rgb", "w_warp_l2", "w_warp_tv"):
            checks.append((getattr(self, name) >= 0, f"{name} must be >= 0 (a loss weight), got {getattr(self, name)}"))
        checks += [
            (self.gan_start >= 0, f"gan_start must be >= 0, got {self.gan_start}"),
            (self.w_gan == 0 or min(self.disc_width, self.disc_scales, self.disc_layers) >= 1,
             f"discriminator sizes must be at least 1, got disc_width {self.disc_width}, disc_scales "
             f"{self.disc_scales}, disc_layers {self.disc_layers}"),
            (self.inpaint_steps >= 0, f"inpaint_steps must be >= 0 (0: no inpainting), got {self.inpaint_steps}"),
            (self.inpaint_views >= 1 or self.inpaint_steps == 0,
             f"inpaint_views must be at least 1 when inpainting, got {self.inpaint_views}"),
            (self.anr_texture_every >= 1, f"anr_texture_every must be at least 1, got {self.anr_texture_every}"),
            (self.checkpoint_minutes >= 0, f"checkpoint_minutes must be >= 0, got {self.checkpoint_minutes}"),
            (self.max_recoveries >= 0, f"max_recoveries must be >= 0, got {self.max_recoveries}"),
            (self.report_every >= 1, f"report_every must be at least 1 step, got {self.report_every}"),
            (self.log_every >= 1, f"log_every must be at least 1 step, got {self.log_every}"),
            (self.seed >= 0, f"seed must be >= 0, got {self.seed}"),
        ]
        return checks

    @property
    def colour_frozen(self) -> bool:
        """Whether texture channels 0-2 stay the projected colours (``freeze_colour`` on a renderer
        with colour channels)."""
        return self.freeze_colour and self.renderer.rgb_skip

    @property
    def warp_faded(self) -> bool:
        """Whether the warp is faded out before the last step (then the bake is skipped)."""
        return self.warp_fade_end < 1.0

    def warp_scale(self, step: int) -> float:
        """The factor on the warp's offsets at ``step``: 1 before the fade, 0 after it."""
        start, end = self.warp_fade_start * self.steps, self.warp_fade_end * self.steps
        if step < start or self.warp_fade_start >= 1.0:
            return 1.0
        if step >= end:
            return 0.0
        return 1.0 - (step - start) / (end - start)

    def lr_factor(self, step: int) -> float:
        """The learning-rate multiplier of ``step`` under the decay schedule (1.0 before it starts)."""
        start = self.lr_decay_start * self.steps
        if step <= start or self.steps <= start:
            return 1.0
        t = min(1.0, (step - start) / (self.steps - start))
        return self.lr_decay_floor + (1.0 - self.lr_decay_floor) * 0.5 * (1.0 + math.cos(math.pi * t))


DETAIL_PRESET = "detail"  # the preset 'morf run' names when the cpu preset is chosen for a user (cli/run.py)
PRESETS: dict[str, TrainConfig] = {
    # CI: seconds on 2 cores. Tiny everything. A checkpoint every 0.6 s, so that a run killed during
    # its few seconds of training resumes part-way, as a long run does (morf bench resume).
    "tiny": TrainConfig(
        preset="tiny", resolution=64, batch_size=2, steps=30, texture_channels=8, texture_size=64,
        renderer=RendererConfig(in_channels=8, width=8, depth=2, stem=2, skip_hidden=8, rgb_skip=True),
        w_ssim=1.0, w_gan=0.0, freeze_colour=True,
        warp=WarpConfig(latent_dim=8, style_dim=16, mlp_layers=2, fourier_freqs=3, base_resolution=16, width=8, levels=2),
        disc_width=8, disc_scales=1, disc_layers=2, inpaint_steps=5, inpaint_views=2,
        checkpoint_minutes=0.01, report_every=5, log_every=5),
    # 6-7 minutes on 2 CPU cores with native bf16 at 256 px (0.25 s a step); 0.49M-parameter renderer.
    # The hold-out scores of the default capture were the same at 300 and 1200 steps (fit error,
    # not training, bounds them); 1500 leaves the image time to sharpen.
    "cpu": TrainConfig(
        preset="cpu", resolution=256, zoom_resolution=512, batch_size=4, steps=1500, texture_channels=16, texture_size=256,
        # stem x4 (base 24 first, now 16): with the colour skip the full-resolution detail comes from the
        # texture, and on the default capture's hold-out it scored the same as stem x2 base 16 (20.96 against
        # 20.93 dB person PSNR, seed 0) while it trains 2x and plays 1.6x faster (docs/avatar.md).
        # Its head runs at half resolution (head_stride 2): 10 ms less a 640x640 int8 frame, and on
        # the same hold-out 21.25 against 20.96 dB at 256 px, 20.10 against 20.06 at 512 (seed 0).
        # Base width 16 then scored the same as 24 (21.35 against 21.25 dB, seed 0), plays faster and
        # its int8 outline holds (docs/avatar.md, "Base width 16").
        renderer=RendererConfig(in_channels=16, width=16, depth=4, max_width=64, stem=4, skip_hidden=16, rgb_skip=True,
                                head_stride=2),
        # L1 + SSIM, no adversarial terms: without VGG weights the discriminator's feature matching
        # stood in for the perceptual loss, outweighed the L1 six to one and pulled the colours
        # (person PSNR 10.4 dB after 300 steps, mean error +0.34 green); without it 17.9 dB
        # (docs/avatar.md, "Why the avatar had the wrong colours").
        # The residual penalty, the late cosine decay and the weight average: +0.35 dB person PSNR on
        # the default capture's hold-out, the fingertip fill speck gone (docs/avatar.md).
        w_ssim=1.0, w_gan=0.0, freeze_colour=True, w_residual=0.5, lr_decay_start=0.5, ema_decay=0.998,
        # L1 and SSIM over a random backdrop colour, not on black: +0.17 dB person PSNR on the
        # default capture's held-out frames at 256 px, +0.26 at 512 (seed 0; docs/avatar.md).
        loss_background="random",
        # The warp absorbs misalignment while the texture forms, then fades out, so the last 40 % of
        # the steps train what the player renders (no bake): +0.3 dB on the same hold-out.
        warp_fade_start=0.3, warp_fade_end=0.6,
        # The colour projected with each pixel shared among four texels and texels few pixels saw
        # drawn towards their neighbourhood: on the tennis clip the speckle on the hair is gone and
        # the head's shift-tolerant SSIM rose 0.670 -> 0.698 on both seeds (person SSIM +0.02); on
        # the default capture every score held (docs/avatar.md, "Colour without the speckle").
        colour_bilinear=True, colour_prior_count=4.0,
        # The colour projected from the 512 px frames the zoomed steps crop, not the 256 px ones: the
        # head's shift-tolerant SSIM +0.005-0.007 on the tennis, outdoor and People-Snapshot clips,
        # the whole person's scores held (docs/avatar.md, "The head frame by frame").
        colour_from_zoom=True,
        # The colour by view: 16 more colour textures, each from the 12 training frames that saw the
        # body from about one direction, blended by the pose's own orientation. People-Snapshot's
        # hold-out: head SSIM+-shift 0.855 -> 0.888, person PSNR +1.3 dB, flicker -12 %; the tennis
        # clip's: head 0.689 -> 0.710, +0.5 dB; the outdoor walk's: head +0.004, person SSIM -0.004;
        # the flicker that forgives misregistration +1 to +7 % (docs/avatar.md, "Colour by view").
        view_colours=16, view_colour_frames=12,
        # The head's colour by the head's own orientation: 32 anchors, 4 frames each, laid over the
        # view colours down to the neck, back-projected where the capture's heads support it. The
        # tennis clip's player turns his head on his own: head SSIM+-shift 0.716 -> 0.727 (seed 1
        # 0.711 -> 0.722), its HF ratio inside 0.521 -> 0.820 (0.532 -> 0.832); People-Snapshot
        # 0.900 -> 0.907, 0.560 -> 0.612; outdoor -0.001 and +0.054; person PSNR +0.01 to +0.05 dB
        # (docs/avatar.md, "The head's colour by the head's own orientation").
        head_view_colours=32, head_view_colour_frames=4, head_view_colour_passes=-1,
        # A back-projection pass where the capture's own frames support it (chosen on frames held
        # aside): People-Snapshot took it, head SSIM+-shift +0.001-0.002 and its HF ratio inside
        # 0.43 -> 0.51-0.52 on two seeds, hands +0.002-0.004, person PSNR -0.03/+0.04 dB, the flicker
        # that forgives misregistration +1-3 %; the demo's capture took it, head 0.846 -> 0.854 with
        # eyes and mouth back, person PSNR -0.11 dB, that flicker +9 %; the tennis and outdoor clips
        # did not, where a pass costs head SSIM (docs/avatar.md, "The face's finest detail").
        colour_back_projections=-1,
        warp=WarpConfig(latent_dim=16, style_dim=64, mlp_layers=3, fourier_freqs=5, base_resolution=32, width=16, levels=3),
        disc_width=16, disc_scales=1, disc_layers=3, inpaint_steps=200, inpaint_views=16,
        channels_last=True, bf16=True),
    # Paper sizes: 640 px, 1024^2 texture, ~14M-parameter U-Net; meant for a GPU.
    "gpu": TrainConfig(
        preset="gpu", resolution=640, crop=512, batch_size=8, steps=100000, texture_channels=16, texture_size=1024,
        renderer=RendererConfig(in_channels=16, width=48, depth=5, max_width=352, stem=1, rgb_skip=True),
        w_ssim=1.0, w_feature_matching=0.0, gan_start=50000,
        warp=WarpConfig(latent_dim=32, style_dim=128, mlp_layers=4, fourier_freqs=8, base_resolution=128, width=32, levels=4),
        disc_width=64, disc_scales=3, disc_layers=3, inpaint_steps=2000, inpaint_views=64,
        checkpoint_minutes=10.0, report_every=50, log_every=50),
}


# Detail where people look, in at most half an hour on 2 CPU cores (2500 steps: about 0.6 s a step
# in float32 on a 2-core Xeon without AVX512-BF16, 0.25-0.31 s with it): the cpu preset's renderer and
# losses, with the face and hands at the density the player draws them. Crops of the frames at
# 640 px (the player's side) every other step, every fourth step centred on the head or a hand;
# a 512^2 texture whose colour channels are projected from those 640 px frames, each pixel weighted
# by its facing to the 8th power (at 256^2 the face had about 60 texels of height, at 512^2 about
# 120: the player draws it about 75 px high); the logit-space mask term. On the default capture
# at 600 steps: +0.40 dB person PSNR over the cpu preset's 1000, the head's detail scores the same
# (docs/avatar.md, "Faces and hands at the player's density").
#
# The colour is projected from frames first aligned to one another by optical flow (two passes,
# morf/train/colour_align.py): on the synthetic capture the shirt's checks come out square and its
# print legible, head HF ratio 0.572 -> 0.698 and shift-tolerant SSIM up in every region, at
# -0.45 dB of plain person PSNR (sharp colour a few pixels off costs PSNR more than blur); on the
# real outdoor clip every whole-person score holds or rises (docs/avatar.md, "Flow-aligned colour
# projection").
PRESETS[DETAIL_PRESET] = PRESETS["cpu"].replace(
    preset=DETAIL_PRESET, zoom_resolution=640, texture_size=512, colour_from_zoom=True, detail_every=4, steps=2500,
    colour_facing_power=8.0, w_mask_bce=0.1, colour_align_passes=2)


def preset(name: str, method: str = "morf", **overrides) -> TrainConfig:
    """A named preset for ``method`` with field overrides applied."""
    if name not in PRESETS:
        raise InputError(f"unknown preset {name!r}; choose one of {', '.join(PRESETS)}")
    return PRESETS[name].replace(method=method, **overrides)  # no warp to fade for other methods: see replace
