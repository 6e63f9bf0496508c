"""The pytest plugin of the test kit (entry point pytest11 "carav"; installed with the package).

Fixture `carav`: a `carav_stream.testing.graphs.Graphs` in the test's tmp_path, every process group it started
killed and its run folder removed after the test. Parametrise it indirectly with a data plane to run every graph
of the test over it:

    @pytest.mark.parametrize("carav", ["zmq", "shm"], indirect=True)
    def test_my_detector_fails_closed(carav):
        run = carav.run(radar_graph(carav, {"detector": {"type": "my_detector"}}, block_paths=[HERE]),
                        "--cycles", "200")
        assert run.wait() == 0
        check_fail_closed(carav.workdir)
"""
from __future__ import annotations

import pytest

from carav_stream.testing.graphs import Graphs


@pytest.fixture
def carav(tmp_path, request):
    graphs = Graphs(tmp_path, transport=getattr(request, "param", None))
    yield graphs
    graphs.close()
