"""`python3 dev.py bench gr-bridge`: the pyzmq feeder's messages are the stream GNU Radio's sink would send, and every
case, against pyzmq peers and (where it is installed) GNU Radio's own blocks, moves every item and is recorded and
rendered."""
import argparse
import json
from pathlib import Path

import numpy as np
import pytest

from bench import gr_bridge, report
from carav_stream.capture.gr_stream import layout_of
from carav_stream.capture.gr_zmq import decode
from carav_stream.radar.scene_loader import load_scene

ROOT = Path(__file__).resolve().parents[2]
SCENE = str(ROOT / "tests" / "golden" / "adc_small_iq.toml")       # 4 chirps x 256 I/Q samples: 1024 a cycle


@pytest.mark.parametrize("tagged", [False, True])
def test_the_feeder_s_messages_are_the_stream_in_pieces_with_packet_len_on_every_chirp(tagged):
    lay = layout_of(load_scene(SCENE))
    got = [decode([m], "complex64", tagged=tagged) for m in gr_bridge.stream_messages(lay, 3, tagged, 700)]
    assert [len(m.items) for m in got] == [700] * 4 + [3 * 1024 - 2800]
    stream = np.concatenate([m.items for m in got])
    assert np.array_equal(stream, np.tile(np.arange(1024), 3).astype(np.complex64))
    if tagged:
        assert [m.offset for m in got] == [0, 700, 1400, 2100, 2800]
        assert [(t.offset, t.key, t.value) for m in got for t in m.tags] == [(o, "packet_len", 256)
                                                                             for o in range(0, 3 * 1024, 256)]
    else:
        assert all(m.offset is None and not m.tags for m in got)


@pytest.mark.integration
def test_every_pyzmq_case_moves_every_item_and_is_recorded_and_rendered(tmp_path):
    out = tmp_path / "docs" / "bench" / "records" / "gr_bridge.json"
    out.parent.mkdir(parents=True)
    args = argparse.Namespace(json=out, scene=SCENE, cycles=20, repeats=1, batch=4, message_kb=32, peers=["pyzmq"],
                              argv=["gr-bridge", "--scene", SCENE, "--cycles", "20", "--peers", "pyzmq"])
    assert gr_bridge.run(args) == 0
    doc = json.loads(out.read_text())
    cases = [(r["direction"], r["tagged"], r["items_per_message"]) for r in doc["records"]]
    assert cases == [("raw", False, 1024), ("raw", False, 4096), ("to_gnuradio", False, 1024),
                     ("to_gnuradio", True, 1024), ("from_gnuradio", False, 20 * 1024 / 5),
                     ("from_gnuradio", True, 20 * 1024 / 5)]
    for r in doc["records"]:
        assert r["items_per_s"] > 0 and r["mb_per_s"] == pytest.approx(r["items_per_s"] * 8 / 1e6)
        assert r["direction"] == "raw" or r["ratio_to_raw"] == pytest.approx(r["items_per_s"] / r["raw_items_per_s"])
    (tmp_path / "docs" / "bench" / "gr_bridge.md").write_text(
        f"# G\n\n{report.pages.HEAD_BEGIN}\n{report.pages.HEAD_END}\n\n{report.BEGIN}\n{report.END}\n")
    docs = report.render(tmp_path)
    assert "| carav -> GNU Radio: gr_zmq_sink into a pyzmq PULL, with Pass Tags (" in docs[tmp_path / "BENCHMARKS.md"]
    assert "| from_gnuradio | pyzmq | yes | 4096 |" in docs[tmp_path / "docs" / "bench" / "gr_bridge.md"]


@pytest.mark.integration
@pytest.mark.parametrize("direction", ["to_gnuradio", "from_gnuradio"])
def test_gnu_radio_s_own_blocks_move_every_item_each_way(direction):
    version, why = gr_bridge.gnuradio_version()
    if version is None:
        pytest.skip(f"GNU Radio not importable by {gr_bridge.SYSTEM_PYTHON}: {why}")
    for tagged in (False, True):
        if direction == "to_gnuradio":
            got = gr_bridge.to_gnuradio(SCENE, "gnuradio", tagged, 20, 4)
        else:
            got = gr_bridge.from_gnuradio(SCENE, "gnuradio", tagged, 20, 4, 4096)
        assert got["items"] == 20 * 1024 and got["items_per_s"] > 0 and got["cpu_ns_per_item"] > 0


def test_no_module_of_bench_shadows_gnu_radio_for_the_peer_script():
    """bench/gr_peer.py runs with bench/ first on its path (python3 bench/gr_peer.py): a bench/gnuradio.py would be
    imported in place of GNU Radio."""
    assert [p.name for p in (ROOT / "bench").iterdir() if p.stem in ("gnuradio", "pmt", "zeromq")] == []
