"""The physics of a block of revolutions computed with fewer passes and imports (issue 27, item 4)
gives the numbers of the straightforward code, bit for bit: the recording's bytes depend on it.

Each fast path is checked against the plain form it replaces (kept here as the reference), on
random inputs and on the edges (empty arrays, every regime of [91]-[93], angles on the wrap).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from shipradar.sensors import doppler_filters as df

ROOT = Path(__file__).resolve().parents[1]


def _same_bits(a, b) -> None:
    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype == b.dtype and a.shape == b.shape
    assert a.tobytes() == b.tobytes()


@pytest.mark.parametrize("sidelobe_db", [45.0, 50.0, 57.3, 80.0, 100.0, 150.0, 300.0])
def test_chebyshev_window_is_scipys_bit_for_bit(sidelobe_db):
    from scipy.signal import windows

    for n_taps in range(1, 130):
        _same_bits(df.window_weights("chebyshev", n_taps, sidelobe_db=sidelobe_db),
                   windows.chebwin(n_taps, at=sidelobe_db, sym=True))


def test_chebyshev_window_below_45_db_is_still_scipys():
    # scipy warns below 45 dB: that level still goes to scipy (and its warning)
    from scipy.signal import windows

    with pytest.warns(UserWarning):
        got = df.window_weights("chebyshev", 16, sidelobe_db=30.0)
    with pytest.warns(UserWarning):
        _same_bits(got, windows.chebwin(16, at=30.0, sym=True))


def test_shipped_windows_do_not_import_scipy_signal():
    # scipy.signal's import (0.3-0.45 s) fell inside the stress scene's loop, at its first
    # steep I_F cell; the shipped scenes' Chebyshev and rectangular windows no longer need it
    code = ("import sys; from shipradar.sensors import doppler_filters as df; "
            "df.bank_weights(8, window='chebyshev', sidelobe_db=50.0); "
            "df.bank_weights(7, window='rectangular'); "
            "print(sorted(m for m in sys.modules if m.startswith('scipy.signal')))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip().splitlines()[-1] == "[]"
