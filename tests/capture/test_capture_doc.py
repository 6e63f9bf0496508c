"""docs/CAPTURE.md quotes what its commands print: the profile's scene table and the UDP benchmark's record."""
from __future__ import annotations

import json
import re
from pathlib import Path

from carav_stream.cli import main as carav

ROOT = Path(__file__).resolve().parents[2]
DOC = (ROOT / "docs" / "CAPTURE.md").read_text()


def test_the_scene_figures_in_the_doc_are_those_of_carav_scenes_from_ti_cfg(tmp_path, capsys):
    assert carav(["scenes", "--from-ti-cfg", str(ROOT / "docs/capture/awr1642_tdm.cfg"),
                  "--out", str(tmp_path / "s.toml")]) == 0
    table = dict(line.strip("|").split("|")[:2] for line in capsys.readouterr().out.splitlines()
                 if line.startswith("| ") and line.count("|") == 3)
    table = {k.strip(): v.strip() for k, v in table.items()}
    quoted = {"chirps x samples": "128 x 256 (I/Q)", "sweep / chirp period": "1200 MHz in 60 us / 67 us",
              "sampling window": "51.2 us from 6 us", "slope": "20 MHz/us", "fs": "5 MHz",
              "range resolution": "0.1464 m", "max range": "37.47 m", "unambiguous velocity": "+-14.41 m/s"}
    for key, value in quoted.items():
        assert table[key] == value and value in DOC.replace("\n", " "), key
    assert table["carrier"] == "77.63 GHz" and table["cycle"].startswith("40 ms")


def test_the_udp_figures_come_from_the_benchmark_record_alone():
    """The receiver's figures are rendered from the record into docs/bench/dca1000_udp.md; the guide names the
    command and that page and copies no packet count that could go stale."""
    doc = json.loads((ROOT / "docs/bench/records/dca1000_udp.json").read_text())
    page = (ROOT / "docs/bench/dca1000_udp.md").read_text().replace("\n", " ")
    for r in (r for r in doc["records"] if r["case"] == "receiver"):
        assert f"{r['packets_received']} of {r['packets_sent']} packets, {r['damaged_cycles']} of " in page
        assert f"{r['packets_dropped_by_host']} dropped by this host's kernel" in page
    text = DOC.replace("\n", " ")
    assert "python3 dev.py bench dca1000-udp --json docs/bench/records/dca1000_udp.json" in text
    assert "`docs/bench/dca1000_udp.md`" in text
    assert not re.search(r"\d+ of \d+ packets|\d+ of 9003|packets/s", text)
