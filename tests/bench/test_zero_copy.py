"""`carav bench zerocopy`: every data plane carries every frame of a run, and the record says what was measured."""
import json

import pytest

from carav_stream.bench.report import zerocopy_rows
from carav_stream.bench.zero_copy import iceoryx2_missing, run_once
from carav_stream.cli import main as carav

pytestmark = pytest.mark.integration


@pytest.mark.parametrize("mode", ["zmq", "shm", "iox"])
def test_each_data_plane_delivers_a_runs_frames(mode):
    if mode == "iox" and iceoryx2_missing():
        pytest.skip(iceoryx2_missing())
    fps, cpu_us, resent = run_once(mode, 262_144, 200, 4)      # returns only once the consumer read all 200
    assert fps > 0 and cpu_us > 0 and resent >= 0


def test_bench_zerocopy_writes_its_record_and_rows(tmp_path):
    out = tmp_path / "zc.json"
    assert carav(["bench", "zerocopy", "--frames", "100", "--repeats", "1", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["command"] == "carav bench zerocopy --frames 100 --repeats 1"
    assert [r["frame"] for r in doc["records"]] == ["table1", "awr1642"]
    for r in doc["records"]:
        assert r["shm"]["ratio_to_zmq"] == pytest.approx(r["shm"]["frames_per_s"] / r["zmq"]["frames_per_s"])
        assert ("iox" in r) == (iceoryx2_missing() is None)
    assert len(zerocopy_rows(doc)) == 4
