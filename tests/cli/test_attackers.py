"""`carav attackers`: one row per model of the registry, with what it hears, its fidelity and its own parameters."""
from __future__ import annotations

from carav_stream.cli import main as carav
from carav_stream.console.errors import Exit
from carav_stream.radar.attackers import KINDS


def _rows(out: str) -> dict[str, list[str]]:
    lines = [line for line in out.splitlines() if line.startswith("| `")]
    return {cells[0].strip("`"): cells[1:] for cells in ([c.strip() for c in line.strip("|").split("|")]
                                                        for line in lines)}


def test_every_model_has_a_row_in_registry_order_with_its_own_parameters_and_defaults(capsys):
    assert carav(["attackers"]) == Exit.OK
    out = capsys.readouterr().out
    rows = _rows(out)
    assert list(rows) == list(KINDS)
    assert rows["none"] == ["No attack: nothing on the air.", "nothing", "beat or waveform", "-"]
    assert rows["reactive"][1:3] == ["each chirp on the air, as it comes", "beat or waveform"]
    assert rows["lfsr_predictor"][1] == "past cycles' emission"
    assert rows["secondary_antenna"][2] == "waveform"
    assert rows["ghost"][3] == "`range_m` = 30 m, `velocity_mps` = 0 m/s, `rarms` = 3"
    for kind, cls in KINDS.items():
        assert [part.split(" = ")[0].strip("`") for part in rows[kind][3].split(", ")] == (
            [p.name for p in cls.params] or ["-"])
    assert out.endswith("Every model also takes `start_cycle` = 0 cycles: first cycle the attacker is on; "
                        "`n_active_cycles` = none: cycles it stays on (none: until the end).\n")


def test_brief_leaves_the_parameters_out(capsys):
    assert carav(["attackers", "--brief"]) == Exit.OK
    rows = _rows(capsys.readouterr().out)
    assert list(rows) == list(KINDS) and {len(cells) for cells in rows.values()} == {3}
