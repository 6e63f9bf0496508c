"""What an estimation method is: the one Method subclass of a file of this package, named after the file.

From the strongest cell (l0, k0) of a cycle's range-Doppler map (estimators._grid), `locate` gives sub-bin
frequencies and the magnitude there; `refine`, where a method has one, refines them on the samples. `refine_at`
starts from cells listed elsewhere: `_grid.start` with `start_pad` (unless None: the cell is kept), then `refine`.
"""
from __future__ import annotations

from carav_stream.estimate.estimators import _grid


class Method:
    """An estimation method. Subclasses set what differs from the interpolated start without refinement:

    order        place in METHODS, the order of every list and table that names all the methods
    range_words, velocity_words   how it reads the range (beat) and the velocity, in words (`carav estimators`
                 prints them as the table docs/ESTIMATION.md quotes)
    start_pad    Doppler zero padding of the interpolated start (_grid.start); None: no start, the cell is kept
    padding      (range, Doppler) zero-padding factors of the map's FFTs
    locate       sub-bin (f, nu, |RD|) at the strongest cells
    refine       None, or refine(x, chirps, f, nu, *, n_newton, music_length, iq, onset) -> (f, nu, amp), each
                 (C, K): f [cycles/sample], nu [cycles/chirp], amp the positive-frequency tone amplitude per sample
                 of the echo (normalised units), from the compacted active chirps x (C, A, N), the cells' (f, nu)
                 (C, K) and the samples (C, K) where the targets' echoes start (_onset; None: at the window's start)
    """

    order: int
    range_words: str
    velocity_words: str
    start_pad: int | None = 8
    refine = None

    def __init__(self, name: str):
        self.name = name

    def __repr__(self) -> str:
        return f"<estimation method {self.name}>"

    def padding(self, zeropad: int) -> tuple[int, int]:
        """Zero-padding factors (range, Doppler) of the map's fast- and slow-time FFTs; `zeropad` is estimate's."""
        return 1, 1

    def locate(self, spec, chirps, l0, k0, n_samp: int, nr: int, md: int):
        """(f [cycles/sample], nu [cycles/chirp], |RD| there), each (C, K), of the targets at the cells (l0, k0)
        (C, K) of the map of the compacted range spectra spec (C, A, nb): range FFT length nr over n_samp
        samples, Doppler FFT length md."""
        return _grid.start(spec, chirps, k0, l0, n_samp, self.start_pad)
