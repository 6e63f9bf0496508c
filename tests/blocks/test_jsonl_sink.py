"""JSON-lines sink: one line per frame, small payloads as lists, both ports told apart."""
import json

import numpy as np
import pytest

from carav_blocks.jsonl_sink import JsonlSink
from carav_stream.runtime import Frame
from tests.blocks.helpers import wire


def test_each_frame_is_one_line_with_its_header_and_small_payloads(tmp_path):
    sink = JsonlSink(path=str(tmp_path / "log.jsonl"), max_values=4)
    sink.start()
    sink.process(wire(Frame.of(np.arange(3, dtype=np.float32), note="a"), 7), None)
    sink.process(None, wire(Frame.of(np.zeros((4, 4), np.int16)), 8))
    sink.finish()
    first, second = (json.loads(line) for line in (tmp_path / "log.jsonl").read_text().splitlines())
    assert first["port"] == "inp" and first["seq"] == 7 and first["note"] == "a" and first["data"] == [0, 1, 2]
    assert second["port"] == "extra" and second["seq"] == 8 and "data" not in second   # 16 values: too large


def test_a_full_disk_is_one_line_naming_the_file_and_no_restart_would_help():
    from carav_stream.runtime import BlockError

    sink = JsonlSink(path="/dev/full")
    sink.start()
    with pytest.raises(BlockError, match=r"^/dev/full: cannot write: No space left on device$") as err:
        sink.process(Frame.of(None, cycle=0, cycles=1))
    assert err.value.retry is False
