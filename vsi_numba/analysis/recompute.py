"""Re-run one case of a results file from the configuration it stores.

A study keeps time histories only for some speeds (``history_speeds_kmh``); the report
still wants the history of the governing case. The file's ``config_json`` holds the
resolved configuration, so the model can be rebuilt and that one case simulated again
(milliseconds to seconds). The model is rebuilt as the study runner builds it: the
bridge, trains and solver settings of the configuration, the irregularity profiles drawn
over the same track range (:func:`vsi_numba.model.irregularity.profile_range`, so a seed gives
the same realisation), and the file's own output points.

Relative paths in the configuration (train file, profile file, imported modes) resolve
against a base directory: the one given, else the first of the configuration's own
directory (the results file's ``config_directory``), the results file's directory and
its parents (up to three levels) and the working directory where the configuration
loads.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import xarray as xr

from vsi_numba.analysis.dataset import DETERMINISTIC


class RecomputeError(RuntimeError):
    """The case cannot be re-run from the results file (the message says why)."""


def _candidates(base_dir, source_path, stored=None) -> list[Path]:
    """The directories a configuration's relative paths are tried against: ``base_dir``
    (given), ``stored`` (the configuration's own directory, the results file's
    ``config_directory``), the results file's directory and up to three above it, the
    working directory."""
    dirs: list[Path] = []
    if base_dir is not None:
        dirs.append(Path(base_dir))
    if stored:
        dirs.append(Path(str(stored)))
    if source_path is not None:
        here = Path(source_path).resolve().parent
        dirs += [here, *list(here.parents)[:3]]
    dirs.append(Path.cwd())
    seen, out = set(), []
    for d in dirs:
        if d not in seen:
            seen.add(d)
            out.append(d)
    return out


def _check_budget(bridge, train, speed: float, settings, n_points: int) -> None:
    """Refuse a re-run beyond the budgets of a study run (time steps, history memory,
    output points; :mod:`vsi_numba.config.limits`), whatever the file asks for."""
    from vsi_numba.config.limits import MAX_HISTORY_BYTES, MAX_OUTPUT_POINTS, MAX_STEPS
    from vsi_numba.config.physics import train_extent

    if n_points > MAX_OUTPUT_POINTS:
        raise RecomputeError(f"the file has {n_points} output points, more than the "
                             f"{MAX_OUTPUT_POINTS} a run may have")
    if not speed > 0:
        raise RecomputeError(f"speed = {speed!r} m/s: expected a speed > 0")
    run = settings.approach + bridge.length + train_extent(train)
    steps = (run / speed + settings.free_vibration) / settings.dt
    if not steps <= MAX_STEPS:
        raise RecomputeError(f"the re-run needs {steps:.3g} time steps, more than the budget "
                             f"of {MAX_STEPS:.3g}")
    n_w = train.n_wheels + train.n_loads
    nbytes = steps * 8.0 * (2 * bridge.n_modes + 2 * n_w + len(train.vehicles) + 2 * n_points)
    if nbytes > MAX_HISTORY_BYTES:
        raise RecomputeError(f"the re-run's time histories need about {nbytes / 2**30:.3g} "
                             f"GiB, more than the budget of {MAX_HISTORY_BYTES / 2**30:g} GiB")


class CaseRunner:
    """Rebuilds the model of a results file once and re-runs cases of it.

    Parameters
    ----------
    ds : xarray.Dataset
        Results with the ``config_json`` attribute and a ``point`` coordinate.
    base_dir : path, optional
        Directory the configuration's relative paths resolve against.
    source_path : path, optional
        The results file (its directory and parents are tried as base directories).
    """

    def __init__(self, ds: xr.Dataset, base_dir=None, source_path=None):
        self.config_json = str(ds.attrs.get("config_json", "") or "")
        self.points = np.atleast_1d(np.asarray(ds["point"].values, float))
        self.dirs = _candidates(base_dir, source_path, ds.attrs.get("config_directory"))
        self._model = None

    def _data(self) -> dict:
        """The stored configuration as a mapping, without the keys that lift the budgets
        of a run (a results file is input: the report must not start a run beyond them)."""
        if not self.config_json:
            raise RecomputeError("the file carries no config_json")
        try:
            data = json.loads(self.config_json)
        except ValueError as exc:
            raise RecomputeError(f"config_json is not JSON ({exc})") from None
        if not isinstance(data, dict):
            raise RecomputeError("config_json is not a table")
        if isinstance(data.get("solver"), dict):
            data["solver"] = {k: v for k, v in data["solver"].items()
                              if k != "allow_large_problem"}
        return data

    def _load(self, data: dict):
        """``data`` loaded with the first candidate directory its files resolve in."""
        from vsi_numba.config import ConfigError, load_config

        first = None
        for d in self.dirs:
            try:
                return load_config(data, base_dir=d)
            except ConfigError as exc:
                errs = getattr(exc, "errors", None)
                first = first or (str(errs[0]) if errs else str(exc).strip().splitlines()[0])
        raise RecomputeError(f"its configuration does not load ({first})")

    def study(self, train: str, speed_kmh: float, dt: float | None = None) -> xr.Dataset:
        """Run the study engine on one train at one speed (every irregularity realisation
        of the file) and return its results, loaded: the same variables, computed the
        same way as the file's, so a check gives the quantity the report states.

        Parameters
        ----------
        train : str
            Train name, as in the file's ``train`` coordinate.
        speed_kmh : float
            Speed (km/h).
        dt : float, optional
            Time step (s) instead of the stored configuration's.

        Raises
        ------
        RecomputeError
            Configuration missing or not loadable, the train not in it, the run refused
            or failed.
        """
        (res,) = self.study_speeds(train, [speed_kmh], dt)
        if isinstance(res, RecomputeError):
            raise res
        return res

    def study_speeds(self, train: str, speeds_kmh, dt: float | None = None) -> list:
        """:meth:`study` at several speeds in one run of the study engine: one result per
        speed of ``speeds_kmh`` (a one-speed dataset, as :meth:`study` returns it), or the
        :class:`RecomputeError` of a speed whose run failed numerically.

        Raises
        ------
        RecomputeError
            Configuration missing or not loadable, the train not in it, the run refused
            or failed as a whole.
        """
        import tempfile

        from vsi_numba.study.runner import execute_study
        from vsi_numba.study.store import StudyError

        asked = [round(float(v), 9) for v in speeds_kmh]
        data = self._data()
        if dt is not None:
            data["solver"] = {**data.get("solver", {}), "dt": float(dt)}
        study = {k: v for k, v in dict(data.get("study", {})).items()
                 if k not in ("history_speeds_kmh", "refine_resonance", "vary")}
        study.update(speeds_kmh=sorted(set(asked)), output="rerun.nc",
                     save_time_histories=False)
        data["study"] = study
        data.pop("fatigue", None)
        tr = dict(data.get("train", {}))
        if isinstance(tr.get("preset"), list):
            if str(train) not in [str(t) for t in tr["preset"]]:
                raise RecomputeError(f"train {train!r} is not in the stored configuration")
            tr["preset"] = [str(train)]
        data["train"] = tr
        cfg = self._load(data)
        with tempfile.TemporaryDirectory(prefix="vsi_rerun_") as tmp:
            out = Path(tmp) / "rerun.nc"
            try:
                execute_study(cfg, output=out, backend="serial", quiet=True,
                              command="vsi report (re-run of a governing case)")
            except (StudyError, OSError, ValueError) as exc:
                raise RecomputeError(f"the re-run was refused or failed ({exc})") from None
            with xr.open_dataset(out) as ds:
                res = ds.load()
        if str(train) not in [str(t) for t in res["train"].values]:
            raise RecomputeError(f"train {train!r} is not in the stored configuration")
        res = res.sel(train=[str(train)])
        kmh = np.asarray(res["speed_kmh"].values, float)
        runs: list = []
        for v in asked:
            one = res.isel(speed=[int(np.argmin(abs(kmh - v)))])
            if "status" in one and bool((one["status"].values != 0).any()):
                msg = (str(np.ravel(one["message"].values)[0]) if "message" in one else "")
                one = RecomputeError(f"the re-run failed numerically ({msg})")
            runs.append(one)
        return runs

    def model(self):
        """(bridge, trains by name, settings, profiles by realisation id); built once."""
        if self._model is not None:
            return self._model
        cfg = self._load(self._data())
        from vsi_numba.config.physics import train_extent
        from vsi_numba.model.irregularity import profile_range

        bridge = cfg.build_bridge()
        self._bridge_for = cfg.bridge_for  # + EN 1991-2 additional damping (moving forces)
        trains = {t.name: t for t in cfg.trains()}
        settings = cfg.solver_settings()
        x_range = profile_range(bridge.length, [train_extent(t) for t in trains.values()],
                                settings.approach, settings.free_vibration)
        profiles = dict(cfg.irregularities(*x_range))
        self._model = (bridge, trains, settings, profiles)
        return self._model

    def run(self, train: str, speed: float, irregularity: int = DETERMINISTIC,
            dt: float | None = None) -> xr.Dataset:
        """Simulate one case with time histories.

        Parameters
        ----------
        train : str
            Train name, as in the file's ``train`` coordinate.
        speed : float
            Speed (m s-1).
        irregularity : int
            Realisation id (seed; -1 = deterministic track).
        dt : float, optional
            Time step (s) instead of the stored configuration's (a convergence check).

        Returns
        -------
        xarray.Dataset
            The output of :func:`vsi_numba.solver.simulate.simulate` (dims ``time``,
            ``point``, ``wheel``, ``vehicle``) at the file's output points.

        Raises
        ------
        RecomputeError
            Configuration missing or not loadable, train or realisation not in it, or the
            re-run failed numerically.
        """
        bridge, trains, settings, profiles = self.model()
        if self._data().get("train", {}).get("other_trains"):
            # the file's case had every train of train.other_trains in it
            raise RecomputeError("the case has trains on other tracks (train.other_trains), "
                                 "which a re-run of one train alone leaves out")
        if str(train) not in trains:
            raise RecomputeError(f"train {train!r} is not in the stored configuration "
                                 f"({', '.join(trains)})")
        if int(irregularity) not in profiles:
            raise RecomputeError(f"irregularity realisation {irregularity} is not in the "
                                 f"stored configuration ({', '.join(map(str, profiles))})")
        from vsi_numba.solver.simulate import simulate

        if dt is not None:
            settings = dataclasses.replace(settings, dt=float(dt))
        _check_budget(bridge, trains[str(train)], float(speed), settings, self.points.size)
        bridge = self._bridge_for(trains[str(train)])  # the bridge the train ran on
        sim = simulate(bridge, trains[str(train)], float(speed), profiles[int(irregularity)],
                       settings, output_points=self.points, save_histories=True)
        if int(sim.attrs.get("status", 0)) != 0:
            raise RecomputeError(f"the re-run failed: {sim.attrs.get('message', '')}")
        return sim
