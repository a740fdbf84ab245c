"""The checks every stage config shares: keys read from a file must be fields, and the first
setting that makes no sense is reported as one :class:`~morf.errors.InputError`."""

from __future__ import annotations

import dataclasses
import math

from morf.errors import InputError


def check_keys(cls: type, d: dict, what: str) -> dict:
    """``d`` when all its keys are fields of dataclass ``cls``; else an InputError naming the others."""
    unknown = set(d) - {f.name for f in dataclasses.fields(cls)}
    if unknown:
        raise InputError(f"unknown {what} keys: {sorted(unknown)}")
    return d


_KINDS = {"bool": (lambda v: isinstance(v, bool), "true or false"),
          "int": (lambda v: isinstance(v, int) and not isinstance(v, bool), "a whole number"),
          "float": (lambda v: isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v),
                    "a finite number"),
          "str": (lambda v: isinstance(v, str), "text")}


def check_field_kinds(cfg, what: str, prefix: str = "") -> None:
    """InputError unless every plain field of dataclass ``cfg`` holds a value of its declared kind
    (a config file may hold anything): a bool for a switch, a whole number (not a bool) for a count,
    a finite number for a real, text for a name. Fields of other types (nested configs, optional
    values) are left to their own checks. ``what`` names the config in messages ("fit config");
    ``prefix`` goes before the field's name ("renderer.")."""
    for f in dataclasses.fields(cfg):
        kind = _KINDS.get(f.type if isinstance(f.type, str) else getattr(f.type, "__name__", ""))
        if kind is None:
            continue
        value = getattr(cfg, f.name)
        ok, words = kind
        if not ok(value):
            raise InputError(f"{what} field {prefix}{f.name} must be {words}, got {value!r}")


def raise_first(checks: list[tuple[bool, str]]) -> None:
    """Raise an InputError with the message of the first ``(ok, message)`` that is not ok."""
    for ok, message in checks:
        if not ok:
            raise InputError(message)


def apply_settings(d: dict, settings: list[str] | tuple[str, ...]) -> dict:
    """``d`` (a config's ``to_dict()``) with ``FIELD=VALUE`` settings applied in place and returned.

    FIELD may name a nested field (``renderer.width``) or an item of a list (``stages.0.iterations``).
    VALUE is read as JSON when it parses (numbers, true/false, lists), else as a string. A malformed
    setting or an unknown field is an InputError naming the known ones.
    """
    import json

    for item in settings:
        key, sep, text = item.partition("=")
        if not sep or not key:
            raise InputError(f"--set wants FIELD=VALUE, got {item!r}")
        try:
            value = json.loads(text)
        except json.JSONDecodeError:
            value = text
        node, parts = d, key.split(".")
        for part in parts[:-1]:
            child = _child(node, part, key)
            if isinstance(child, tuple):  # to_dict keeps tuples (fit stages): a list to set an item of
                child = list(child)
                node[int(part) if isinstance(node, list) else part] = child
            if not isinstance(child, (dict, list)):
                raise InputError(f"unknown config section {part!r} in {key!r}")
            node = child
        last = parts[-1]
        if isinstance(node, list):
            node[int(last)] = _like(_child(node, last, key), value, key)  # _child: a valid index
            continue
        if last not in node:
            raise InputError(f"unknown config field {key!r}; known here: {', '.join(sorted(node))}")
        node[last] = _like(node[last], value, key)
    return d


def _like(old, value, key: str):
    """``value`` when it has the kind of ``old`` (the field's current value; None: any kind), an
    integer turned float for a float field; else an InputError."""
    kinds = ((bool, (bool,), "true or false"), (int, (int,), "an integer"), (float, (int, float), "a number"),
             (str, (str,), "a string"), ((list, tuple), (list, tuple), "a list"), (dict, (dict,), "a section"))
    for kind, accepted, words in kinds:
        if isinstance(old, kind):
            if not isinstance(value, accepted) or (isinstance(value, bool) and kind is not bool):
                raise InputError(f"config field {key!r} wants {words}, got {value!r}")
            if kind is float and not math.isfinite(value):
                raise InputError(f"config field {key!r} wants a finite number, got {value!r}")
            return float(value) if kind is float else value
    return value


def _child(node, part: str, key: str):
    """Item ``part`` of a dict, or of a list when ``part`` is an index into it."""
    if isinstance(node, list):
        if not part.isdigit() or int(part) >= len(node):
            raise InputError(f"{part!r} in {key!r} is no index of a list of {len(node)}")
        return node[int(part)]
    if not isinstance(node.get(part), (dict, list, tuple)):
        raise InputError(f"unknown config section {part!r} in {key!r}")
    return node[part]


def read_config_file(path, what: str) -> dict:
    """The JSON object in file ``path``; an unreadable file or anything but an object is an InputError."""
    import json

    try:
        d = json.loads(open(path, encoding="utf-8").read())
    except (OSError, ValueError) as e:
        raise InputError(f"cannot read config {path}: {e}") from None
    if not isinstance(d, dict):
        raise InputError(f"{path} is not a {what} (a JSON object)")
    bad = first_non_finite(d)
    if bad is not None:
        raise InputError(f"{path}: {bad[0]!r} is {bad[1]!r}; every number of a {what} must be finite")
    return d


def first_non_finite(node, key: str = "") -> tuple[str, float] | None:
    """(dotted key, value) of the first NaN or infinite number in a JSON tree; None when all are finite."""
    if isinstance(node, float) and not math.isfinite(node):
        return key, node
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, (list, tuple)) else ()
    for k, v in items:
        found = first_non_finite(v, f"{key}.{k}" if key else str(k))
        if found is not None:
            return found
    return None
