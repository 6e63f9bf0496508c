"""A new attacker model is one new file: dropped into a copy of the package's attackers folder, with no other edit,
it shows in `carav blocks attacker` (the model's choices, its summary and its parameter), in the validation of a
graph that uses it (its parameter checked by name), and in `carav attackers`, the table the documents quote.

The copy (carav_stream, and the blocks and graphs as the installed carav_blocks and carav_graphs) goes first on
PYTHONPATH for `python -m carav_stream.cli`; the outputs name the copy's files, which shows that the copy ran."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.integration

MODEL = '''"""Echo tone: answers every chirp of the victim on the air with a tone in the IF band (a test's model)."""
import numpy as np

from carav_stream.core.params import Param
from carav_stream.radar.attackers._base import LiveChirpAttacker, rarms_param


class EchoToneAttacker(LiveChirpAttacker):
    """A tone at `tone_hz` in every chirp on the air, per-sample RMS `rarms`."""

    kind = "echo_tone"
    params = (Param("tone_hz", float, 1e6, "frequency of its tone in the IF band", unit="Hz", low=0.0),
              rarms_param(2.0))

    def response(self, fidelity):
        s = self.scene
        t = np.arange(s.n_samples) / s.fs_hz
        amp = self.rarms * s.sigma_n
        row = amp * np.exp(2j * np.pi * self.tone_hz * t) if s.iq else amp * np.sqrt(2.0) * np.cos(
            2 * np.pi * self.tone_hz * t)
        main = np.repeat(row.astype(self.dtype)[None], s.n_chirps, axis=0)
        main.setflags(write=False)
        return main, None
'''


@pytest.fixture(scope="module")
def tree(tmp_path_factory) -> Path:
    tree = tmp_path_factory.mktemp("tree")
    skip = shutil.ignore_patterns("__pycache__")
    shutil.copytree(ROOT / "carav_stream", tree / "carav_stream", ignore=skip)
    shutil.copytree(ROOT / "blocks", tree / "carav_blocks", ignore=skip)
    shutil.copytree(ROOT / "graphs", tree / "carav_graphs", ignore=skip)
    (tree / "carav_stream" / "radar" / "attackers" / "echo_tone.py").write_text(MODEL)
    return tree


def carav(tree: Path, *argv: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tree), os.environ.get("PYTHONPATH", "")]),
           "COLUMNS": "200"}
    return subprocess.run([sys.executable, "-m", "carav_stream.cli", *argv], cwd=tree, env=env, capture_output=True,
                          text=True, timeout=300)


def test_carav_blocks_attacker_offers_the_new_model_with_its_summary_and_parameter(tree):
    done = carav(tree, "blocks", "attacker")
    assert done.returncode == 0, done.stderr
    out = done.stdout
    assert "(AttackerBlock v" in out and str(tree / "carav_blocks" / "attacker.py") in out
    choices = next(line for line in out.splitlines() if line.strip().startswith("param model "))
    assert "'echo_tone'" in choices
    assert "echo_tone          A tone at `tone_hz` in every chirp on the air, per-sample RMS `rarms`." in out
    tone = next(line for line in out.splitlines() if line.strip().startswith("param tone_hz "))
    assert "frequency of its tone in the IF band (echo_tone) [Hz] (>= 0)" in tone
    rarms = next(line for line in out.splitlines() if line.strip().startswith("param rarms "))
    assert "echo_tone" in rarms


def test_a_graph_using_the_new_model_validates_and_its_parameter_is_checked_by_name(tree):
    good = tree / "echo.toml"
    good.write_text('include = "carav_graphs/radar_chain.toml"\n[blocks]\n'
                    'attacker = { model = "echo_tone", tone_hz = 2e6, rarms = 1.5, start_cycle = 10 }\n')
    done = carav(tree, "validate", str(good))
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f"{good}: ok (")
    bad = tree / "bad_echo.toml"
    bad.write_text('include = "carav_graphs/radar_chain.toml"\n[blocks]\n'
                   'attacker = { model = "echo_tone", tone_hz = -1.0 }\n')
    done = carav(tree, "validate", str(bad))
    assert done.returncode != 0
    assert "bad_echo.toml: blocks.attacker.tone_hz: must be >= 0, got -1" in done.stderr
    done = carav(tree, "validate", "--set", "attacker.max_history_bits=8", str(good))
    assert done.returncode != 0
    assert ("echo.toml: blocks.attacker: attacker 'echo_tone': max_history_bits: unknown parameter for attacker "
            "'echo_tone' (known: n_active_cycles, rarms, start_cycle, tone_hz)") in done.stderr


def test_the_documents_model_table_has_a_row_for_the_new_model(tree):
    done = carav(tree, "attackers")
    assert done.returncode == 0, done.stderr
    assert ("| `echo_tone` | A tone at `tone_hz` in every chirp on the air, per-sample RMS `rarms`. | each chirp on "
            "the air, as it comes | beat or waveform | `tone_hz` = 1e+06 Hz, `rarms` = 2 |") in done.stdout.splitlines()
    rows = [line.split("|")[1].strip() for line in done.stdout.splitlines() if line.startswith("| `")]
    assert rows == ["`none`", *sorted(f"`{p.stem}`" for p in (tree / "carav_stream/radar/attackers").glob("[!_]*.py")
                                      if p.stem != "none")]
