"""The neural avatar: neural texture, texture-space warp field, U-Net renderer, losses, metrics.

Data conventions shared by every file here:

* A neural texture is ``(C, Ht, Wt)`` (or ``(B, C, Ht, Wt)``); texel row 0 is the TOP of the UV
  atlas, i.e. ``v = 1``: mesh UVs are v-up, so texel row = ``(1 - v) * Ht``.
* A UV map (rasterization) is ``(B, H, W, 2)`` in the same mesh-UV convention plus a ``(B, H, W)``
  coverage mask; :func:`morf.avatar.texture.sample_texture` turns both into ``(B, C, H, W)``.
* The renderer outputs ``(B, 4, H, W)``: linear RGB (trained towards [0, 1], clamp for display)
  premultiplied by the person's mask (black background), then one mask logit.
"""
