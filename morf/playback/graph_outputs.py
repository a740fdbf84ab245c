"""Keep some outputs of a serialized ONNX model and drop the nodes only the others needed.

onnxruntime runs every node of a session's graph whatever a run fetches, so a player that only
ever fetches ``image`` pays for the nodes that make ``rgba`` alone. This trims them from the
model's bytes before the session opens.

It reads the protobuf wire format directly instead of importing the ``onnx`` package: that import
pulls in ``ml_dtypes``, half a second on a small CPU, which the torch-free player otherwise never
needs. Only the fields below are read; every other field is copied through byte for byte, in
order (field numbers from onnx.proto3):

    ModelProto.graph = 7
    GraphProto.node = 1, GraphProto.initializer = 5, GraphProto.input = 11, GraphProto.output = 12
    NodeProto.input = 1, NodeProto.output = 2, NodeProto.op_type = 4
    TensorProto.name = 8, ValueInfoProto.name = 1

Graphs with control-flow nodes (If, Loop, Scan) are left whole: their subgraphs read tensors of
the outer graph without naming them as node inputs.
"""

from __future__ import annotations

from dataclasses import dataclass

MODEL_GRAPH = 7
GRAPH_NODE, GRAPH_INITIALIZER, GRAPH_INPUT, GRAPH_OUTPUT = 1, 5, 11, 12
TENSOR_NAME = 8
NODE_INPUT, NODE_OUTPUT, NODE_OP_TYPE = 1, 2, 4
VALUE_INFO_NAME = 1
CONTROL_FLOW = frozenset({"If", "Loop", "Scan"})

VARINT, FIXED64, LENGTH, FIXED32 = 0, 1, 2, 5


@dataclass(frozen=True)
class Field:
    """One field of a message: its number, wire type, the bytes of the whole field (key included)
    and, for a length-delimited field, its payload."""

    number: int
    wire_type: int
    raw: bytes
    payload: bytes = b""


