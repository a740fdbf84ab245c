"""User-facing errors: one line of text, a non-zero exit, never a traceback."""


class MorfError(Exception):
    """An error caused by the user's input or environment, reported as one line."""

    exit_code = 2


class InputError(MorfError):
    """The input file or folder cannot be used (missing, wrong kind, corrupt, malformed)."""


class ProjectError(MorfError):
    """A capture project folder is missing, of an unknown version, or damaged."""


class TrainingDiverged(MorfError):
    """Training produced NaN/inf or exploded; the last good checkpoint is kept."""

    exit_code = 3
