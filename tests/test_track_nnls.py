"""The track element's NNLS fit through scipy's compiled routine without importing
scipy.optimize (vsi_numba.model.track.nnls): the same bits as scipy.optimize.nnls."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def test_fit_element_without_scipy_optimize_is_scipys_fit_bit_for_bit():
    script = textwrap.dedent("""
        import sys
        import numpy as np
        from vsi_numba.model import track
        got = track.fit_element(8.5e7, 1.28e7, 1.2e5, 120.0)
        assert "scipy.optimize" not in sys.modules, "scipy.optimize imported"
        import scipy.optimize
        assert hasattr(scipy.optimize, "_slsqplib")  # scipy's own import is whole
        band = track.FIT_BAND_HZ
        k, ei, c, m = 8.5e7, 1.28e7, 1.2e5, 120.0
        w = 2.0 * np.pi * band * np.arange(1, track.FIT_POINTS + 1) / track.FIT_POINTS
        kw = k + 1j * w * c - w**2 * m
        G = (kw / (4.0 * ei)) ** 0.25 / (2.0 * kw)
        K0 = 2.0 * k / (k / (4.0 * ei)) ** 0.25
        wb = 2.0 * np.pi * band
        A = np.column_stack([np.ones_like(w), 1j * w / wb, -((w / wb) ** 2)]) * (K0 * G)[:, None]
        p, _ = scipy.optimize.nnls(np.vstack([A.real, A.imag]),
                                   np.concatenate([np.ones_like(w), np.zeros_like(w)]))
        want = (float(p[0] * K0), float(p[1] * K0 / wb), float(p[2] * K0 / wb**2))
        assert got == want, (got, want)
        print("ok")
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"}, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"


def test_nnls_equals_scipy_on_random_problems():
    import scipy.optimize

    from vsi_numba.model import track

    rng = np.random.default_rng(7)
    for _ in range(200):
        A = rng.normal(size=(int(rng.integers(3, 40)), int(rng.integers(1, 6))))
        b = rng.normal(size=A.shape[0])
        x, r = track.nnls(A, b)
        x0, r0 = scipy.optimize.nnls(A, b)
        assert np.array_equal(x, x0) and r == r0
        assert np.all(x >= 0.0)
