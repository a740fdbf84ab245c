"""Benchmarks (``morf bench NAME --out DIR``): every number quoted in docs/ comes from one of these.

Each module defines ``add_arguments(parser)`` and ``run(args) -> int`` and writes
``DIR/<name>.json`` plus a Markdown table ``DIR/<name>.md``.
"""
