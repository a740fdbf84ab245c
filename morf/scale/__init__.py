"""Many trainings and captures at once on Ray: the sweeps' and stability series' trainings
(``morf bench pareto`` / ``stability``) and whole captures (``morf batch``).

:mod:`morf.scale.ray_runtime` connects (an embedded local Ray by default, a cluster with
``--address`` or ``RAY_ADDRESS``) and says what each task holds; :mod:`morf.scale.tasks` runs a
list of calls as Ray tasks and hands back one outcome per call. Ray is the optional extra
``morf-studio[ray]``: nothing here imports it until a function that needs it runs, so the rest of
``morf`` (and ``morf --help``) never loads it.
"""
