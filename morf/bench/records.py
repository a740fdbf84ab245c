"""Results that are flat records of JSON values (a row of a benchmark's table)."""

from __future__ import annotations

from dataclasses import asdict, fields


class FlatRecord:
    """Base of a frozen dataclass whose fields are all plain JSON values: it is saved as the dict
    of its fields and read back from one, so the JSON keys are the field names and cannot drift
    from them."""

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict):
        """The record of ``d``'s values of the fields (other keys are ignored; a missing one is a KeyError)."""
        return cls(**{f.name: d[f.name] for f in fields(cls)})
