"""``quality.md``: the tables of ``morf bench quality`` (one per evaluation block, one for the
trainings), its targets, and links to the comparison sheets and y-t slices beside it."""

from __future__ import annotations

from morf.bench.common import markdown_table
from morf.bench.quality_checks import Checks
from morf.bench.quality_runs import BenchRun
from morf.bench.quality_scores import BlockScores

BLOCK_COLUMNS = ["method", "runs", "psnr", "psnr_person", "psnr_person per seed", "psnr_person spread", "ssim",
                 "ssim_person", "ssim_person spread", "temporal"]
LPIPS_COLUMNS = ["lpips", "lpips_person"]  # shown when LPIPS was scored
# the detail table (shown when morf eval scored regions): the scores that choose between configurations
DETAIL_COLUMNS = ["method", "head_ssim_shift", "head_ssim_shift spread", "head_gmsd", "head_hf_ratio",
                  "head_hf_ratio_inside", "hands_ssim_shift", "hands_gmsd", "hands_hf_ratio", "person_ssim_shift", "person_gmsd",
                  "person_hf_ratio"]
RUN_COLUMNS = ["run", "method", "seed", "train_minutes", "plateau_minutes", "steps", "diverged"]


def _per_seed(values) -> str:
    return " / ".join("n/a" if v is None else f"{v:.2f}" for v in values)


def block_rows(block: BlockScores) -> list[dict]:
    rows = []
    for method, s in block.methods.items():
        rows.append({"method": method, "runs": len(s.seeds), **s.mean,
                     "psnr_person per seed": _per_seed(x["psnr_person"] for x in s.seeds),
                     "psnr_person spread": s.spread["psnr_person"], "ssim_person spread": s.spread["ssim_person"]})
    return rows


def detail_rows(block: BlockScores) -> list[dict]:
    return [{"method": method, **s.mean, "head_ssim_shift spread": s.spread.get("head_ssim_shift")}
            for method, s in block.methods.items()]


def detail_table(block: BlockScores) -> str:
    """The block's detail scores at native size, or "" when none were scored."""
    if not any(s.mean.get("head_ssim_shift") is not None or s.mean.get("person_ssim_shift") is not None
               for s in block.methods.values()):
        return ""
    md = ("\nDetail at native size (docs/evaluation.md): SSIM at the best shift within +-4 px and GMSD (lower is "
          "better) of the head, the hands and the whole person, and the high-frequency ratio render / real (under 1: "
          "blurrier than the real frames). Choose between configurations on these, not on person PSNR alone.\n\n")
    md += markdown_table(detail_rows(block), DETAIL_COLUMNS, "{:.4g}")
    if block.heads:
        md += f"\n![head crops at native size: real | each method (seed 0) | floor]({block.heads})\n"
    return md


def checks_lines(checks: Checks) -> str:
    lines = []
    for t in checks.targets:
        v, met = checks.values.get(t.name), checks.met[t.name]
        verdict = "not measured" if met is None else ("met" if met else "NOT met")
        lines.append(f"- {t.name} = {'n/a' if v is None else f'{v:.4g}'} (target {t.op} {t.bound:g}): {verdict}")
    lines += [f"- {k} = {'n/a' if v is None else f'{v:.4g}'}" for k, v in checks.values.items()
              if k not in checks.met]
    return "\n".join(lines) + "\n"


def quality_markdown(head: dict, blocks: list[tuple[BlockScores, Checks]], runs: list[BenchRun],
                     training: Checks) -> str:
    """The whole page; ``head``: preset, fits, holdout, seeds, project (as in quality.json)."""
    from morf.evaluate.targets import ordinal

    seeds, k = head["seeds"], head["holdout"]
    held = f"every {ordinal(k)} usable capture frame kept out of training" if k else "no capture frame kept out"
    trained = f"with seeds 0 to {seeds - 1}" if seeds > 1 else "once (seed 0)"
    bodies = "fitted bodies" if head["fits"] == "fits" else f"{head['fits']} bodies"
    md = (f"# Avatar quality ({head['preset']} preset, {bodies}, {seeds} seed{'s' * (seeds > 1)})\n\n"
          f"Capture `{head['project']}`; every learned method trained {trained}, the RGB floor "
          f"(rgb, no learning) built once; {held}. Means over the seeds; spread = max - min over them. PSNR in "
          "dB, SSIM, both over the image and over the person (higher is better); temporal = flicker (lower is "
          "better).\n")
    if head.get("poses") == "refined":
        md += ("Every frame is scored in its pose refined against the frame, each run alike, the floor included "
               "(`--refine-poses`, docs/evaluation.md): compare with other refined scores only.\n")
    lpips = any(s.mean.get(k) is not None for b, _ in blocks for s in b.methods.values() for k in LPIPS_COLUMNS)
    if lpips:
        md += "LPIPS (v0.1, vgg) over the image and over the person: lower is better.\n"
    for block, checks in blocks:
        md += (f"\n## {block.title[:1].upper()}{block.title[1:]}, {block.frames} frames\n\n"
               + markdown_table(block_rows(block), BLOCK_COLUMNS + (LPIPS_COLUMNS if lpips else []), "{:.4g}")
               + detail_table(block)
               + "\n" + checks_lines(checks)
               + f"\n![comparison sheet: real | each method (seed 0) | floor]({block.sheet})\n\n"
               + f"![y-t slices]({block.slices})\n")
    md += ("\n## Trainings\n\n" + markdown_table([{"run": r.name, **r.to_dict()} for r in runs], RUN_COLUMNS, "{:.4g}")
           + "\n" + checks_lines(training))
    return md
