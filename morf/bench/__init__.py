"""Benchmarks (``morf bench NAME --out DIR``): every number quoted in docs/ comes from one of these.

Library code, one benchmark a module (with its helpers beside it: ``quality_*``, ``stability_*``,
``pareto_results``, ``render_results``): each takes typed options (a frozen dataclass or keyword
arguments), writes ``DIR/<name>.json`` plus a Markdown table ``DIR/<name>.md`` and returns the
result. Their command lines live in :mod:`morf.cli.bench`.
"""