def _varint(buf: bytes, pos: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        if pos >= len(buf):
            raise ValueError("truncated varint")
        b = buf[pos]
        pos += 1
        value |= (b & 0x7F) << shift
        if not b & 0x80:
            return value, pos
        shift += 7
        if shift > 63:
            raise ValueError("varint too long")


def encode_varint(value: int) -> bytes:
    out = bytearray()
    while True:
        b = value & 0x7F
        value >>= 7
        if value:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


def fields(message: bytes) -> list[Field]:
    """The top-level fields of a serialized message, in order."""
    out, pos = [], 0
    while pos < len(message):
        start = pos
        key, pos = _varint(message, pos)
        number, wire_type = key >> 3, key & 7
        payload = b""
        if wire_type == VARINT:
            _, pos = _varint(message, pos)
        elif wire_type == FIXED64:
            pos += 8
        elif wire_type == FIXED32:
            pos += 4
        elif wire_type == LENGTH:
            size, pos = _varint(message, pos)
            payload = message[pos:pos + size]
            pos += size
        else:
            raise ValueError(f"unsupported wire type {wire_type} (field {number})")
        if pos > len(message):
            raise ValueError(f"truncated field {number}")
        out.append(Field(number, wire_type, message[start:pos], payload))
    return out


def _strings(message: bytes, number: int) -> list[str]:
    return [f.payload.decode("utf-8") for f in fields(message) if f.number == number and f.wire_type == LENGTH]


def _name(value_info: bytes) -> str:
    names = _strings(value_info, VALUE_INFO_NAME)
    if not names:
        raise ValueError("a graph output without a name")
    return names[0]


def _length_field(number: int, payload: bytes) -> bytes:
    return encode_varint(number << 3 | LENGTH) + encode_varint(len(payload)) + payload


def _graph(model: bytes) -> bytes:
    graphs = [f for f in fields(model) if f.number == MODEL_GRAPH and f.wire_type == LENGTH]
    if len(graphs) != 1:
        raise ValueError("not an ONNX model (no graph)")
    return graphs[0].payload


def _nodes(graph_fields: list[Field]) -> dict[int, tuple[list[str], list[str]]] | None:
    """Field index -> (inputs, outputs) of each node of a graph, or None when it has control flow."""
    nodes = {}
    for i, f in enumerate(graph_fields):
        if f.number == GRAPH_NODE:
            parts = fields(f.payload)
            op = [p.payload.decode("utf-8") for p in parts if p.number == NODE_OP_TYPE]
            if op and op[0] in CONTROL_FLOW:
                return None
            nodes[i] = ([p.payload.decode("utf-8") for p in parts if p.number == NODE_INPUT],
                        [p.payload.decode("utf-8") for p in parts if p.number == NODE_OUTPUT])
    return nodes


def keep_outputs(model: bytes, keep: tuple[str, ...] | list[str]) -> bytes | None:
    """``model`` with only the outputs named in ``keep`` and the nodes they need, or None when
    that would change nothing (no other output, a name in ``keep`` missing, no node to drop) or
    the graph has control flow.

    A node is dropped when none of its outputs is a kept graph output or an input of a kept node
    (repeated until nothing changes), so every tensor a kept output depends on is still made.
    Raises ValueError on bytes that are not a serialized model.
    """
    top = fields(model)
    graph_fields = fields(_graph(model))
    outputs = {i: _name(f.payload) for i, f in enumerate(graph_fields) if f.number == GRAPH_OUTPUT}
    if not set(keep) <= set(outputs.values()) or set(outputs.values()) <= set(keep):
        return None
    nodes = _nodes(graph_fields)
    if nodes is None:
        return None
    dropped = {i for i, name in outputs.items() if name not in keep}
    while True:
        used = set(keep)
        for i, (ins, _) in nodes.items():
            if i not in dropped:
                used.update(ins)
        dead = {i for i, (_, outs) in nodes.items() if i not in dropped and not used.intersection(outs)}
        if not dead:
            break
        dropped |= dead
    graph = b"".join(f.raw for i, f in enumerate(graph_fields) if i not in dropped)
    return b"".join(_length_field(MODEL_GRAPH, graph) if f.number == MODEL_GRAPH else f.raw for f in top)


def cut_graph(model: bytes, outputs: tuple[str, ...] | list[str]) -> bytes:
    """``model`` with exactly ``outputs`` as its outputs (tensors the graph makes; those that were
    not outputs are added by name, onnxruntime infers their types), the nodes they need, and the
    initializers and graph inputs those nodes read. Raises ValueError when a name is not made by
    the graph or the graph has control flow."""
    graph_fields = fields(_graph(model))
    nodes = _nodes(graph_fields)
    if nodes is None:
        raise ValueError("the graph has control flow")
    made = {o for _, outs in nodes.values() for o in outs}
    missing = [o for o in outputs if o not in made]
    if missing:
        raise ValueError(f"the graph makes no tensor named {missing[0]!r}")
    needed, keep_nodes = set(outputs), set()
    for i in sorted(nodes, reverse=True):  # nodes are stored in topological order
        ins, outs = nodes[i]
        if needed.intersection(outs):
            keep_nodes.add(i)
            needed.update(ins)
    parts = []
    for i, f in enumerate(graph_fields):
        if f.number == GRAPH_NODE and i not in keep_nodes:
            continue
        if f.number == GRAPH_OUTPUT:
            continue
        if f.number == GRAPH_INITIALIZER and not set(_strings(f.payload, TENSOR_NAME)[:1]) <= needed:
            continue
        if f.number == GRAPH_INPUT and _name(f.payload) not in needed:
            continue
        parts.append(f.raw)
    parts += [_length_field(GRAPH_OUTPUT, _length_field(VALUE_INFO_NAME, name.encode("utf-8"))) for name in outputs]
    graph = b"".join(parts)
    return b"".join(_length_field(MODEL_GRAPH, graph) if f.number == MODEL_GRAPH else f.raw for f in fields(model))
