"""The report of a posterior file (``vsi report POSTERIOR.nc``) and of a reliability file
(``vsi report RELIABILITY.nc``): Markdown with its figures, in a directory of its own.

Posterior: the table of the parameters (prior, median, 5 % and 95 %, effective sample
size, R-hat), the sampler's diagnostics, a corner plot (matplotlib: histograms on the
diagonal, pairwise scatter below), the measured records beside the posterior-predictive
band, and the deck-acceleration check at the line speed, +10 % and +20 % with the
calibrated model (median and 90 % credible band) beside the same check with the
configuration's values.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from vsi_numba.existing.text import md as _md

#: Which file a results file is (its ``vsi_file`` attribute).
POSTERIOR, RELIABILITY = "posterior", "reliability"


def kind_of(ds) -> str | None:
    """``"posterior"``, ``"reliability"`` or None (a study's results)."""
    k = ds.attrs.get("vsi_file")
    return k if k in (POSTERIOR, RELIABILITY) else None


def _g(v, digits: int = 4) -> str:
    return f"{float(v):.{digits}g}"


def _corner(ds, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [str(p) for p in ds["parameter"].values]
    x = ds["posterior"].values
    n = len(names)
    fig, axes = plt.subplots(n, n, figsize=(2.4 * n, 2.4 * n), squeeze=False)
    for i in range(n):
        for j in range(n):
            ax = axes[i, j]
            if j > i:
                ax.axis("off")
                continue
            if i == j:
                ax.hist(x[:, i], bins=40, color="0.4")
                for q in np.percentile(x[:, i], [5, 50, 95]):
                    ax.axvline(q, color="C3", lw=0.8, ls="--")
            else:
                ax.plot(x[:, j], x[:, i], ".", ms=1.0, alpha=0.3, color="0.2")
            if i == n - 1:
                ax.set_xlabel(names[j], fontsize=8)
            if j == 0 and i > 0:
                ax.set_ylabel(names[i], fontsize=8)
            ax.tick_params(labelsize=6)
    fig.tight_layout()
    fig.savefig(path, format="png", dpi=110)  # into the report's new directory
    plt.close(fig)


def _records(ds, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = ds.sizes["record"]
    fig, axes = plt.subplots(n, 1, figsize=(8, 2.2 * n), squeeze=False)
    for i in range(n):
        ax = axes[i, 0]
        k = int(ds["record_length"].values[i])
        t = ds["record_time"].values[i, :k]
        ax.plot(t, ds["record_measured"].values[i, :k], color="0.3", lw=0.6,
                label="measured (low-passed)")
        ax.fill_between(t, ds["record_predictive_p05"].values[i, :k],
                        ds["record_predictive_p95"].values[i, :k], color="C0", alpha=0.35,
                        label="posterior predictive 5-95 %")
        ax.plot(t, ds["record_predictive_p50"].values[i, :k], color="C0", lw=0.6,
                label="posterior predictive median")
        ax.set_title(f"record {i}: {ds['record_quantity'].values[i]} at x = "
                     f"{float(ds['record_point'].values[i]):g} m, "
                     f"{ds['record_train'].values[i]} at "
                     f"{float(ds['record_speed_kmh'].values[i]):g} km/h", fontsize=8)
        ax.set_xlabel("record time (s)", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0, 0].legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, format="png", dpi=110)  # into the report's new directory
    plt.close(fig)


def posterior_markdown(ds) -> str:
    """The Markdown of a posterior file (figures referenced as corner.png, records.png)."""
    lines = [f"# {_md(ds.attrs.get('title', 'Calibration'))}", "",
             "Bayesian updating of the configuration's keys from measured records "
             "(`vsi calibrate`).", ""]
    lines += ["## Posterior", "",
              "| parameter | prior | median | 5 % | 95 % | effective samples | R-hat |",
              "|---|---|---:|---:|---:|---:|---:|"]
    x = ds["posterior"].values
    for i, p in enumerate(ds["parameter"].values):
        q = np.percentile(x[:, i], [5, 50, 95])
        lines.append(f"| {_md(p)} | {_md(ds['prior'].values[i])} | {_g(q[1])} | "
                     f"{_g(q[0])} | {_g(q[2])} | "
                     f"{float(ds['effective_sample_size'].values[i]):.0f} | "
                     f"{float(ds['r_hat'].values[i]):.3f} |")
    acc = ds["acceptance_fraction"].values
    a = ds.attrs
    lines += ["", f"Sampler: {_md(a.get('sampler', ''))}; {a.get('n_walkers')} walkers x "
              f"{a.get('n_steps')} steps kept after {a.get('burn_in')} burn-in steps; "
              f"{a.get('n_forward_runs')} forward runs "
              f"({a.get('n_kernel_runs_per_forward_run')} passages each) in "
              f"{float(a.get('elapsed_s', float('nan'))):.1f} s; acceptance fraction "
              f"{acc.mean():.2f} (walkers {acc.min():.2f} .. {acc.max():.2f}); seed "
              f"{a.get('seed')}.", ""]
    rh = np.nanmax(ds["r_hat"].values)
    ess = np.nanmin(ds["effective_sample_size"].values)
    if not (rh <= 1.1 and ess >= 100):
        lines += [f"**Not converged**: largest R-hat {rh:.3f} (should be <= 1.1), fewest "
                  f"effective samples {ess:.0f} (should be >= 100): run more samples "
                  "(calibration.n_samples) before using the intervals.", ""]
    shifts = ds["record_shift"].values
    lines += ["Records (low-passed at the EN cut-off "
              f"{float(a.get('acceleration_cutoff_hz', float('nan'))):.4g} Hz, compared "
              f"every {float(a.get('likelihood_step_s', float('nan'))):.4g} s):", "",
              "| record | file | quantity | x (m) | train | km/h | shift (s), median |",
              "|---:|---|---|---:|---|---:|---:|"]
    for i in range(ds.sizes["record"]):
        lines.append(f"| {i} | {_md(ds['record_file'].values[i])} | "
                     f"{_md(ds['record_quantity'].values[i])} | "
                     f"{float(ds['record_point'].values[i]):g} | "
                     f"{_md(ds['record_train'].values[i])} | "
                     f"{float(ds['record_speed_kmh'].values[i]):g} | "
                     f"{np.nanmedian(shifts[:, i]):.4f} |")
    lines += ["", "![corner plot](corner.png)", "",
              "![measured and posterior-predictive records](records.png)", ""]
    lim = float(a.get("check_limit", float("nan")))
    lines += ["## Deck acceleration with the calibrated model", "",
              f"EN 1990 A2.4.4.2.1 peak deck acceleration (whole deck, band-limited), "
              f"train(s) {_md(a.get('check_trains', ''))}, limit {lim:g} m/s².", "",
              "| speed (km/h) | configuration's values (m/s²) | verdict | calibrated median "
              "(m/s²) | 5 % | 95 % | verdict (95 %) |",
              "|---:|---:|---|---:|---:|---:|---|"]
    post = ds["check_posterior"].values
    for j, v in enumerate(ds["check_speed_kmh"].values):
        code = float(ds["check_code"].values[j])
        q = np.percentile(post[:, j], [5, 50, 95]) if post.shape[0] else [np.nan] * 3
        lines.append(f"| {float(v):g} | {code:.3f} | {'pass' if code <= lim else 'FAIL'} | "
                     f"{q[1]:.3f} | {q[0]:.3f} | {q[2]:.3f} | "
                     f"{'pass' if q[2] <= lim else 'FAIL'} |")
    lines += ["", "The calibrated verdict is that of the 95 % quantile of the posterior "
              "(the safe side of its 90 % band).", ""]
    return "\n".join(lines)


def write_report(ds, outdir) -> Path:
    """Write the report of a posterior or reliability file into ``outdir`` (replaced as
    a whole: :func:`vsi_numba.io.atomic.replace_directory`); returns the Markdown path."""
    from vsi_numba.io.atomic import replace_directory

    outdir = Path(outdir)
    kind = kind_of(ds)
    names = {"report.md", "corner.png", "records.png"}

    def owns(rel: str, is_dir: bool) -> bool:
        return rel in names

    with replace_directory(outdir, owns) as tmp:
        if kind == POSTERIOR:
            _corner(ds, tmp / "corner.png")
            _records(ds, tmp / "records.png")
            (tmp / "report.md").write_text(posterior_markdown(ds), encoding="utf-8")
        else:
            from vsi_numba.existing.reliability import reliability_markdown

            (tmp / "report.md").write_text(reliability_markdown(ds), encoding="utf-8")
    return outdir / "report.md"


def config_of(ds) -> dict:
    """The stored configuration of a posterior or reliability file."""
    try:
        return json.loads(ds.attrs.get("config_json", "{}"))
    except ValueError:
        return {}
