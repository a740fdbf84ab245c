"""A pose prior built from joint limits (no learned prior: none can be downloaded here).

Anny's "local-ref" rotations are expressed in world-aligned axes of the rest pose (X = the
person's left, Y = backwards, Z = up), so each fitted bone gets a box of allowed angles per
axis, in degrees, around the rest A-pose. Hinge joints get more: the elbow and the knee may
only bend about their hinge axis, within their range, and pay for any other rotation.
The elbow's hinge axis is taken from the rest skeleton (the rest pose bends the elbow by about
42 degrees, so the axis is the normal of the upper-arm / forearm plane).

The limits are hand-set from textbook ranges of motion, widened where Anny's helper bones
share the motion (three spine bones share the trunk's range). The energy is a squared hinge
outside each box, zero inside, so it never biases a plausible pose.
"""

from __future__ import annotations

import torch

from morf.fitting.params import FIT_BONES

# (lo, hi) degrees about world X, Y, Z of the rest pose, per fitted bone. Left side; the right
# side mirrors Y and Z.
_LIMITS_LEFT_DEG = {
    "spine03": ((-20, 35), (-20, 20), (-25, 25)),
    "spine02": ((-20, 35), (-20, 20), (-25, 25)),
    "spine01": ((-20, 35), (-20, 20), (-25, 25)),
    "neck01": ((-40, 45), (-35, 35), (-50, 50)),
    "head": ((-40, 40), (-30, 30), (-45, 45)),
    "clavicle.L": ((-20, 20), (-25, 15), (-20, 25)),
    "upperarm01.L": ((-120, 120), (-110, 60), (-110, 110)),
    "lowerarm01.L": ((-150, 150), (-150, 150), (-150, 150)),  # hinge term below does the work
    "wrist.L": ((-70, 70), (-60, 60), (-60, 60)),
    "upperleg01.L": ((-120, 35), (-30, 45), (-45, 45)),
    "lowerleg01.L": ((-5, 150), (-10, 10), (-15, 15)),  # knee flexion is +X
    "foot.L": ((-45, 35), (-20, 20), (-25, 25)),
}

# Elbows: bone -> (upper-arm bone, wrist bone, flexion range in degrees from the rest bend).
_HINGES = {
    "lowerarm01.L": ("upperarm01.L", "wrist.L", (-40.0, 105.0)),
    "lowerarm01.R": ("upperarm01.R", "wrist.R", (-40.0, 105.0)),
}


def _limits_for(name: str) -> tuple[tuple[float, float], ...]:
    if name.endswith(".R"):
        lx, ly, lz = _LIMITS_LEFT_DEG[name[:-2] + ".L"]
        return lx, (-ly[1], -ly[0]), (-lz[1], -lz[0])
    return _LIMITS_LEFT_DEG[name]


class JointLimitPrior(torch.nn.Module):
    """Energy of body rotations (N, len(FIT_BONES), 3) against joint limits."""

    def __init__(self, model, bones: tuple[str, ...] = FIT_BONES):
        super().__init__()
        lo = torch.tensor([[a[0] for a in _limits_for(b)] for b in bones], dtype=torch.float32)
        hi = torch.tensor([[a[1] for a in _limits_for(b)] for b in bones], dtype=torch.float32)
        self.register_buffer("lo", torch.deg2rad(lo), persistent=False)
        self.register_buffer("hi", torch.deg2rad(hi), persistent=False)
        with torch.no_grad():
            joints = model(model.zero_pose(1), model.default_shape()).joints[0].cpu()
        hinge_rows, axes, ranges = [], [], []
        for name, (parent, child, rng) in _HINGES.items():
            if name not in bones:
                continue
            j, p, c = (model.bone_index(n) for n in (name, parent, child))
            upper, fore = joints[j] - joints[p], joints[c] - joints[j]
            axis = torch.linalg.cross(upper, fore)
            hinge_rows.append(bones.index(name))
            axes.append(axis / axis.norm())
            ranges.append(rng)
        # knees: hinge about world X (flexion is +X: the ankle moves backwards)
        for name in ("lowerleg01.L", "lowerleg01.R"):
            if name in bones:
                hinge_rows.append(bones.index(name))
                axes.append(torch.tensor([1.0, 0.0, 0.0]))
                ranges.append((-5.0, 150.0))
        self.register_buffer("hinge_rows", torch.tensor(hinge_rows, dtype=torch.long), persistent=False)
        self.register_buffer("hinge_axes", torch.stack(axes) if axes else torch.zeros(0, 3), persistent=False)
        self.register_buffer("hinge_range", torch.deg2rad(torch.tensor(ranges, dtype=torch.float32)).reshape(-1, 2),
                             persistent=False)

    def excess_deg(self, body: torch.Tensor) -> torch.Tensor:
        """(N, B) how far each bone's rotation lies outside its limits, degrees (0 within them): the
        largest excess over the box's axes and, for hinge joints, over the flexion range. What the
        frame filter judges; the energy below is what the fit minimises."""
        lo, hi = self.lo.to(body.dtype), self.hi.to(body.dtype)
        out = torch.maximum(torch.relu(lo - body), torch.relu(body - hi)).amax(-1)
        if self.hinge_rows.numel() > 0:
            flex = (body[:, self.hinge_rows] * self.hinge_axes.to(body.dtype)).sum(-1)
            rng = self.hinge_range.to(body.dtype)
            hinge = torch.maximum(torch.relu(rng[:, 0] - flex), torch.relu(flex - rng[:, 1]))
            out = out.clone()
            out[:, self.hinge_rows] = torch.maximum(out[:, self.hinge_rows], hinge)
        return torch.rad2deg(out)

    def forward(self, body: torch.Tensor) -> torch.Tensor:
        """(N, B, 3) body rotvecs -> (N,) energy (radians squared)."""
        lo, hi = self.lo.to(body.dtype), self.hi.to(body.dtype)
        box = (torch.relu(lo - body) ** 2 + torch.relu(body - hi) ** 2).sum((1, 2))
        if self.hinge_rows.numel() == 0:
            return box
        h = body[:, self.hinge_rows]  # (N, H, 3)
        axes = self.hinge_axes.to(body.dtype)
        flex = (h * axes).sum(-1)
        off = h - flex[..., None] * axes
        rng = self.hinge_range.to(body.dtype)
        hinge = torch.relu(rng[:, 0] - flex) ** 2 + torch.relu(flex - rng[:, 1]) ** 2
        return box + (hinge + 4.0 * (off ** 2).sum(-1)).sum(-1)

