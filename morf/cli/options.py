"""Options that several commands take, declared and checked in one place so that they read,
default and fail alike in every command that has them."""

from __future__ import annotations

FITS_CHOICES = ("auto", "fits", "ground-truth")  # the body fits a stage poses the body with


def add_config_options(p, config_file: str, examples: tuple[str, ...]) -> None:
    """``--config JSON`` (a whole stage config from a file an earlier run wrote, instead of a preset)
    and ``--set FIELD=VALUE`` (any field, repeatable, applied last). ``config_file`` says which file
    that is, e.g. "a run's config.json"; ``examples``: ``FIELD=VALUE`` examples for the help."""
    p.add_argument("--config", default=None, metavar="JSON",
                   help=f"start from a config file ({config_file}) instead of a preset")
    shown = " ".join(f"--set {e}" for e in examples)
    p.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                   help=f"set any config field, e.g. {shown} (repeatable; applied last)")


def read_config_option(args, what: str, instead_of: tuple[str, ...] = ("preset",)) -> dict | None:
    """The JSON object of ``--config`` (None when not given), checked by
    :func:`morf.config_checks.read_config_file`. ``instead_of``: the options that also choose the
    whole config (e.g. ``--preset``), refused beside it so that one of them is not silently ignored."""
    if not getattr(args, "config", None):
        return None
    from morf.config_checks import read_config_file
    from morf.errors import InputError

    if any(getattr(args, name, None) for name in instead_of):
        named = "/".join(f"--{name}" for name in instead_of)
        raise InputError(f"--config gives the whole config; use --set to change fields, not {named}")
    return read_config_file(args.config, what)


def add_fits_option(p, purpose: str) -> None:
    """``--fits auto|fits|ground-truth``: which body fits a stage uses; ``purpose`` is its help."""
    p.add_argument("--fits", choices=FITS_CHOICES, default="auto", help=purpose)


def add_force_option(p, replaces: str) -> None:
    """``--force``: a command's permission to write where its output already exists (under the
    rules of :mod:`morf.io.outputs`: it replaces only its own files). ``replaces``: its help, what
    the command replaces and what it keeps."""
    p.add_argument("--force", action="store_true", help=replaces)


def add_motion_fps_option(p, text: str) -> None:
    """``--motion-fps RATE``: the frame rate of a motion file that stores none (a stored one wins);
    checked by :func:`check_frame_rate`. ``text``: its help, naming the formats the command reads."""
    p.add_argument("--motion-fps", type=float, default=None, help=text)


def check_frame_rate(flag: str, rate: float | None) -> None:
    """A given frame rate must be positive and at most 1000 (NaN refused too); None is not given."""
    from morf.errors import InputError

    if rate is not None and not 0 < rate <= 1000:
        raise InputError(f"{flag} must be positive (a frame rate of at most 1000), got {rate}")


def add_weights_option(p, flag: str, text: str) -> None:
    """``--vgg PATH`` / ``--lpips PATH``: a network's weights file, never downloaded; without it
    the library falls back to its environment variable (:mod:`morf.avatar.vgg`,
    :mod:`morf.avatar.lpips`). ``text``: its help, what the command uses the weights for."""
    p.add_argument(flag, default=None, metavar="PATH", help=text)
