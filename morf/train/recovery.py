"""What a training run does when it goes unhealthy: roll back, restart, or give up.

The training loop reports each failure (NaN/inf, a collapsed mask, a mask that never formed:
``health.py``) to a :class:`RecoveryPolicy` and carries out the :class:`Recovery` it answers.
The policy holds what that answer depends on: the rollback targets (in-memory snapshots of
healthy states, the checkpoint on disk, the initial state), the number of recoveries so far and
the limit on them. It loads, saves and logs nothing itself, so its decisions can be checked
without training.

The rules:

* A mask that never formed has no earlier state worth returning to: the run restarts once from
  its initial state (with the adversarial terms held until the mask forms; the loop does that)
  and the learning rates are kept.
* Any other failure rolls back, at most ``max_recoveries`` times, to the newer of the older of
  the two latest snapshots and the checkpoint (the older snapshot, so that a collapse that began
  before the monitor saw it is not restored), or to the initial state when there is neither.
  The learning rates end up halved once per recovery counted since the target was taken (a
  target taken after two recoveries already has its rates halved twice).
* Without a target, or with the recoveries spent, the run gives up.

The count of recoveries lives in memory only: a resumed run starts again from zero, its
checkpoint counting as taken before any recovery (the halved rates themselves are in the
checkpoint's optimizer state).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

Action = Literal["restart", "rollback", "give_up"]


@dataclass(frozen=True)
class Recovery:
    """The policy's answer to one failure.

    Fields:
        action: "restart" (load ``state``, hold the adversarial terms, start a new health monitor,
            write a checkpoint), "rollback" (load ``state``, or the checkpoint when it is None, scale
            the learning rates by ``lr_factor``, reset the health monitor) or "give_up" (raise
            ``TrainingDiverged`` with ``note``).
        state: the in-memory training state to load; None for the checkpoint on disk (or when
            giving up).
        step: the step of the state returned to (None when giving up).
        lr_factor: what the learning rates are multiplied by (1.0 unless rolling back).
        note: the log line once done; when giving up, the error message.
    """

    action: Action
    state: dict | None
    step: int | None
    lr_factor: float
    note: str


@dataclass(frozen=True)
class _Target:
    """A state to roll back to: its step, its training state (None: the checkpoint on disk), and
    the recoveries counted when it was taken."""

    step: int
    state: dict | None
    recoveries: int


class RecoveryPolicy:
    """Retry and rollback state of one training session.

    Args:
        max_recoveries: rollbacks allowed before giving up (``TrainConfig.max_recoveries``).
        snapshot_every: steps between in-memory snapshots of a healthy state.
        checkpoint_step: the step of the checkpoint on disk when the session starts, or None.
        checkpoint_path: where the checkpoint is; named in the message when giving up.
        initial: the training state at step 0 (a copy), or None when the session did not start
            there or has already restarted (then a mask that never formed is a plain failure).
    """

    def __init__(self, max_recoveries: int, snapshot_every: int, checkpoint_step: int | None,
                 checkpoint_path: str | Path, initial: dict | None = None):
        self.max_recoveries = max_recoveries
        self.snapshot_every = snapshot_every
        self.checkpoint_path = Path(checkpoint_path)
        self.recoveries = 0
        self.initial = initial
        # Checkpoints are minutes apart (and short runs never write one before the end), so healthy
        # states are also kept in memory; a rollback takes the older of the two latest.
        self._snapshots: deque[_Target] = deque(maxlen=2)
        self._checkpoint = _Target(checkpoint_step, None, 0) if checkpoint_step is not None else None

    @property
    def has_checkpoint(self) -> bool:
        """Whether a checkpoint of this run is on disk."""
        return self._checkpoint is not None

    # ---- healthy steps --------------------------------------------------------------------
    def wants_snapshot(self, step: int, healthy: bool) -> bool:
        """Whether the state after ``step`` should be handed to :meth:`keep_snapshot`."""
        return step % self.snapshot_every == 0 and healthy

    def keep_snapshot(self, step: int, state: dict) -> None:
        """Keep ``state`` (a copy the caller no longer changes) as a rollback target."""
        self._snapshots.append(_Target(step, state, self.recoveries))

    def checkpoint_saved(self, step: int) -> None:
        """The checkpoint on disk now holds ``step``."""
        self._checkpoint = _Target(step, None, self.recoveries)

    # ---- failures -------------------------------------------------------------------------
    def decide(self, reason: str, kind: str | None = None) -> Recovery:
        """The answer to a failure: ``reason`` is its message, ``kind`` the health monitor's
        (``CollapseMonitor.kind``: "collapsed", "never_formed", or None for NaN/inf)."""
        if kind == "never_formed" and self.initial is not None:
            state, self.initial = self.initial, None
            self._snapshots.clear()
            return Recovery("restart", state, 0, 1.0,
                            "restarted from step 0 with the adversarial terms off until the mask forms")
        target = self._target()
        if self.recoveries >= self.max_recoveries or target is None:
            kept = f"; the last good checkpoint ({self.checkpoint_path}) is kept" if self.has_checkpoint else ""
            return Recovery("give_up", None, None, 1.0, f"{reason}{kept}")
        self.recoveries += 1
        self._snapshots.clear()
        where = "checkpoint" if target.state is None else "in-memory state"
        return Recovery("rollback", target.state, target.step, 0.5 ** (self.recoveries - target.recoveries),
                        f"rolled back to the {where} of step {target.step} with the learning rates halved "
                        f"(recovery {self.recoveries} of {self.max_recoveries})")

    def _target(self) -> _Target | None:
        """The state a rollback returns to: the older kept snapshot (the initial state when there
        is neither snapshot nor checkpoint) unless the checkpoint is newer; None when there is none."""
        snap = self._snapshots[0] if self._snapshots else None
        if snap is None and self._checkpoint is None and self.initial is not None:
            snap = _Target(0, self.initial, 0)  # failed before the first snapshot: start again from step 0
        if snap is not None and (self._checkpoint is None or snap.step >= self._checkpoint.step):
            return snap
        return self._checkpoint
