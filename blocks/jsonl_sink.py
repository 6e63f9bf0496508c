"""JSON-lines sink: one line per frame with its header (and small payloads), for logs and tests.

    line = {"port": input port, **header, "data": payload as a list if it has at most `max_values` values}

A larger payload is left out: the line holds its header only.

A restarted sink (or one swapped in) appends to the file: only the sink a run starts with creates or truncates
it, so a restart never erases what was written (each line is written whole as it comes: line buffering).

Ports   in  inp      any    frames to record (main stream)
        in  extra    any    optional second stream (e.g. alarms), recorded with "port": "extra"
Graph   log = { type = "jsonl_sink", path = "run.jsonl" }
"""
import json
import sys

import numpy as np

from carav_stream.runtime import Block, Frame, In, Param, writing


class JsonlSink(Block):
    inputs = (In("inp", doc="frames to record"), In("extra", doc="optional second stream", required=False))
    merge_inputs = True
    params = (Param("path", str, doc="output file, or - for stdout", output=True),
              Param("max_values", int, 16, "largest payload written in full", low=0))

    def start(self) -> None:
        first = self.instance == (0, 0)              # the run's own sink, not a restarted or swapped-in one
        with writing(self.path):
            self.fh = sys.stdout if self.path == "-" else open(self.path, "w" if first else "a", buffering=1)
        self.n = 0

    def _write(self, port: str, frame: Frame) -> None:
        line = {"port": port, **frame.header}
        data = frame.payload
        if data is not None and data.size <= self.max_values:
            line["data"] = (data.view(np.float32 if data.dtype == np.complex64 else np.float64).tolist()
                            if np.iscomplexobj(data) else data.tolist())
        with writing(self.path):
            self.fh.write(json.dumps(line, default=str) + "\n")
        self.n += 1

    def process(self, inp: Frame | None, extra: Frame | None = None) -> None:
        for port, frame in (("inp", inp), ("extra", extra)):
            if frame is not None:
                self._write(port, frame)

    def finish(self) -> None:
        with writing(self.path):
            self.fh.flush()
            if self.fh is not sys.stdout:
                self.fh.close()

    def summary(self) -> dict:
        return {"lines": self.n}
