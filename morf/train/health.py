"""Catch a training run that collapsed without any NaN: the renderer's mask died.

A GAN can win against the renderer in a few dozen steps: the discriminator's loss falls to ~0,
the renderer's mask logit goes to minus infinity everywhere and it renders the background only
(Dice ~1, image TV 0), after which nothing recovers. Seen once in a 3000-step cpu-preset run
(stylepeople, step ~2380, after its Dice had been below 0.01 for a thousand steps).

:class:`CollapseMonitor` follows a smoothed Dice loss and reports a collapse when it climbs back
above ``collapsed`` after it had once been below ``learned``, or when the mask never formed (the
same failure before the mask was ever learned: seen in a 3000-step cpu-preset run with a 128^2
texture, Dice 1.0 from step 160 to the end, and in one 400-step stability run). ``healthy`` says whether the
current state may be saved as a checkpoint (it is not while the Dice is far above its best).

Why a mask never forms: the renderer's mask starts flat (p = 0.12 everywhere) and forms in a jump
around step 20; with the discriminator's feature matching and GAN terms on from step 0, that jump
can overshoot to a mask logit far below zero everywhere, where the sigmoid's gradient vanishes
and neither Dice nor anything else brings it back (same run, same data up to step 17, 128^2
texture dies at step 21, 256^2 forms). Rolling back does not help (there is no earlier state with
a mask); the training loop restarts from step 0 with the adversarial terms held off until the
mask has formed (``formed``), which in that run formed the mask by step 47 (Dice 0.02 at step 190).
"""

from __future__ import annotations

import math


class CollapseMonitor:
    """Args:
        decay: weight of the running mean per step (0.9: about ten steps).
        learned: the mask counts as learned once the running Dice was below this.
        collapsed: a learned mask whose running Dice is above this has collapsed.
        never_formed, grace: a mask never learned whose running Dice is still above ``never_formed``
            after ``grace`` steps never formed (the renderer draws only background). Healthy runs
            measured here stayed below 0.6 after step 200 (80+ runs of all presets and methods);
            the two that failed this way sat at 0.998-1.0 from step ~160 to the end.
    """

    def __init__(self, decay: float = 0.9, learned: float = 0.3, collapsed: float = 0.8,
                 never_formed: float = 0.95, grace: int = 200):
        self.decay, self.learned, self.collapsed = decay, learned, collapsed
        self.never_formed, self.grace = never_formed, grace
        self.mean: float | None = None
        self.best = math.inf
        self.steps = 0
        self.kind: str | None = None  # of the last reported failure: "collapsed" | "never_formed"

    @property
    def formed(self) -> bool:
        """Whether the mask has been learned (the running Dice was once below ``learned``)."""
        return self.best < self.learned

    def update(self, losses: dict[str, float]) -> str | None:
        """Feed one step's losses; returns a reason when the run has collapsed, else None."""
        dice = losses.get("dice")
        if dice is None or not math.isfinite(dice):
            return None
        self.mean = dice if self.mean is None else self.decay * self.mean + (1 - self.decay) * dice
        self.best = min(self.best, self.mean)
        self.steps += 1
        if self.best < self.learned and self.mean > self.collapsed:
            self.kind = "collapsed"
            return (f"the mask collapsed (Dice {self.mean:.3f}, was {self.best:.3f}): the renderer now draws "
                    "no person")
        if self.best >= self.learned and self.steps >= self.grace and self.mean > self.never_formed:
            self.kind = "never_formed"
            return (f"the mask never formed (Dice {self.mean:.3f} after {self.steps} steps): the renderer "
                    "draws no person")
        return None

    @property
    def healthy(self) -> bool:
        """False while the running Dice is far above the best it reached (a collapse may be starting),
        or while there is no mask at all (a state not worth returning to)."""
        if self.mean is None:
            return True
        if self.best >= self.learned:
            return self.mean <= self.never_formed
        return self.mean <= 2.0 * self.best + 0.05

    def reset(self) -> None:
        """After rolling back to a checkpoint: start the running mean (and the grace period) again;
        the best is kept, the last failure's kind is cleared."""
        self.mean = None
        self.steps = 0
        self.kind = None
