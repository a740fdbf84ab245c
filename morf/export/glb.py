"""A small binary glTF 2.0 (.glb) builder: one buffer, typed accessors, a JSON document.

Enough of the format for a skinned, textured mesh with animations; no external dependency.
Every buffer view starts on a 4-byte boundary (the spec's alignment for any accessor component)
and both chunks are padded to 4 bytes (JSON with spaces, BIN with zeros), as the spec requires.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np

GLB_MAGIC = 0x46546C67  # "glTF"
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942
ARRAY_BUFFER = 34962
ELEMENT_ARRAY_BUFFER = 34963

# numpy dtype -> glTF componentType
COMPONENT_TYPES = {np.dtype(np.int8): 5120, np.dtype(np.uint8): 5121, np.dtype(np.int16): 5122,
                   np.dtype(np.uint16): 5123, np.dtype(np.uint32): 5125, np.dtype(np.float32): 5126}
# trailing shape -> glTF accessor type
ACCESSOR_TYPES = {(): "SCALAR", (2,): "VEC2", (3,): "VEC3", (4,): "VEC4", (4, 4): "MAT4"}


class GlbBuilder:
    """Collects buffer views, accessors and the glTF JSON; :meth:`write` makes the .glb.

    The document (``self.doc``) is a plain dict in glTF's own keys; callers append nodes,
    meshes, materials, ... to its lists and use the indices the ``add_*`` methods return.
    """

    def __init__(self, generator: str):
        self.doc: dict = {"asset": {"version": "2.0", "generator": generator}, "buffers": [], "bufferViews": [],
                          "accessors": []}
        self._chunks: list[bytes] = []
        self._length = 0

    def add_buffer_view(self, data: bytes, target: int | None = None) -> int:
        """Append raw bytes as a buffer view (4-byte aligned); returns its index."""
        pad = (-self._length) % 4
        if pad:
            self._chunks.append(b"\0" * pad)
            self._length += pad
        view = {"buffer": 0, "byteOffset": self._length, "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        self._chunks.append(bytes(data))
        self._length += len(data)
        self.doc["bufferViews"].append(view)
        return len(self.doc["bufferViews"]) - 1

    def add_accessor(self, array: np.ndarray, target: int | None = None, min_max: bool = False,
                     normalized: bool = False) -> int:
        """Append an array as a tightly packed accessor; returns its index.

        Args:
            array: (N, *element) with element shape (), (2,), (3,), (4,) or (4, 4) and a dtype
                glTF knows (int8/uint8/int16/uint16/uint32/float32). MAT4 elements are written
                column-major, as glTF stores matrices, from row-major (N, 4, 4) input.
            target: ARRAY_BUFFER (vertex attributes), ELEMENT_ARRAY_BUFFER (indices) or None.
            min_max: record per-component min and max (required for POSITION and sampler inputs).
        """
        a = np.asarray(array)
        if a.dtype not in COMPONENT_TYPES:
            raise ValueError(f"glTF has no component type for {a.dtype}")
        element = a.shape[1:]
        if element not in ACCESSOR_TYPES:
            raise ValueError(f"glTF has no accessor type for elements of shape {element}")
        if element == (4, 4):
            a = np.swapaxes(a, 1, 2)  # column-major
        a = np.ascontiguousarray(a)
        acc = {"bufferView": self.add_buffer_view(a.tobytes(), target), "componentType": COMPONENT_TYPES[a.dtype],
               "count": int(a.shape[0]), "type": ACCESSOR_TYPES[element]}
        if normalized:
            acc["normalized"] = True
        if min_max:
            flat = a.reshape(a.shape[0], -1)
            cast = float if a.dtype.kind == "f" else int
            acc["min"] = [cast(x) for x in flat.min(0)]
            acc["max"] = [cast(x) for x in flat.max(0)]
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def add_image(self, png: bytes, name: str = "") -> int:
        """Embed a PNG as an image in the binary chunk; returns the image index."""
        image = {"bufferView": self.add_buffer_view(png), "mimeType": "image/png"}
        if name:
            image["name"] = name
        self.doc.setdefault("images", []).append(image)
        return len(self.doc["images"]) - 1

    def append(self, key: str, item: dict) -> int:
        """Append ``item`` to the document's list ``key`` (nodes, meshes, ...); returns its index."""
        self.doc.setdefault(key, []).append(item)
        return len(self.doc[key]) - 1

    def to_bytes(self) -> bytes:
        """The whole .glb: header, JSON chunk, BIN chunk."""
        binary = b"".join(self._chunks)
        binary += b"\0" * ((-len(binary)) % 4)
        doc = dict(self.doc)
        doc["buffers"] = [{"byteLength": len(binary)}]
        text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
        text += b" " * ((-len(text)) % 4)
        total = 12 + 8 + len(text) + 8 + len(binary)
        return b"".join([struct.pack("<III", GLB_MAGIC, 2, total), struct.pack("<II", len(text), CHUNK_JSON), text,
                         struct.pack("<II", len(binary), CHUNK_BIN), binary])

    def write(self, path: str | Path) -> int:
        """Write the .glb atomically; returns its size in bytes."""
        from morf.io import atomic_path

        data = self.to_bytes()
        with atomic_path(path) as tmp:
            Path(tmp).write_bytes(data)
        return len(data)
