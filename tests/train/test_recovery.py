"""The recovery policy alone: failures in, decisions out (no training)."""

import dataclasses

import pytest

from morf.train.recovery import Recovery, RecoveryPolicy

CKPT = "/runs/a/checkpoint.pt"
NAN = "training diverged at step 7: loss l1 is not finite"


def _policy(max_recoveries=2, snapshot_every=2, checkpoint_step=None, initial=None):
    return RecoveryPolicy(max_recoveries, snapshot_every, checkpoint_step, CKPT, initial)


def _state(step):
    return {"step": step}


def test_rolls_back_to_the_checkpoint_with_the_rates_halved():
    p = _policy(checkpoint_step=4)
    r = p.decide(NAN)
    assert r == Recovery("rollback", None, 4, 0.5, "rolled back to the checkpoint of step 4 with the learning "
                                                   "rates halved (recovery 1 of 2)")
    assert p.recoveries == 1


def test_takes_the_older_of_the_two_latest_snapshots():
    p = _policy()
    for step in (2, 4, 6):
        p.keep_snapshot(step, _state(step))
    r = p.decide("collapsed", "collapsed")
    assert (r.action, r.state, r.step, r.lr_factor) == ("rollback", _state(4), 4, 0.5)
    assert r.note.startswith("rolled back to the in-memory state of step 4")


def test_a_target_taken_after_a_recovery_is_halved_once_more_only():
    p = _policy()
    p.keep_snapshot(4, _state(4))
    assert p.decide(NAN).lr_factor == 0.5
    p.keep_snapshot(8, _state(8))  # taken with the rates already halved once
    p.keep_snapshot(10, _state(10))
    r = p.decide(NAN)
    assert (r.step, r.lr_factor) == (8, 0.5) and "recovery 2 of 2" in r.note
    p.checkpoint_saved(12)  # after the second recovery
    p.max_recoveries = 3
    assert p.decide(NAN).lr_factor == 0.5


def test_a_checkpoint_taken_before_a_recovery_halves_again():
    p = _policy(max_recoveries=3, checkpoint_step=4)
    p.keep_snapshot(6, _state(6))
    p.keep_snapshot(8, _state(8))
    assert p.decide(NAN).step == 6  # the snapshot is newer than the checkpoint
    r = p.decide(NAN)  # the snapshots went with the rollback: the checkpoint, taken before recovery 1
    assert (r.state, r.step, r.lr_factor) == (None, 4, 0.25)


def test_the_newer_of_snapshot_and_checkpoint_wins():
    p = _policy(checkpoint_step=6)
    p.keep_snapshot(4, _state(4))
    p.keep_snapshot(8, _state(8))
    assert p.decide(NAN).step == 6  # the older snapshot (4) is older than the checkpoint
    p = _policy(checkpoint_step=6)
    p.keep_snapshot(6, _state(6))
    r = p.decide(NAN)
    assert (r.state, r.step) == (_state(6), 6)  # as new as the checkpoint: the in-memory state


def test_before_any_snapshot_or_checkpoint_the_initial_state():
    initial = _state(0)
    p = _policy(initial=initial)
    r = p.decide("collapsed", "collapsed")
    assert (r.action, r.state, r.step, r.lr_factor) == ("rollback", initial, 0, 0.5)
    assert "in-memory state of step 0" in r.note
    assert p.initial is initial  # still there for a later restart
    p = _policy(checkpoint_step=3, initial=initial)
    assert p.decide(NAN).state is None  # with a checkpoint: the checkpoint


def test_gives_up_when_the_recoveries_are_spent():
    p = _policy(max_recoveries=1, checkpoint_step=4)
    assert p.decide(NAN).action == "rollback"
    r = p.decide(NAN)
    assert r == Recovery("give_up", None, None, 1.0, f"{NAN}; the last good checkpoint ({CKPT}) is kept")
    assert p.recoveries == 1


def test_gives_up_without_a_target():
    p = _policy()
    r = p.decide(NAN)
    assert (r.action, r.note) == ("give_up", NAN)  # no checkpoint to name
    assert p.recoveries == 0
    assert _policy(max_recoveries=0, checkpoint_step=2).decide(NAN).action == "give_up"


def test_a_mask_that_never_formed_restarts_once_from_the_initial_state():
    initial = _state(0)
    p = _policy(max_recoveries=0, initial=initial)
    p.keep_snapshot(2, _state(2))
    r = p.decide("the mask never formed", "never_formed")
    assert r == Recovery("restart", initial, 0, 1.0,
                         "restarted from step 0 with the adversarial terms off until the mask forms")
    assert p.recoveries == 0 and p.initial is None  # not a recovery; not twice
    p.checkpoint_saved(0)
    assert p.decide("the mask never formed", "never_formed").action == "give_up"  # max_recoveries 0
    p = _policy(checkpoint_step=0)
    p.checkpoint_saved(0)
    r = p.decide("the mask never formed", "never_formed")  # no initial state: a plain failure
    assert (r.action, r.step) == ("rollback", 0)


def test_a_restart_drops_the_snapshots_of_the_failed_attempt():
    p = _policy(initial=_state(0))
    p.keep_snapshot(2, _state(2))
    p.keep_snapshot(4, _state(4))
    p.decide("never formed", "never_formed")
    p.checkpoint_saved(0)
    assert p.decide(NAN).state is None  # the checkpoint of step 0, not a snapshot


def test_snapshots_are_wanted_on_healthy_steps_of_the_period():
    p = _policy(snapshot_every=100)
    assert p.wants_snapshot(200, True)
    assert not p.wants_snapshot(200, False) and not p.wants_snapshot(150, True)


def test_checkpoint_bookkeeping_and_the_answer_is_frozen():
    p = _policy()
    assert not p.has_checkpoint
    p.checkpoint_saved(5)
    assert p.has_checkpoint
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.decide(NAN).action = "give_up"
