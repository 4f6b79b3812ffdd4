"""Dynamic signatures of trains: the DER and LIR methods of ERRI D214 (EN 1991-2 Annex E).

A train of axle loads F_k at distances x_k behind its first axle crossing a simply
supported span at speed v excites the span's first mode (frequency f0) at the
wavelength lambda = v / f0.  Each axle leaves behind it a free vibration of the span
whose phase is 2 pi x_k / lambda and which decays as exp(-2 pi zeta (x_i - x_k) /
lambda) by the time axle i arrives.  The two methods of ERRI D214 [R] split the peak
response into a factor of the bridge and a factor of the train:

DER (decomposition of the excitation at resonance) ::

    response ~ C  A(L / lambda)  G(lambda)
    A(r)      = | cos(pi r) / (4 r^2 - 1) |                 (pi / 4 at r = 1/2)
    G(lambda) = max_{i = 1..N} | sum_{k <= i} F_k exp(-2 pi zeta (x_i - x_k) / lambda)
                                                  exp(2 pi j x_k / lambda) |

LIR (residual influence line): the same with the free vibration left behind by the
whole train (i = N only) ::

    G_r(lambda) = | sum_{k = 1..N} F_k exp(-2 pi zeta (x_N - x_k) / lambda)
                                         exp(2 pi j x_k / lambda) |

G is the train's *signature* (N), a function of the wavelength and of the damping ratio
only; A the bridge's.  For N equal forces F at a spacing d, every term is in phase at
lambda = d / i (i = 1, 2, ...) and G = F (1 - q^N) / (1 - q), q = exp(-2 pi zeta d /
lambda) (N F undamped): the resonance peaks.

EN 1991-2 Annex E (E.1, E.2 [R]) takes HSLM-A1..A10 as designed to envelope the signatures
of the interoperable trains: a real train whose signature stays under the HSLM-A
envelope over the wavelengths of interest is covered by a design made with HSLM-A
(:func:`compare_with_hslm`).  The clause references and the wavelength range are entries
of the code profile (``signature_*``, :mod:`vsi_numba.code_profile`).

The comparison is pointwise in lambda, the strict reading.  The HSLM-A peaks sit at
lambda = D / i with the coach lengths D = 18, 19, ..., 27 m of A1..A10; between two of
them (8.0 and 8.33 m at i = 3, A7 and A8) the envelope dips, and a real train whose
coach length falls between (the ICE3: 24.775 m, its i = 3 peak at 8.26 m) can rise
above it there (ratio 1.57 at 1 % damping, lambda = 8.19 m).  A design with HSLM-A
sweeps the speeds: the HSLM-A peak a few per cent of speed away gives nearly the same
A(L / lambda) G.  :attr:`Coverage.shift` states how far the envelope is from covering
the train (the wavelength, i.e. speed, change to an envelope value that reaches the
train's): above the envelope means "not shown covered by the signature route"; the
dynamic analysis with the train decides.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vsi_numba.code_profile import CodeProfile, resolve

#: The HSLM-A trains (EN 1991-2 Table E.1 [R]).
HSLM_A = tuple(f"HSLM-A{i}" for i in range(1, 11))
#: Clause the signatures implement (recalled).
SIGNATURE_CLAUSE = "ERRI D214 RP9 (DER, LIR methods); EN 1991-2 Annex E"


def train_axles(train) -> tuple[np.ndarray, np.ndarray]:
    """Static axle positions (m behind the first axle, ascending) and whole-axle loads (N)
    of a :class:`~vsi_numba.model.vehicle.Train` (moving forces or interaction vehicles:
    the static loads on rigid level track).  Coincident axles are merged."""
    from vsi_numba.model.library import moving_force_train

    t = train
    if any(v.n_dof for v in t.vehicles):
        t = moving_force_train(train)
    pos = np.concatenate([o + v.load_positions for v, o in zip(t.vehicles, t.offsets,
                                                                strict=True)])
    load = np.concatenate([np.asarray(v.loads, float) for v in t.vehicles])
    order = np.argsort(pos, kind="stable")
    pos, load = pos[order], load[order]
    pos = pos - pos[0]
    # merge coincident axles (articulations listed twice): one force per position
    keys = np.round(pos, 9)
    uniq, inv = np.unique(keys, return_inverse=True)
    return uniq.astype(float), np.bincount(inv, weights=load)


def train_by_name(name: str):
    """A train of the library (moving forces) by name: ``HSLM-A1`` .. ``HSLM-A10``, the
    real trains, and the EN 1991-2 Annex D types ``AnnexD-1`` .. ``AnnexD-12``."""
    from vsi_numba.model.library import annex_d, get_train

    if annex_d.type_of(name) is not None:
        return annex_d.annex_d_train(name)
    return get_train(name, "moving_force")


def der_signature(positions, loads, wavelengths, damping: float = 0.0) -> np.ndarray:
    """DER signature G(lambda) (N) of a train; see the module notes.

    Parameters
    ----------
    positions : array_like, shape (n_axle,)
        Axle distances behind the first axle (m), ascending.
    loads : array_like, shape (n_axle,)
        Whole-axle loads (N).
    wavelengths : array_like, shape (n_lambda,)
        Wavelengths lambda = v / f0 (m, > 0).
    damping : float
        Damping ratio zeta (fraction, >= 0).

    Returns
    -------
    ndarray, shape (n_lambda,)
    """
    return _partial_sums(positions, loads, wavelengths, damping).max(axis=0)


def lir_signature(positions, loads, wavelengths, damping: float = 0.0) -> np.ndarray:
    """LIR signature G_r(lambda) (N): the residual vibration after the last axle."""
    return _partial_sums(positions, loads, wavelengths, damping)[-1]


def _partial_sums(positions, loads, wavelengths, damping) -> np.ndarray:
    """|S_i(lambda)| for every axle i, shape (n_axle, n_lambda), by the recurrence
    S_i = S_{i-1} exp(-2 pi zeta (x_i - x_{i-1}) / lambda) + F_i exp(2 pi j x_i / lambda)."""
    x = np.asarray(positions, float)
    f = np.asarray(loads, float)
    lam = np.atleast_1d(np.asarray(wavelengths, float))
    if x.shape != f.shape or x.ndim != 1 or x.size == 0:
        raise ValueError("positions and loads: expected two 1-D arrays of the same length")
    if np.any(np.diff(x) < 0):
        raise ValueError("positions: expected ascending axle positions")
    if not np.all(lam > 0):
        raise ValueError("wavelengths: expected values > 0 m")
    if not damping >= 0:
        raise ValueError(f"damping = {damping!r}: expected a ratio >= 0")
    out = np.empty((x.size, lam.size))
    s = np.zeros(lam.size, complex)
    prev = x[0]
    for i in range(x.size):
        s = s * np.exp(-2 * np.pi * damping * (x[i] - prev) / lam) + f[i] * np.exp(
            2j * np.pi * x[i] / lam)
        out[i] = np.abs(s)
        prev = x[i]
    return out


def influence_factor(span: float, wavelengths) -> np.ndarray:
    """DER influence factor A(L / lambda) = |cos(pi r) / (4 r^2 - 1)| of a simply
    supported span (pi / 4 at r = 1/2, its limit)."""
    r = np.asarray(span / np.asarray(wavelengths, float), float)
    den = 4 * r * r - 1
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.abs(np.cos(np.pi * r) / den)
    return np.where(np.abs(den) < 1e-9, np.pi / 4, a)


def wavelength_grid(profile: CodeProfile | None = None, n: int = 2000) -> np.ndarray:
    """The wavelengths of the comparison (m): ``n`` values from the profile's
    ``signature_wavelength_min`` to ``signature_wavelength_max``."""
    p = resolve(profile)
    return np.linspace(p["signature_wavelength_min"], p["signature_wavelength_max"], n)


@dataclass(frozen=True)
class Signature:
    """A train's signatures on a wavelength grid."""

    name: str
    wavelength: np.ndarray  # m
    der: np.ndarray  # N
    lir: np.ndarray  # N
    damping: float


