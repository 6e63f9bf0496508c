"""graphs/awr1642_mimo.toml as real processes: a 2 TX x 4 RX TDM-MIMO radar under a secondary antenna at 30 degrees.

The graph runs end to end and catches the attack; the same chain, tapped, equals the in-process library bit for bit
(frames of four receivers over both data planes, activation per TDM loop, the detector's RMS over all receivers,
ranging on one virtual element)."""
import json

import pytest

from carav_stream.firmware.algorithm1 import run_algorithm1
from carav_stream.radar.streams import scene_of
from carav_stream.runtime.graph import TRANSPORTS
from tests.integration.conftest import ROOT
from tests.integration.test_radar_pipeline import TAPS, assert_data_plane, assert_equals_the_library

pytestmark = pytest.mark.integration

GRAPH = ROOT / "graphs" / "awr1642_mimo.toml"


def test_the_mimo_graph_runs_end_to_end_and_catches_the_secondary_antenna(carav):
    out = carav.workdir / "s.json"
    done = carav.cli("run", str(GRAPH), "--cycles", "64", "--no-progress", "--json", str(out))
    assert done.returncode == 0, done.stderr
    s = json.loads(out.read_text())
    assert s["lost"] == 0 and s["cycles"] == 64 and s["cycles_judged"] == 64
    assert s["attacked_cycles"] == 32 and s["detected"] == 32


@pytest.mark.parametrize("carav", TRANSPORTS, indirect=True)
def test_the_tapped_mimo_chain_equals_the_in_process_library_bit_for_bit(carav):
    n = 40
    params = {"range_m": 30.0, "tx_power_w": 1e-2, "start_cycle": 24, "azimuth_deg": 30.0}
    sets = ["scene=awr1642_mimo", "seed=23", "fidelity=waveform", "batch=16", "attacker.model=secondary_antenna",
            *(f"attacker.{k}={v}" for k, v in params.items())]
    run = carav.run(TAPS / "radar_taps.toml", "--cycles", str(n), *sum((["--set", s] for s in sets), []))
    assert run.wait() == 0, run.stderr()
    lib = run_algorithm1(scene_of("awr1642_mimo"), n, seed=23, attack="secondary_antenna", attack_params=params,
                         fidelity="waveform", batch=16)
    s = assert_equals_the_library(carav, run, lib, n)
    assert s["attacked_cycles"] == 16 and s["detected"] == int(lib.alarm[24:].sum()) == 16
    assert_data_plane(carav, s)
