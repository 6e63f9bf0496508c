"""CSV sink: one row per cycle, for spreadsheets and plotting scripts.

Expands frames that carry several cycles (per_cycle fields) into one row each; a column takes the cycle's
per-cycle value, else the frame's header value, else stays empty. A list value (one range per target, say)
is written as its items joined by ";".

    cycle,port,attack_active,reason,q,range_m,velocity_mps
    150,alarms,True,attack,2.91,,
    151,estimates,False,,0.42,43.0012,-26.6701

A restarted sink (or one swapped in) appends rows without a second header line: only the sink a run starts with
creates or truncates the file, so a restart never erases what was written; each frame's rows leave for the
file before the next frame is taken.

Ports   in  estimates   any    frames to record (main stream), written with port "estimates"
        in  alarms      any    optional second stream, written with port "alarms"
Graph   csv = { type = "csv_sink", path = "cycles.csv" }
"""
import csv
import sys

from carav_stream.runtime import Block, Frame, In, Param, cycle_indices, per_cycle, writing

DEFAULT_COLUMNS = ["attack_active", "reason", "q", "range_m", "velocity_mps"]


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, list):
        return ";".join(_cell(v) for v in value)
    return str(value)


class CsvSink(Block):
    inputs = (In("estimates", doc="frames to record"), In("alarms", doc="optional second stream", required=False))
    merge_inputs = True
    params = (Param("path", str, doc="output file, or - for stdout", output=True),
              Param("columns", list, DEFAULT_COLUMNS, "columns after cycle and port"))

    def check_params(self) -> None:
        if not all(isinstance(c, str) and c for c in self.columns):
            raise ValueError(f"columns must be a list of names, got {self.columns!r}")

    def start(self) -> None:
        first = self.instance == (0, 0)              # the run's own sink, not a restarted or swapped-in one
        with writing(self.path):
            self.fh = sys.stdout if self.path == "-" else open(self.path, "w" if first else "a", newline="")
            self.writer = csv.writer(self.fh)
            if first:
                self.writer.writerow(["cycle", "port", *self.columns])
        self.rows = self.malformed = 0

    def process(self, estimates: Frame | None, alarms: Frame | None = None) -> None:
        port, frame = ("estimates", estimates) if estimates is not None else ("alarms", alarms)
        try:
            per, cycles = per_cycle(frame), cycle_indices(frame)
        except ValueError:   # per-cycle fields out of step with the cycles: one row from the header alone
            per, cycles = {}, [frame.cycle]
            self.malformed += 1
        with writing(self.path):
            for i, cycle in enumerate(cycles):
                self.writer.writerow([cycle, port, *(_cell(per[c][i] if c in per else frame.header.get(c))
                                                     for c in self.columns)])
            self.fh.flush()              # written, not buffered: a SIGKILL loses no row of a frame counted in
        self.rows += len(cycles)

    def finish(self) -> None:
        with writing(self.path):
            self.fh.flush()
            if self.fh is not sys.stdout:
                self.fh.close()

    def summary(self) -> dict:
        return {"rows": self.rows, "malformed_frames": self.malformed}