def signature(train, damping: float, wavelengths=None, profile=None) -> Signature:
    """DER and LIR signatures of ``train`` (a Train or a library name)."""
    t = train_by_name(train) if isinstance(train, str) else train
    lam = wavelength_grid(profile) if wavelengths is None else np.asarray(wavelengths, float)
    x, f = train_axles(t)
    return Signature(t.name, lam, der_signature(x, f, lam, damping),
                     lir_signature(x, f, lam, damping), float(damping))


@dataclass(frozen=True)
class Coverage:
    """A train's DER signature against the HSLM-A envelope."""

    train: Signature
    envelope: np.ndarray  # N, max over HSLM-A1..A10 at each wavelength
    governing: np.ndarray  # which HSLM-A gives the envelope (name per wavelength)
    ratio: float  # max over the wavelengths of train / envelope
    wavelength_at_ratio: float  # m
    covered: bool  # ratio <= the profile's signature_ratio_limit
    #: the largest, over the wavelengths where the train is above the envelope, relative
    #: wavelength (= speed) change to the nearest wavelength whose envelope reaches the
    #: train's signature there (0 when covered; inf when none on the grid)
    shift: float = 0.0

    @property
    def margin(self) -> float:
        """1 - ratio (positive: covered with that fraction to spare)."""
        return 1.0 - self.ratio


