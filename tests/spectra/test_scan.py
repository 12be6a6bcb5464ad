"""The scan assembly's background where the pinhole frames leave pixels never free."""

import numpy as np

from sassi_bench.spectra.scan import _mean_background


def test_pixels_never_free_take_the_closed_frame_plus_the_pinhole_frames_smooth_excess():
    rows, cols = np.mgrid[0:64, 0:96]
    leak = 1000.0 + 300.0 * (cols % 7 == 0)  # structure no smooth fill can follow
    stray = 20.0 + 0.5 * rows + 0.25 * cols  # light only the pinhole frames carry
    count = np.where((cols >= 40) & (cols < 64), 0, 12)
    total = count * (leak + stray)
    never = count == 0

    background = _mean_background(total, count, closed=leak)
    # The excess is filled as block medians are (1 ADU off across a 24-column hole).
    assert np.abs(background - (leak + stray))[never].max() < 2e-3 * leak.max()
    assert np.array_equal(background[~never], (leak + stray)[~never])
    # Without the closed frame the fill misses the structure by its whole height.
    filled = _mean_background(total, count)
    assert np.abs(filled - (leak + stray))[never].max() > 100.0
