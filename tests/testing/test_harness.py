"""The kit's block harness feeds a block as a node does: through the codec, paired by seq, a frame without partner
to `unpaired`; whole and split give the same outputs; a block that breaks its port's declaration is caught."""
import numpy as np
import pytest

from carav_stream.runtime import Block, Frame, In, Out
from carav_stream.testing import BlockHarness, assert_outputs, random_bounds
from carav_stream.testing.harness import frames_of
from tests.toy_blocks.adder import Adder
from tests.toy_blocks.pairer import Pairer


def test_the_harness_pairs_inputs_by_seq_and_sums_them_whole_and_split():
    a, b = np.arange(12.0).reshape(6, 2), np.ones((6, 2))
    for bounds in (None, random_bounds(6, seed=4), [(0, 1), (1, 2), (2, 6)]):
        out = BlockHarness(Adder).run({"a": a, "b": b}, bounds=bounds)
        assert_outputs(out.payloads(), {"out": a + b}, where=f"bounds {bounds}")
        assert [h["cycles"] for h in out.headers("out")] == [y - x for x, y in bounds or [(0, 6)]]


def test_a_frame_whose_partner_never_comes_goes_to_unpaired_as_in_a_node():
    bounds = [(0, 2), (2, 4), (4, 6)]
    frames = {"a": frames_of(np.zeros((6, 1)), bounds), "b": frames_of(np.zeros((4, 1)), bounds[:2])}
    out = BlockHarness(Pairer).feed(frames)
    assert out.unpaired == [("a", 2)]
    assert [h["handled"] for h in out.headers("out")] == ["paired", "paired", "alone"]


class WrongDtype(Block):
    inputs = (In("x"),)
    outputs = (Out("y", dtypes=("float32",)),)

    def process(self, x: Frame) -> Frame:
        return x.derive(x.payload.astype(np.float64))


class WritesItsInput(Block):
    inputs = (In("x"),)
    outputs = (Out("y"),)

    def process(self, x: Frame) -> Frame:
        x.payload[:] = 0
        return x.derive(x.payload)


def test_a_block_that_sends_an_undeclared_dtype_is_caught():
    with pytest.raises(AssertionError, match="payload float64, declared"):
        BlockHarness(WrongDtype).run({"x": np.zeros((2, 3), np.float32)})


def test_a_block_that_writes_into_its_received_frame_fails_as_on_the_wire():
    with pytest.raises(ValueError, match="read-only"):
        BlockHarness(WritesItsInput).run({"x": np.zeros((2, 3))})


def test_assert_outputs_names_what_differs():
    with pytest.raises(AssertionError, match="y has shape"):
        assert_outputs({"y": np.zeros(3)}, {"y": np.zeros(4)})
    with pytest.raises(AssertionError, match="y is float32, expected float64"):
        assert_outputs({"y": np.zeros(3, np.float32)}, {"y": np.zeros(3)})
    with pytest.raises(AssertionError):
        assert_outputs({"y": np.array([1.0])}, {"y": np.array([1.1])}, rtol=0.01)
