"""The superposition's static moment and shear histories (the jitted sweep of
:func:`vsi_numba.kernels.influence.beam_section_history`, called by
:func:`vsi_numba.solver.results.effect_series`) against the numpy influence lines of
:mod:`vsi_numba.model.influence` summed step by step with ``numpy.bincount``: the same
values bit for bit, loads on supports, at the deck's ends, off the deck and of zero
force included."""

import numpy as np
import pytest

from vsi_numba.kernels.influence import MOMENT, SHEAR, beam_section_history
from vsi_numba.model import influence as inf


def _numpy_history(static, effect, at, x, force):
    n = x.shape[0]
    step, load = np.nonzero((x >= static.supports[0]) & (x <= static.supports[-1])
                            & (force != 0.0))
    line = inf.influences(static, [(effect, at)], x[step, load])[0] * force[step, load]
    return np.stack([np.bincount(step, weights=row, minlength=n) for row in line], axis=1)


@pytest.mark.parametrize("spans", [[20.0], [25.0, 32.0, 25.0], [15.0, 20.0, 18.0, 15.0]])
@pytest.mark.parametrize("effect", ["moment", "shear"])
def test_beam_section_history_is_the_numpy_formula_bit_for_bit(spans, effect):
    static = inf.beam_deck(spans, [2.0e11, 1.5e11, 2.5e11, 1.8e11][:len(spans)])
    sup = static.supports
    rng = np.random.default_rng(7)
    n, n_load = 400, 30
    x = rng.uniform(-5.0, sup[-1] + 5.0, (n, n_load))
    x[:, ::6] = rng.choice(sup, x[:, ::6].shape)  # on the supports and the deck's ends
    force = rng.uniform(-2.0e5, 2.0e5, (n, n_load))
    force[:, 4] = 0.0
    at = np.concatenate([np.linspace(0.0, sup[-1], 41), sup, [-1.0, sup[-1] + 1.0]])
    ref = _numpy_history(static, effect, at, x, force)
    step, load = np.nonzero((x >= sup[0]) & (x <= sup[-1]) & (force != 0.0))
    on, sl, a, b, ms = inf.beam_loads(static, x[step, load])
    sa, X, xi, inside = inf.beam_sections(static, at)
    order = np.flatnonzero(inside)
    order = order[np.argsort(sa[order], kind="stable")]
    span0 = np.searchsorted(sa[order], np.arange(len(spans) + 1))
    got = np.zeros((n, at.size))
    got[:, order] = beam_section_history(
        MOMENT if effect == "moment" else SHEAR, static.spans, span0, X[order], xi[order],
        sl, a, b, ms, step, np.ascontiguousarray(force[step, load]),
        np.zeros((n, order.size)))
    assert np.any(ref != 0.0)
    np.testing.assert_array_equal(got.view(np.int64), ref.view(np.int64))
