"""CSV sink: one row per cycle, per-cycle fields before header fields, malformed frames counted."""
from carav_blocks.csv_sink import CsvSink
from carav_stream.runtime import Frame
from tests.blocks.helpers import wire


def test_csv_sink_writes_one_row_per_cycle_from_per_cycle_and_header_fields(tmp_path):
    sink = CsvSink(path=str(tmp_path / "c.csv"), columns=["attack_active", "reason", "range_m", "method"])
    sink.start()
    est = wire(Frame.of(None, cycles=2, method="ml", per_cycle={"cycle_index": [4, 6], "attack_active": [False, True],
                                                                 "range_m": [[43.0], [None]]}), 1)
    alarm = wire(Frame.of(None, cycles=1, per_cycle={"cycle_index": [5], "reason": ["attack"]}), 1)
    bad = wire(Frame.of(None, cycles=2, per_cycle={"reason": ["attack"]}), 2)   # one value for two cycles
    sink.process(est)
    sink.process(None, alarm)
    sink.process(None, bad)
    sink.finish()
    assert (tmp_path / "c.csv").read_text().splitlines() == [
        "cycle,port,attack_active,reason,range_m,method", "4,estimates,False,,43.0,ml", "6,estimates,True,,,ml",
        "5,alarms,,attack,,", "2,alarms,,,,"]
    assert sink.summary() == {"rows": 4, "malformed_frames": 1}