def hslm_envelope(wavelengths, damping: float) -> tuple[np.ndarray, np.ndarray]:
    """Envelope (max) of the DER signatures of HSLM-A1..A10 and the governing name."""
    sig = np.stack([der_signature(*train_axles(train_by_name(n)), wavelengths, damping)
                    for n in HSLM_A])
    k = np.argmax(sig, axis=0)
    return sig.max(axis=0), np.asarray(HSLM_A)[k]


def compare_with_hslm(train, damping: float, wavelengths=None, profile=None) -> Coverage:
    """Is ``train`` covered by HSLM-A?  Its DER signature against the HSLM-A envelope
    over the profile's wavelength range (EN 1991-2 Annex E [R]); covered when the ratio
    stays at or below ``signature_ratio_limit`` (1)."""
    p = resolve(profile)
    sig = signature(train, damping, wavelengths, p)
    env, gov = hslm_envelope(sig.wavelength, damping)
    limit = p["signature_ratio_limit"]
    r = sig.der / env
    i = int(np.argmax(r))
    return Coverage(sig, env, gov, float(r[i]), float(sig.wavelength[i]),
                    bool(r[i] <= limit), _shift(sig.wavelength, sig.der, env * limit))


def _shift(lam, der, env) -> float:
    """The largest over the wavelengths where ``der > env`` of the relative distance
    |lambda_j / lambda_i - 1| to the nearest j with ``env[j] >= der[i]``."""
    worst = 0.0
    for i in np.flatnonzero(der > env):
        ok = np.flatnonzero(env >= der[i])
        if ok.size == 0:
            return float("inf")
        worst = max(worst, float(np.min(np.abs(lam[ok] / lam[i] - 1.0))))
    return worst


def plot_signature(cov_or_sig, path, title: str | None = None) -> None:
    """Draw a signature (and the HSLM-A envelope when given a :class:`Coverage`) to PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vsi_numba.analysis.figure_file import save_figure

    sig = cov_or_sig.train if isinstance(cov_or_sig, Coverage) else cov_or_sig
    fig, ax = plt.subplots(figsize=(8, 4.2), dpi=110)
    if isinstance(cov_or_sig, Coverage):
        ax.fill_between(sig.wavelength, 0, cov_or_sig.envelope / 1e3, color="0.85",
                        label="HSLM-A1..A10 envelope (DER)")
    ax.plot(sig.wavelength, sig.der / 1e3, color="C0", lw=1.2, label=f"{sig.name}: DER G")
    ax.plot(sig.wavelength, sig.lir / 1e3, color="C1", lw=0.9, ls="--",
            label=f"{sig.name}: LIR G_r")
    ax.set_xlabel("wavelength lambda = v / f0 (m)")
    ax.set_ylabel("signature (kN)")
    ax.set_xlim(sig.wavelength[0], sig.wavelength[-1])
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    head = title or f"Dynamic signature of {sig.name}, damping {100 * sig.damping:g} %"
    if isinstance(cov_or_sig, Coverage):
        c = cov_or_sig
        head += (f"\n{'covered' if c.covered else 'NOT covered'} by HSLM-A: max ratio "
                 f"{c.ratio:.2f} at lambda = {c.wavelength_at_ratio:.2f} m")
    ax.set_title(head, fontsize=10)
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    try:
        save_figure(fig, path)
    finally:
        plt.close(fig)
