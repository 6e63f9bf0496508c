"""What crosses a process boundary besides frames: node specs and control messages, msgpack only."""
import msgpack
import pytest

from carav_stream.runtime.protocol import Control, NodeSpec, OutEdge, Report, pack, unpack


def spec(**changes) -> NodeSpec:
    base = NodeSpec(name="gate", type="gate", params={"x": 1.5}, control="ipc:///tmp/c",
                    inputs={"frames": "ipc:///tmp/g.frames"},
                    outputs={"clean": (OutEdge("gate.clean -> r.frames", "ipc:///tmp/r.frames"),)},
                    block_paths=("/blocks",), security={})
    return base.with_(**changes)


def test_a_node_spec_survives_the_trip_to_the_node_process_unchanged():
    s = spec(incarnation=2, generation=1, start_seq=7, recovering=True)
    assert NodeSpec.from_wire(s.to_wire()) == s


def test_a_node_spec_with_an_unknown_key_is_refused_naming_it():
    raw = msgpack.packb({**msgpack.unpackb(spec().to_wire()), "colour": "red"})
    with pytest.raises(ValueError, match=r"unknown keys \['colour'\]"):
        NodeSpec.from_wire(raw)


def test_messages_are_plain_maps_and_anything_else_is_refused():
    assert unpack(pack(Control.SWAP, block="b", id=1)) == {"type": "swap", "block": "b", "id": 1}
    assert unpack(pack(Report.HEARTBEAT)) == {"type": "hb"}
    with pytest.raises(ValueError, match="expected a map"):
        unpack(msgpack.packb([1, 2]))
    with pytest.raises(ValueError, match="extension type 5 refused"):
        unpack(msgpack.packb({"type": msgpack.ExtType(5, b"\x80\x04")}))
    with pytest.raises(ValueError, match="not valid msgpack"):
        unpack(b"\xc1")
