"""A recorder whose disk fills up stops with one line naming the file and what happened, never its traceback
(in-process through /dev/full; `carav record` on a full disk: tests/integration/test_recording_full_disk.py)."""

import numpy as np
import pytest

from carav_blocks.sigmf_sink import SigmfSink
from carav_stream.runtime import BlockError, Frame
from tests.blocks.helpers import wire
from tests.blocks.jig import GOLDEN

IQ_SCENE = str(GOLDEN / "adc_small_iq.toml")      # 4 chirps x 256 samples, I/Q


def test_a_full_disk_under_the_samples_is_one_error_naming_the_data_file(tmp_path):
    (tmp_path / "rec.sigmf-data").symlink_to("/dev/full")
    sink = SigmfSink(path=str(tmp_path / "rec"), scene=IQ_SCENE, batch=2)
    sink.start()
    codes = np.zeros((64, 4, 256, 2), np.int16)      # 256 KiB: more than the file's buffer, written at once
    with pytest.raises(BlockError, match=rf"^{tmp_path}/rec.sigmf-data: cannot write: No space left on device$"):
        sink.process(wire(Frame.of(codes, cycle=0, cycles=64), 0))


def test_a_full_disk_at_the_end_of_the_stream_is_one_error_naming_the_file(tmp_path):
    (tmp_path / "rec.sigmf-data").symlink_to("/dev/full")
    sink = SigmfSink(path=str(tmp_path / "rec"), scene=IQ_SCENE, batch=2)
    sink.start()
    sink.process(wire(Frame.of(np.zeros((1, 4, 256, 2), np.int16), cycle=0, cycles=1), 0))   # still buffered
    with pytest.raises(BlockError, match=rf"^{tmp_path}/rec.sigmf-data: cannot write: No space left on device$"):
        sink.finish()
