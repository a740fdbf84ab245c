"""The stability benchmark's trainings on Ray: which may run at once (waves of one setting of the
shared clean capture each) and which trainings run once for several results."""

from __future__ import annotations

from morf.bench.stability import Setting, plan_waves


def test_waves_keep_one_setting_of_the_clean_capture_at_a_time():
    clean = "/x/captures/clean"
    settings = [
        Setting(clean, "ground-truth", "stab-clean", hidden_deg=0),  # misalignment level 0
        Setting(clean, "fits", "stab-misalignment-1", hidden_deg=0, noise=(10.0, 1)),
        Setting(clean, "fits", "stab-misalignment-2", hidden_deg=0, noise=(20.0, 2)),  # other fits: another wave
        Setting("/x/captures/slide-1", "ground-truth", "stab-slide-1"),  # its own capture: the first wave
        Setting(clean, "ground-truth", "stab-coverage-1", hidden_deg=90),
        Setting(clean, "ground-truth", "stab-clean", hidden_deg=0),  # coverage level 0
        Setting("/x/captures/keypoints-1", "fits", "stab-keypoints-1"),
    ]
    assert plan_waves(settings) == [(0, (10.0, 1), [0, 1, 3, 5, 6]), (0, (20.0, 2), [2]), (90, None, [4])]


def test_waves_of_captures_of_their_own_only():
    settings = [Setting("/x/captures/fast-1", "ground-truth", "stab-fast-1"),
                Setting("/x/captures/loose-1", "ground-truth", "stab-loose-1")]
    assert plan_waves(settings) == [(None, None, [0, 1])]
    assert plan_waves([]) == []
    # the first wave of own captures takes the first clean setting that comes
    mixed = settings + [Setting("/x/captures/clean", "ground-truth", "stab-coverage-1", hidden_deg=180)]
    assert plan_waves(mixed) == [(180, None, [0, 1, 2])]
