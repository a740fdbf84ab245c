"""The ``morf`` command line: one module per sub-command, all calling library functions."""
