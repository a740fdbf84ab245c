"""Names a user types (run names, motion names) that become one folder or file inside a project.

They are single path components, never joined unchecked: ``--name ..`` or ``--name ../../x``
must not reach outside ``runs/``. Names starting with a dot are the project's own (``runs/.cache``).
"""

from __future__ import annotations

from morf.errors import InputError

MAX_NAME_CHARS = 100


def check_name(name: str, what: str = "run name") -> str:
    """``name`` itself when it is a usable single folder name; an InputError saying why not."""
    if not isinstance(name, str) or not name.strip():
        raise InputError(f"the {what} is empty; give a folder name such as 'morf-cpu'")
    problem = None
    if name in (".", ".."):
        problem = "is a path, not a name"
    elif any(c in name for c in "/\\\0"):
        problem = "holds a path separator"
    elif name.startswith("."):
        problem = "starts with '.', which marks the project's own folders"
    elif name != name.strip():
        problem = "starts or ends with a space"
    elif len(name) > MAX_NAME_CHARS:
        problem = f"is longer than {MAX_NAME_CHARS} characters"
    elif any(ord(c) < 32 for c in name):
        problem = "holds a control character"
    if problem:
        raise InputError(f"the {what} {name!r} {problem}; a {what} is a single folder name "
                         "(letters, digits, '-', '_' and '.', e.g. 'morf-cpu')")
    return name
