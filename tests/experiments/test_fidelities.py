"""`carav experiment fidelities`: the two fidelities agree away from the IF filter's transition band and split at the
range edge and for loud echoes, in the detector's units and in the estimator's."""
import numpy as np

from carav_stream.cli import main as carav
from carav_stream.experiments.fidelities import moved, range_errors, slot_differences
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.scene_loader import load_scene


def _rho(scene):
    return balanced_rows(np.random.default_rng(5), 1, scene.n_chirps)[0]


def test_the_fidelities_agree_in_the_detectors_units_up_to_nine_tenths_of_the_range_and_split_at_the_edge():
    base = load_scene("table1")
    for fraction in (0.5, 0.8, 0.9):
        assert max(slot_differences(moved(base, fraction, 0.0), _rho(base))) < 0.1
    d0, _ = slot_differences(moved(base, 0.99, 0.0), _rho(base))
    assert d0 > 2.0                                  # the spill through the transition band, in the silent slots
    loud_d0, _ = slot_differences(moved(base, 0.95, 20.0), _rho(base))
    assert loud_d0 > 10.0


def test_awr1642s_walking_car_differs_in_the_active_slots_only():
    base = load_scene("awr1642")
    near = slot_differences(moved(base, 0.5, 20.0), _rho(base))
    edge = slot_differences(moved(base, 0.99, 20.0), _rho(base))
    assert near[0] == edge[0] == 0.0                 # its spill beats near -2 GHz: nothing in a silent slot
    assert 1.0 < near[1] < 10.0 < 100.0 < edge[1]


def test_the_estimates_agree_away_from_the_band_edge_and_the_waveform_fidelity_departs_at_it():
    base = load_scene("table1")
    beat, wave, diff = range_errors(moved(base, 0.5, 0.0), 60, 5)
    assert diff < 0.05 and abs(beat - wave) < 0.05
    beat, wave, diff = range_errors(moved(base, 0.99, 0.0), 60, 5)
    assert beat < 1.5 and wave > 5.0 and diff > 5.0


def test_the_command_prints_one_row_per_preset_echo_and_range(capsys):
    assert carav(["experiment", "fidelities", "--units", "detector"]) == 0
    rows = [r.split() for r in capsys.readouterr().out.splitlines() if r.startswith(("table1 ", "awr1642 "))]
    assert len(rows) == 2 * 2 * 6 and all(len(r) == 8 for r in rows)
