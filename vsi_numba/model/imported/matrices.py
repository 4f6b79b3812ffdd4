"""FE matrices (``bridge.kind = "matrices"``): K and M in Matrix Market files, reduced
to the lowest modes along a track line (shift-invert eigensolver), see
:mod:`vsi_numba.model.imported`."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.io
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

from vsi_numba.model import bridge as _br
from vsi_numba.model.imported.common import (
    LOW_FREQUENCY_HZ,
    MAX_MODES,
    NORMALISATION_TOL,
    RIGID_BODY_HZ,
    SIGMA,
    SYMMETRY_TOL,
    ImportResult,
    _check_stations,
    _damping,
    _flip_positive,
    _fmt_x,
    _keep,
    _Problems,
    _spline_slopes,
    _supports_from,
)
from vsi_numba.model.influence import StaticDeck

# ------------------------------------------------------------------------------ matrices


def _mtx_header_problem(path: Path) -> str | None:
    """Why the sizes in the header of a Matrix Market file cannot be its content, read
    before anything is allocated (``scipy.io.mminfo``): an 80-byte file that announces
    10^5 x 10^5 values made ``mmread`` allocate gigabytes before it failed.  Every value
    (array) or entry (coordinate) takes at least 2 or 4 bytes of the file, and a matrix
    of n DOFs needs about n entries."""
    try:
        rows, cols, entries, fmt, _field, _symmetry = scipy.io.mminfo(str(path))
        size = path.stat().st_size
    except Exception as exc:  # noqa: BLE001 - mmread says why below
        return f"unreadable header: {type(exc).__name__}: {' '.join(str(exc).split())[:120]}"
    rows, cols, entries = int(rows), int(cols), int(entries)
    if rows != cols:
        return f"the header says {rows:,} x {cols:,}: not square"
    if fmt == "array" and 2 * rows * cols > size:
        return (f"the header says a dense {rows:,} x {cols:,} array, {rows * cols:,} values, "
                f"but the file has only {size:,} bytes")
    if fmt == "coordinate":
        if 4 * entries > size:
            return (f"the header says {entries:,} entries, but the file has only {size:,} "
                    "bytes")
        if rows > 4 * entries + 1000:
            return (f"the header says {rows:,} x {cols:,} with only {entries:,} entries: "
                    "too few for a stiffness or mass matrix of that size")
    return None


def _read_mtx(path: Path, key, name, p: _Problems):
    if not path.is_file():
        p.add(key, name, f"an existing Matrix Market file (looked for {path.resolve()})")
        return None
    problem = _mtx_header_problem(path)
    if problem is not None:
        what = ("readable by scipy.io.mmread" if problem.startswith("unreadable header")
                else "whose header fits its content")
        p.add(key, name, f"a Matrix Market file {what} ({problem})")
        return None
    try:
        a = scipy.io.mmread(str(path))
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad file
        p.add(key, name, f"a Matrix Market file readable by scipy.io.mmread "
                         f"({type(exc).__name__}: {' '.join(str(exc).split())[:160]})")
        return None
    if np.iscomplexobj(a):
        coo = scipy.sparse.coo_matrix(a)
        im = np.abs(coo.data.imag)
        if im.size and im.max() > 0:
            k = int(np.argmax(im))
            p.add(key, name, f"a real matrix (the file holds complex entries, e.g. "
                             f"({int(coo.row[k])}, {int(coo.col[k])}) = {coo.data[k]:.4g}; "
                             "export the real stiffness and mass matrices)")
            return None
        a = coo.real
    a = scipy.sparse.csr_matrix(a, dtype=float) if not scipy.sparse.issparse(a) else a.tocsr()
    return a.astype(float)


def _not_semidefinite(K, M, dof_base, free) -> str | None:
    """Why the free-DOF stiffness ``K`` (with mass ``M``) is not positive semi-definite,
    or None when no proof of it is found.

    Looks for a negative diagonal entry, a 2 x 2 principal minor K_ii K_jj < K_ij^2, then
    counts the negative pivots of the symmetric factorisation of ``K + M`` (Sylvester's
    law of inertia: as many eigenvalues of K phi = lam M phi below -1 rad^2/s^2; none
    when K is positive semi-definite and M positive semi-definite).  ``free`` maps the
    free DOFs back to the file's numbering (``dof_base``).
    """
    d = K.diagonal()
    if np.any(d < 0):
        i = int(np.argmin(d))
        return (f"DOF {free[i] + dof_base} has the negative diagonal entry {d[i]:.4g} "
                f"({int(np.sum(d < 0))} negative)")
    coo = scipy.sparse.triu(K, k=1).tocoo()
    minor = d[coo.row] * d[coo.col] - coo.data**2
    bad = minor < -1e-12 * np.maximum(d[coo.row] * d[coo.col], 1e-300)
    if bad.any():
        k = int(np.flatnonzero(bad)[np.argmin(minor[bad])])
        i, j = int(coo.row[k]), int(coo.col[k])
        return (f"the entry ({free[i] + dof_base}, {free[j] + dof_base}) = {coo.data[k]:.4g} "
                f"exceeds sqrt(K_ii K_jj) = {np.sqrt(d[i] * d[j]):.4g} (a 2 x 2 principal "
                "minor is negative)")
    try:
        lu = scipy.sparse.linalg.splu((K + M).tocsc(), permc_spec="MMD_AT_PLUS_A",
                                      diag_pivot_thresh=0.0,
                                      options={"SymmetricMode": True})
    except RuntimeError:  # singular K + M: the eigensolver reports it
        return None
    if not np.array_equal(lu.perm_r, lu.perm_c):  # not a symmetric factorisation
        return None
    n_neg = int(np.count_nonzero(lu.U.diagonal() < 0))
    if n_neg:
        return (f"{n_neg} eigenvalue(s) of K phi = lam M phi below -1 rad^2/s^2 (negative "
                "pivots of K + M)")
    return None


def _check_matrix(p, key, name, a, what):
    if a.shape[0] != a.shape[1] or a.shape[0] == 0:
        p.add(key, name, f"a square {what} matrix (found {a.shape[0]} x {a.shape[1]})")
        return False
    if not np.all(np.isfinite(a.data)):
        k = int(np.flatnonzero(~np.isfinite(a.data))[0])
        coo = a.tocoo()
        bad = ~np.isfinite(coo.data)
        i, j = int(coo.row[bad][0]), int(coo.col[bad][0])
        del k
        p.add(key, name, f"finite entries (entry ({i}, {j}) is {coo.data[bad][0]}; "
                         f"{int(bad.sum())} non-finite)")
        return False
    big = float(np.max(np.abs(a.data), initial=0.0))
    if big == 0.0:
        p.add(key, name, f"a non-zero {what} matrix")
        return False
    d = (a - a.T).tocoo()
    if d.nnz:
        k = int(np.argmax(np.abs(d.data)))
        worst = abs(float(d.data[k]))
        if worst > SYMMETRY_TOL * big:
            p.add(key, name, f"a symmetric {what} matrix (max |A - A^T| = {worst:.3g} at "
                             f"({int(d.row[k])}, {int(d.col[k])}), {worst / big:.3g} of max |A|; "
                             f"tolerance {SYMMETRY_TOL:g})")
            return False
    return True


def _lowest_modes(K, M, n_modes, max_frequency):
    """Lowest modes of ``K phi = lam M phi`` by shift-invert Lanczos (eigsh).

    Returns at least ``n_modes`` modes (when given) and every mode up to
    ``max_frequency`` (Hz, when given; at most ``MAX_MODES``), ascending.  ``K - sigma M``
    is factorised once (``splu``) and reused when more modes are needed.
    """
    n = K.shape[0]
    lam_max = None if max_frequency is None else (2 * np.pi * max_frequency) ** 2
    k = max(1, min(int(n_modes) if n_modes is not None else 12, MAX_MODES))
    op = None
    while True:
        if k >= n - 1:  # eigsh needs k < n - 1: tiny problem, dense solver
            return scipy.linalg.eigh(K.toarray(), M.toarray())
        if op is None:
            lu = scipy.sparse.linalg.splu((K - SIGMA * M).tocsc())
            op = scipy.sparse.linalg.LinearOperator((n, n), matvec=lu.solve, dtype=float)
        # a fixed start vector (ARPACK's default is random): the same matrices give the
        # same modes bit for bit, so a study's model fingerprint (resume) and every
        # worker's model are the same
        v0 = np.random.default_rng(0).standard_normal(n)
        lam, vec = scipy.sparse.linalg.eigsh(K, k=k, M=M, sigma=SIGMA, which="LM", OPinv=op,
                                             v0=v0)
        o = np.argsort(lam)
        lam, vec = lam[o], vec[:, o]
        if lam_max is None or lam[-1] > lam_max or k >= MAX_MODES:
            return lam, vec
        k = min(2 * k, MAX_MODES, n - 1)


def _rigid_body_gap(Kf, Mf, lam) -> bool:
    """True when the lowest modes are rigid-body modes: eigenvalues at round-off, at
    least 1e-8 below a higher mode (computed again, up to 12 modes, when too few are)."""
    lam = np.abs(np.asarray(lam, float))
    n = Kf.shape[0]
    if lam.size < 12 and lam.size < n:
        try:
            lam = np.abs(np.asarray(_lowest_modes(Kf, Mf, min(12, n), None)[0], float))
        except (RuntimeError, ValueError, np.linalg.LinAlgError,
                scipy.sparse.linalg.ArpackError):
            return True
    top = float(lam.max(initial=0.0))
    rigid = int(np.count_nonzero(lam < 1e-8 * top))
    return 0 < rigid < lam.size


def modes_from_matrices(
    K,
    M,
    x,
    dofs,
    rotation_dofs=None,
    fixed_dofs=(),
    *,
    n_modes: int | None = 10,
    max_frequency: float | None = None,
    damping_ratio=0.0,
    rotation_sign: float = 1.0,
    vertical_dofs=None,
    spans=None,
    all_up_to: float | None = None,
    names: dict | None = None,
    line: str = "",
    dof_base: int = 0,
    extra_lines: dict | None = None,
) -> ImportResult:
    """Modes of FE matrices, tabulated along a track line.

    Parameters
    ----------
    K, M : (n, n) array or sparse matrix
        Stiffness and mass (SI), symmetric, boundary conditions not yet applied for the
        ``fixed_dofs``.
    x : (n_station,) array
        Station abscissae along the track line (m), strictly increasing from 0.
    dofs : (n_station,) int array
        0-based vertical DOF of each station.
    rotation_dofs : (n_station,) int array, optional
        0-based rotation DOF (``rotation_sign * d(w)/dx``) of each station.
    fixed_dofs : sequence of int
        DOFs held at zero (supports).
    n_modes, max_frequency
        Keep the lowest ``n_modes`` and/or the modes up to ``max_frequency`` (Hz).
    damping_ratio : float or sequence
    rotation_sign : {1, -1}
        ``-1`` when the rotation DOF is ``-dw/dx`` in the sign of the vertical DOF.
    vertical_dofs : sequence of int, optional
        The vertical translation DOFs for the effective mass (default: ``dofs``).
    spans : sequence of float, optional
        Span lengths along the track line (coverage check, supports).
    all_up_to : float, optional
        Also compute the modes up to this frequency (Hz) for ``all_frequencies`` (cut-off
        checks); the bridge keeps only the requested ones.
    names : dict, optional
        File names for messages: keys "stiffness", "mass", "stations".
    line : str
        Name of the track line (messages, description).
    dof_base : int
        Numbering base of the DOFs in messages (the arrays are 0-based).
    extra_lines : dict, optional
        Other lines to tabulate the same modes on (rails, other tracks): name ->
        ``(x, dofs, rotation_dofs or None)`` as for the main line; returned in
        ``ImportResult.line_shapes`` with the main line's mode signs.

    Returns
    -------
    ImportResult
        ``bridge.effective_mass_fraction`` holds the effective vertical mass fraction of
        every retained mode.
    """
    names = {"stiffness": "K", "mass": "M", "stations": "stations", **(names or {})}
    p = _Problems()
    K = scipy.sparse.csr_matrix(K, dtype=float)
    M = scipy.sparse.csr_matrix(M, dtype=float)
    okk = _check_matrix(p, "stiffness_matrix", names["stiffness"], K, "stiffness")
    okm = _check_matrix(p, "mass_matrix", names["mass"], M, "mass")
    if okk and okm and K.shape != M.shape:
        p.add("mass_matrix", names["mass"],
              f"a mass matrix of the size of the stiffness matrix ({K.shape[0]} x "
              f"{K.shape[0]}; found {M.shape[0]} x {M.shape[1]})")
    p.raise_if_any()
    n = K.shape[0]
    diag = M.diagonal()
    if np.any(diag < 0):
        i = int(np.argmin(diag))
        p.add("mass_matrix", names["mass"],
              f"positive masses: no negative diagonal entry (DOF {i + dof_base} has "
              f"{diag[i]:.4g} kg; "
              f"{int(np.sum(diag < 0))} negative)")
    fixed = np.unique(np.asarray(list(fixed_dofs), dtype=np.int64))
    if fixed.size and (fixed.min() < 0 or fixed.max() >= n):
        p.add("fixed_dofs", (fixed + dof_base).tolist(),
              f"DOF numbers {dof_base} <= i < {n + dof_base} (the matrices have {n} DOFs)")
    x = np.asarray(x, float)
    dofs = np.asarray(dofs, dtype=np.int64)
    rot = None if rotation_dofs is None else np.asarray(rotation_dofs, dtype=np.int64)
    for what, d in (("dof", dofs), ("rotation_dof", rot)):
        if d is not None and d.size and (d.min() < 0 or d.max() >= n):
            i = int(np.flatnonzero((d < 0) | (d >= n))[0])
            p.add("station_map", names["stations"],
                  f"{what} values that are DOFs of the {n}-DOF matrices, {dof_base} .. "
                  f"{n - 1 + dof_base} (station x = {_fmt_x(x[i])} has {what} "
                  f"{d[i] + dof_base})")
    length = float(np.sum(spans)) if spans is not None else None
    _check_stations(p, "station_map", names["stations"], x, line, length)
    p.raise_if_any()

    free = np.setdiff1d(np.arange(n), fixed)
    Kf = K[free][:, free].tocsc()
    Mf = M[free][:, free].tocsc()
    why = _not_semidefinite(Kf, Mf, dof_base, free)
    if why is not None:
        p.add("stiffness_matrix", names["stiffness"],
              "a positive semi-definite stiffness matrix on the free DOFs (after "
              f"bridge.fixed_dofs): {why}")
        p.raise_if_any()
    up_to = [f for f in (max_frequency, all_up_to) if f is not None]
    try:
        lam, vec = _lowest_modes(Kf, Mf, n_modes, max(up_to) if up_to else None)
    except (RuntimeError, ValueError, np.linalg.LinAlgError,
            scipy.sparse.linalg.ArpackError) as exc:
        p.add("stiffness_matrix", names["stiffness"],
              "a stiffness matrix that, with the mass matrix and bridge.fixed_dofs, gives a "
              f"solvable eigenproblem (eigsh: {' '.join(str(exc).split())[:160]})")
        p.raise_if_any()
    lam_scale = max(abs(float(lam[-1])), 1.0)
    if lam[0] < -1e-8 * lam_scale:
        p.add("stiffness_matrix", names["stiffness"],
              f"a positive semi-definite stiffness (eigenvalue {lam[0]:.4g} rad^2/s^2 < 0: "
              "negative stiffness, or a mass matrix that is not positive definite)")
        p.raise_if_any()
    freqs = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)
    if freqs[0] < RIGID_BODY_HZ and not _rigid_body_gap(Kf, Mf, lam):
        # every computed mode is low, none at round-off: units or swapped matrices
        dk = float(np.max(np.abs(K.diagonal())))
        dm = float(np.max(np.abs(M.diagonal())))
        hint = (f"max diagonal entries: {dk:.4g} in {names['stiffness']}, {dm:.4g} in "
                f"{names['mass']}; check the units, N/m and N m/rad for the stiffness, kg "
                "and kg m^2 for the mass"
                + (", and that bridge.stiffness_matrix and bridge.mass_matrix are not "
                   "swapped (the masses are larger than the stiffnesses)" if dm > dk else
                   ""))
        p.add("stiffness_matrix", names["stiffness"],
              f"a stiffness matrix in SI units that, with the mass matrix "
              f"{names['mass']}, gives the frequencies of a bridge: the lowest modes are "
              f"{freqs[0]:.3g} .. {freqs[-1]:.3g} Hz with no rigid-body gap ({hint})")
        p.raise_if_any()
    if freqs[0] < RIGID_BODY_HZ:
        nr = int(np.count_nonzero(freqs < RIGID_BODY_HZ))
        p.add("fixed_dofs", (fixed + dof_base).tolist(),
              f"supports that stop every rigid-body motion: {nr} mode(s) at f < "
              f"{RIGID_BODY_HZ:g} Hz (the structure moves freely; list the support DOFs in "
              "bridge.fixed_dofs, or export K with the supports applied)")
        p.raise_if_any()
    # mass-normalise (eigsh already does up to round-off) and check
    gm = np.einsum("ij,ij->j", vec, Mf @ vec)
    if np.any(gm <= 0):
        p.add("mass_matrix", names["mass"],
              "a mass matrix positive definite on the vibrating DOFs (a mode has zero or "
              "negative generalised mass)")
        p.raise_if_any()
    vec = vec / np.sqrt(gm)
    err = float(np.max(np.abs(vec.T @ (Mf @ vec) - np.eye(vec.shape[1]))))
    if err > NORMALISATION_TOL:
        p.add("mass_matrix", names["mass"],
              f"mass-normalised modes, |Phi^T M Phi - I| < {NORMALISATION_TOL:g} (found "
              f"{err:.3g}: is M symmetric positive definite on the free DOFs?)")
        p.raise_if_any()
    n_keep = _keep(freqs, n_modes, max_frequency)
    if n_keep < 1:
        p.add("max_frequency", max_frequency,
              f"a frequency >= the first mode ({freqs[0]:.4g} Hz), else no mode is retained")
        p.raise_if_any()
    full = np.zeros((n, vec.shape[1]))
    full[free] = vec
    phi = full[:, :n_keep]

    # effective vertical mass (over the free DOFs)
    vdofs = dofs if vertical_dofs is None else np.asarray(vertical_dofs, dtype=np.int64)
    if vdofs.size and (vdofs.min() < 0 or vdofs.max() >= n):
        p.add("vertical_dofs", (vdofs[:8] + dof_base).tolist(),
              f"DOF numbers {dof_base} <= i < {n + dof_base} (the matrices have {n} DOFs)")
        p.raise_if_any()
    # r: unit vertical translation of the whole structure (support DOFs included), so
    # that phi^T M r = int m phi dx and r^T M r = the total vertical mass exactly for a
    # consistent-mass beam; phi is zero on the fixed DOFs
    r = np.zeros(n)
    r[np.unique(vdofs)] = 1.0
    m_tot = float(r @ (M @ r))
    gamma = phi.T @ (M @ r)
    eff = gamma**2 / m_tot if m_tot > 0 else np.full(n_keep, np.nan)

    warnings: list[str] = []
    if freqs[0] < LOW_FREQUENCY_HZ:
        warnings.append(f"bridge.stiffness_matrix: the first natural frequency is "
                        f"{freqs[0]:.3g} Hz, implausibly low for a railway bridge: check the "
                        f"units (N/m and kg) and that {names['stiffness']} and {names['mass']} "
                        "are not swapped")
    values = phi[dofs]
    if rot is not None:
        slopes = rotation_sign * phi[rot]
        spl = _spline_slopes(x, values)
        c = float(np.sum(slopes * spl) / max(np.linalg.norm(slopes) * np.linalg.norm(spl),
                                             1e-300))
        if c < -0.5:
            p.add("rotation_sign", rotation_sign,
                  f"rotation DOFs equal to {'+' if rotation_sign > 0 else '-'}dw/dx; they "
                  f"correlate {c:.2f} with the slope of the vertical station DOFs: set "
                  f"bridge.rotation_sign = {-int(rotation_sign)}")
            p.raise_if_any()
        if c < 0.9:
            warnings.append(f"bridge.station_map ({names['stations']}): the rotation DOFs "
                            f"correlate only {c:.2f} with the slope of the vertical station "
                            "DOFs (wrong rotation_dof column, or too few stations per mode?)")
    else:
        slopes = _spline_slopes(x, values)
    sign = np.sign(values[np.argmax(np.abs(values), axis=0), np.arange(values.shape[1])])
    sign[sign == 0] = 1.0
    values, slopes = _flip_positive(values, slopes)
    line_shapes = {}
    for name, (xe, de, re) in (extra_lines or {}).items():
        xe = np.asarray(xe, float)
        de = np.asarray(de, dtype=np.int64)
        bad = (de < 0) | (de >= n)
        if re is not None:
            re = np.asarray(re, dtype=np.int64)
            bad |= (re < 0) | (re >= n)
        if bad.any() or not _check_stations(p, "station_map", names["stations"], xe, name,
                                            length):
            if bad.any():
                p.add("station_map", names["stations"],
                      f"DOFs of the {n}-DOF matrices on line '{name}'")
            continue
        ve = phi[de] * sign
        se = (rotation_sign * phi[re] * sign if re is not None
              else _spline_slopes(xe, ve))
        xe = xe.copy()
        xe[0] = 0.0
        if length is not None:
            xe[-1] = length
        line_shapes[name] = (xe, np.ascontiguousarray(ve), np.ascontiguousarray(se))
    zeta = _damping(p, damping_ratio, None, n_keep, warnings)
    p.raise_if_any()
    xs = x.copy()
    xs[0] = 0.0
    if length is not None:
        xs[-1] = length
    supports = _supports_from(spans, None, float(xs[-1]))
    if supports.size == 2:  # supports from the fixed station DOFs
        at = np.isin(dofs, fixed)
        if at.sum() >= 2:
            supports = xs[at]
    total = float(np.sum(eff))
    desc = (f"matrices {names['stiffness']} / {names['mass']} ({n} DOFs, {fixed.size} fixed): "
            f"{n_keep} modes, {x.size} stations{' on line ' + repr(line) if line else ''}, "
            f"effective vertical mass {100 * total:.1f}%")
    bridge = _br.ModalBridge(
        kind=_br.HERMITE, length=float(xs[-1]), frequencies=freqs[:n_keep].copy(),
        damping=zeta, nodes=xs, values=np.ascontiguousarray(values),
        slopes=np.ascontiguousarray(slopes), supports=np.asarray(supports, float),
        description=desc, effective_mass_fraction=eff,
        static=StaticDeck(kind="matrices", supports=np.asarray(supports, float),
                          spans=np.diff(np.asarray(supports, float)), K=K, fixed=fixed,
                          stations=xs, dofs=dofs, rotation_dofs=rot,
                          rotation_sign=float(rotation_sign)),
    )
    return ImportResult(bridge, freqs.copy(), tuple(warnings), (line,) if line else (),
                        line_shapes)


def _read_station_map(path: Path, name, p: _Problems, dof_base: int):
    import pandas as pd

    if not path.is_file():
        p.add("station_map", name, f"an existing station map CSV (looked for {path.resolve()})")
        return None
    try:
        df = pd.read_csv(path, comment="#", skipinitialspace=True)
    except Exception as exc:  # noqa: BLE001
        p.add("station_map", name, f"a CSV station map ({type(exc).__name__}: "
                                f"{' '.join(str(exc).split())[:160]})")
        return None
    df.columns = [str(c).strip().lower() for c in df.columns]
    missing = [c for c in ("x", "dof") if c not in df.columns]
    if missing:
        p.add("station_map", name, f"CSV columns x, dof (+ optional rotation_dof, line); "
                                f"missing: {', '.join(missing)}; found: "
                                f"{', '.join(df.columns) or 'none'}")
        return None
    if df.empty:
        p.add("station_map", name, "at least 2 stations (the map is empty)")
        return None
    cols = [c for c in ("x", "dof", "rotation_dof") if c in df.columns]
    for c in cols:
        v = pd.to_numeric(df[c], errors="coerce").to_numpy(float)
        bad = ~np.isfinite(v)
        if c != "x":
            bad |= np.isfinite(v) & (v != np.round(v))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            kind = "finite numbers (m)" if c == "x" else "integer DOF numbers"
            p.add("station_map", name, f"{kind} in column '{c}' (row {i + 2} has "
                                    f"{df[c].iloc[i]!r})")
            return None
        df[c] = v
    df["dof"] = df["dof"].astype(np.int64) - dof_base
    if "rotation_dof" in df.columns:
        df["rotation_dof"] = df["rotation_dof"].astype(np.int64) - dof_base
    if "line" not in df.columns:
        df["line"] = ""
    df["line"] = df["line"].astype(str).str.strip()
    return df


def _dof_list(p, key, value, dof_base, n_hint=None):
    if value is None:
        return None
    if isinstance(value, dict):
        start, step = int(value.get("start", dof_base)), int(value.get("step", 1))
        if n_hint is None:
            return None
        return np.arange(start - dof_base, n_hint, step, dtype=np.int64)
    return np.asarray(list(value), dtype=np.int64) - dof_base


def read_matrices(
    stiffness,
    mass,
    stations,
    *,
    fixed_dofs=None,
    dof_base: int = 0,
    track_line: str | None = None,
    n_modes: int | None = 10,
    max_frequency: float | None = None,
    damping_ratio=0.0,
    rotation_sign: float = 1.0,
    vertical_dofs=None,
    spans=None,
    all_up_to: float | None = None,
    names: dict | None = None,
) -> ImportResult:
    """Read K and M (Matrix Market) and a station map (CSV); compute the modes.

    Parameters
    ----------
    stiffness, mass, stations : str or path-like
        The files (formats in the module docstring).
    fixed_dofs : sequence of int, optional
        Support DOFs (in ``dof_base`` numbering); None/empty when already applied.
    dof_base : {0, 1}
        Numbering base of the DOFs in the station map, ``fixed_dofs`` and
        ``vertical_dofs``.
    vertical_dofs : sequence of int or {"start": i, "step": s}, optional
        Vertical translation DOFs for the effective mass (default: station DOFs).
    track_line, n_modes, max_frequency, damping_ratio, rotation_sign, spans, all_up_to
        As in :func:`modes_from_matrices`.
    names : dict, optional
        Names of the files in messages (keys "stiffness", "mass", "stations").

    Returns
    -------
    ImportResult
    """
    paths = {"stiffness": Path(stiffness), "mass": Path(mass), "stations": Path(stations)}
    names = {k: str(v) for k, v in paths.items()} | (names or {})
    p = _Problems()
    K = _read_mtx(paths["stiffness"], "stiffness_matrix", names["stiffness"], p)
    M = _read_mtx(paths["mass"], "mass_matrix", names["mass"], p)
    df = _read_station_map(paths["stations"], names["stations"], p, dof_base)
    p.raise_if_any()
    lines = [str(v) for v in dict.fromkeys(df["line"])]
    shown = [ln for ln in lines if ln]
    if track_line is None:
        if len(lines) > 1:
            p.add("track_line", None, "the track line the train runs on: one of "
                  + ", ".join(repr(n) for n in shown) + f" (the station map {names['stations']}"
                  " has several)")
            p.raise_if_any()
        line = lines[0]
    else:
        line = str(track_line)
        if line not in lines:
            p.add("track_line", repr(line), f"a track line of {names['stations']}: "
                  + (", ".join(repr(n) for n in shown) if shown else
                     "the map has no line column (one line only: remove bridge.track_line)"))
            p.raise_if_any()
    sub = df[df["line"] == line].sort_values("x", kind="stable")
    rot = sub["rotation_dof"].to_numpy() if "rotation_dof" in sub.columns else None
    fixed = _dof_list(p, "fixed_dofs", [] if fixed_dofs is None else fixed_dofs, dof_base)
    vd = _dof_list(p, "vertical_dofs", vertical_dofs, dof_base, K.shape[0])
    if vd is None and vertical_dofs is None:
        vd = df["dof"].to_numpy()  # every line's station DOFs
    res = modes_from_matrices(
        K, M, sub["x"].to_numpy(float), sub["dof"].to_numpy(), rot, fixed,
        n_modes=n_modes, max_frequency=max_frequency, damping_ratio=damping_ratio,
        rotation_sign=rotation_sign, vertical_dofs=vd, spans=spans, all_up_to=all_up_to,
        names=names, line=line, dof_base=dof_base,
    )
    return ImportResult(res.bridge, res.all_frequencies, res.warnings, tuple(shown))
