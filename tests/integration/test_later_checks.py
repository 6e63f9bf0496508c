"""`carav run` leaves the blocks' param_warnings() to its supervisor, which runs them while the nodes start
(runtime/supervisor.py, LaterChecks): no frame flows before they are done, their warnings are told, and a graph
they find invalid is refused with validation's exit code before any node is let go."""
from pathlib import Path

from carav_stream.console.errors import Exit

# A source whose checks wait until its own node has started (its start() runs before the node reports ready), then
# take a while more: were the nodes let go before the checks end, it would generate a frame without the mark.
LATE = '''
import time
from pathlib import Path

import numpy as np

from carav_stream.runtime.block import Block, BlockError, Out, Param
from carav_stream.runtime.frames import Frame


class LateSource(Block):
    outputs = (Out("out", kind="numbers", dtypes=("float64",)),)
    params = (Param("folder", str, "", "where the marks go"), Param("fail", bool, False, "checks find it invalid"))

    def start(self) -> None:
        Path(self.folder, "started").touch()

    def param_warnings(self) -> list[str]:
        started, deadline = Path(self.folder, "started"), time.monotonic() + 300
        while not started.exists() and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.5)                  # a node let go now would generate before the mark below
        if self.fail:
            raise ValueError("folder: not a place these checks accept")
        Path(self.folder, "checked").touch()
        return ["late_source: checked while its node was waiting to go"]

    def generate(self, seq: int) -> Frame:
        if not Path(self.folder, "checked").exists():
            raise BlockError("a frame before the checks were done")
        Path(self.folder, "generated").touch()
        return Frame.of(np.full(4, float(seq)))
'''


def _graph(carav, fail: bool) -> Path:
    blocks = carav.workdir / "late_blocks"
    blocks.mkdir(exist_ok=True)
    (blocks / "late_source.py").write_text(LATE)
    marks = carav.workdir / "marks"
    marks.mkdir(exist_ok=True)
    graph = carav.workdir / "late.toml"
    graph.write_text(f"""
block_paths = ["late_blocks"]
connections = ["src.out -> log.inp"]
[run]
cycles = 5
[blocks]
src = {{ type = "late_source", folder = "{marks}", fail = {str(fail).lower()} }}
log = {{ type = "jsonl_sink", path = "out.jsonl" }}
""")
    return marks


def test_no_frame_flows_before_the_blocks_checks_are_done_and_their_warnings_are_told(carav):
    marks = _graph(carav, fail=False)
    run = carav.run(carav.workdir / "late.toml")
    assert run.wait() == Exit.OK, run.stderr()
    assert "carav run: warning: late_source: checked while its node was waiting to go" in run.stderr()
    assert (marks / "generated").exists() and run.summary()["per_node"]["log"]["cycles"] == 5


def test_a_graph_its_blocks_checks_find_invalid_is_refused_before_any_frame(carav):
    marks = _graph(carav, fail=True)
    run = carav.run(carav.workdir / "late.toml")
    assert run.wait() == Exit.INVALID, run.stderr()
    assert "late.toml is not valid:" in run.stderr() and "blocks.src: folder: not a place these checks accept" \
        in run.stderr(), run.stderr()
    assert (marks / "started").exists() and not (marks / "generated").exists()
