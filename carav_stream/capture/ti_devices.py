"""TI radars whose mmWave CLI profiles carav scenes --from-ti-cfg reads: each one's antenna layout and LVDS lanes.

A profile names transmitters and receivers by bit (channelCfg's txChannelEn and rxChannelEn, chirpCfg's txEnable),
not by where they sit: the positions come from the evaluation board's layout, a key of the scene loader's
ARRAY_LAYOUTS (azimuth positions in wavelengths: TX1, TX2, ... and RX1..RX4). The xWR16xx boards carry two
transmitters two wavelengths apart; the xWR12xx/14xx/18xx/68xx boards three, as the AWR1243 BoosterPack's (TX2
between TX1 and TX3, raised half a wavelength: its azimuth offset only). The lanes are the DCA1000 capture's
(carav_stream/capture/dca1000.py): 2 for xWR16xx/18xx/68xx, 4 for xWR12xx/14xx.
"""
from __future__ import annotations

from dataclasses import dataclass

from carav_stream.radar.scene_loader import ARRAY_LAYOUTS


@dataclass(frozen=True)
class Device:
    """A TI radar whose profile this reads: its antenna layout (a key of ARRAY_LAYOUTS) and its LVDS lanes."""

    name: str
    family: str
    layout: str
    lanes: int

    @property
    def tx_positions_wl(self) -> tuple[float, ...]:
        return ARRAY_LAYOUTS[self.layout][0]

    @property
    def rx_positions_wl(self) -> tuple[float, ...]:
        return ARRAY_LAYOUTS[self.layout][1]


DEVICES = {d.name: d for d in (
    Device("awr1642", "xWR16xx", "awr1642", 2), Device("iwr1642", "xWR16xx", "awr1642", 2),
    Device("awr1243", "xWR12xx", "awr1243", 4), Device("awr1443", "xWR14xx", "awr1243", 4),
    Device("iwr1443", "xWR14xx", "awr1243", 4), Device("awr1843", "xWR18xx", "awr1243", 2),
    Device("iwr1843", "xWR18xx", "awr1243", 2), Device("awr6843", "xWR68xx", "awr1243", 2),
    Device("iwr6843", "xWR68xx", "awr1243", 2))}
# Assumed when the profile enables TX1, TX2 at most, and when it enables TX3 (2 lanes either way, as the DCA1000
# blocks' default).
DEFAULT_DEVICE, DEFAULT_DEVICE_3TX = "awr1642", "iwr6843"
