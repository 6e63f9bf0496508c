"""range_estimator with detection = "ca_cfar": a variable-length target list per cycle through the codec."""
import numpy as np

from carav_blocks.range_estimator import RangeEstimator
from carav_stream.montecarlo.engine import balanced_rows
from carav_stream.radar.adc import adc_codes
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import simulate_cycles
from carav_stream.runtime import Frame
from tests.blocks.helpers import wire


def test_the_cfar_list_of_every_clean_cycle_names_the_car_with_its_snr():
    scene = load_scene("table1")
    rng = np.random.default_rng(3)
    rho = balanced_rows(rng, 6, scene.n_chirps)
    codes, _, _ = adc_codes(scene, simulate_cycles(scene, rho, rng).frames)
    block = RangeEstimator(scene="table1", detection="ca_cfar", pfa=1e-6)
    block.start()
    frame = Frame.of(codes, cycles=6, verdict="clean", per_cycle={"attack_active": [False] * 6})
    out = block.process(wire(frame.derive(keep_data=True, arrays={"rho": rho}), 0))
    per = out.header["per_cycle"]
    assert out.header["detection"] == "ca_cfar" and out.header["pfa"] == 1e-6
    for ranges, speeds, snrs in zip(per["range_m"], per["velocity_mps"], per["snr_db"]):
        assert len(ranges) == len(speeds) == len(snrs) >= 1
        assert abs(ranges[0] - 43.0) < 0.1 and abs(speeds[0] - scene.range_rate_mps(scene.targets[0])) < 0.5
        assert snrs[0] > 20
