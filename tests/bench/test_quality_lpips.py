"""``morf bench quality --lpips``: bad weights stop it before any work; LPIPS columns in quality.md."""

from morf.cli.main import main


def test_bad_lpips_weights_fail_before_training(tmp_path, capsys, lpips_weights):
    lin, vgg = lpips_weights
    for args, words in ((["--lpips", str(tmp_path / "none.pth"), "--vgg", str(vgg)], "LPIPS weights not found"),
                        (["--lpips", str(lin), "--vgg", str(tmp_path / "none.pth")], "VGG-16 weights not found")):
        rc = main(["bench", "quality", "--preset", "tiny", "--out", str(tmp_path / "q"), *args])
        err = capsys.readouterr().err.strip().splitlines()
        assert rc != 0 and len(err) == 1 and words in err[0], err
    assert not (tmp_path / "q").exists()


def test_lpips_columns_only_when_scored():
    from morf.bench.quality_checks import block_checks, training_checks
    from morf.bench.quality_report import quality_markdown
    from morf.bench.quality_runs import BenchRun
    from morf.bench.quality_scores import METRICS, BlockScores, MethodScores, method_scores
    from morf.evaluate.results import EvalResult, RunScores, TargetScores

    scores = TargetScores(psnr=20.0, ssim=0.9, psnr_person=18.0, ssim_person=0.7, temporal=0.05,
                          background=(0.5, 0.5, 0.5), frames=4, lpips=0.25, lpips_person=0.4, resolution=64)
    ev = EvalResult("p", "training", "", {"bench-morf-tiny": RunScores("morf", 0, 64, "fits", False,
                                                                      {"novel-poses": scores})}, {}, {})
    runs = [BenchRun("morf", 0, "bench-morf-tiny")]
    scored = method_scores("morf", runs, ev, "novel-poses")
    assert set(METRICS) <= set(scored.mean) and scored.mean["lpips_person"] == 0.4
    unscored = MethodScores("morf", {**scored.mean, "lpips": None, "lpips_person": None}, (), scored.spread)
    head = {"preset": "tiny", "fits": "fits", "holdout": 5, "seeds": 1, "project": "p"}
    for scores, shown in ((scored, True), (unscored, False)):
        block = BlockScores("novel-poses", "novel poses", 4, "s.png", "y.png", {"morf": scores})
        md = quality_markdown(head, [(block, block_checks(block, "rgb"))], runs, training_checks(None))
        assert ("| lpips | lpips_person |" in md) is shown and ("0.4 |" in md) is shown
