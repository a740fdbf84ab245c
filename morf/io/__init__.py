"""Safe file I/O: atomic writes and pickle-free array storage."""

from morf.io.atomic import atomic_write_bytes, atomic_write_json, atomic_write_text, atomic_path
from morf.io.arrays import load_npz, save_npz
from morf.io.images import read_image, write_image

__all__ = [
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_json",
    "atomic_write_text",
    "load_npz",
    "save_npz",
    "read_image",
    "write_image",
]
