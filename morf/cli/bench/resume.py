"""``morf bench resume --out DIR``: the command line of :mod:`morf.bench.resume`."""

from __future__ import annotations


def add_arguments(p) -> None:
    p.add_argument("--out", required=True, help="output folder for resume.json / resume.md (and the work files)")
    p.add_argument("--kills", type=int, default=20, help="kills, spread over the uninterrupted run's duration")
    p.add_argument("--seed", type=int, default=0, help="seed of the kill times (stratified random)")
    p.add_argument("--preset", default="tiny", help="synth and 'morf run' preset (default tiny)")
    p.add_argument("--tolerance", type=float, default=1e-5, help="largest absolute difference allowed in any array")
    p.add_argument("--keep", action="store_true", help="keep every kill's project copy (default: only failed ones)")


def run(args) -> int:
    """0 when every kill ended with the reference avatar, else 1."""
    from morf.bench.resume import ResumeOptions, run_resume

    result = run_resume(ResumeOptions(args.out, args.kills, args.seed, args.preset, args.tolerance, args.keep))
    return 0 if result["passed"] == len(result["rows"]) else 1
