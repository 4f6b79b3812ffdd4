"""The ``vsi`` typer app: options and help of every command, and :func:`main`.

Each command is a function ``*_command(...) -> exit code`` in its own module of this
package, imported when the command runs (``vsi --help`` stays fast).  No numerics here."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="vsi_numba: vehicle-structure interaction for railway bridges (direct method).",
    # plain help: flags read "-q, --quiet" (the rich help of typer 0.2x labels every flag,
    # --help included, "<bool>"), and the text greps as it reads
    rich_markup_mode=None,
)


def _version(value: bool) -> None:
    if value:
        import platform

        import numba

        from vsi_numba import __version__

        typer.echo(f"vsi_numba {__version__} (numba {numba.__version__}, Python "
                   f"{platform.python_version()})")
        raise typer.Exit(0)


@app.callback()
def _main(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                 help="print the version and exit"),
):
    """vsi_numba: vehicle-structure interaction for railway bridges (direct method)."""


@app.command()
def run(
    config: Path = typer.Argument(..., metavar="CONFIG", help="TOML configuration file"),
    output: Path | None = typer.Option(None, "-o", "--output", help="netCDF output file"),
    quiet: bool = typer.Option(False, "--quiet", "-q",
                               help="no progress bar, summary lines or config warnings "
                                    "(errors are still printed)"),
):
    """Run the speeds of one configuration (first train, first realisation) to netCDF."""
    from vsi_numba.cli.run import run_command

    raise typer.Exit(run_command(config, output, quiet))


@app.command()
def sweep(
    config: Path = typer.Argument(..., metavar="CONFIG", help="TOML configuration file"),
    output: Path | None = typer.Option(None, "-o", "--output", help="netCDF output file"),
    workers: int | None = typer.Option(
        None, "--workers", "-w", help="start a Dask LocalCluster (127.0.0.1) with N workers"
    ),
    scheduler: str | None = typer.Option(
        None, "--scheduler", help="address of an existing Dask scheduler, tcp://HOST:PORT"
    ),
    quiet: bool = typer.Option(False, "--quiet", "-q",
                               help="no progress bar, summary lines or config warnings "
                                    "(errors and the governing results are still printed)"),
    fresh: bool = typer.Option(
        False, "--fresh", help="discard finished cases stored by an earlier run and start "
        "over; recompute a results file this study wrote (unchanged configuration, model "
        "and code), which is otherwise left as it is"
    ),
    report_dir: Path | None = typer.Option(
        None, "--report", help="then write the report of the results into this directory"
    ),
):
    """Sweep speeds x trains x irregularity realisations; resumable."""
    from vsi_numba.cli.sweep import sweep_command

    raise typer.Exit(sweep_command(config, output, workers, scheduler, quiet, fresh,
                                   report_dir))


@app.command()
def check(
    config: Path = typer.Argument(..., metavar="CONFIG", help="TOML configuration file"),
    workers: int | None = typer.Option(
        None, "--workers", "-w", help="estimate for N workers (default: the cores)"),
):
    """Validate a configuration, print its study size and estimated time, memory and
    disk; run nothing."""
    from vsi_numba.cli.check import check_command

    raise typer.Exit(check_command(config, workers))


@app.command(name="compile")
def compile_(
    family: str | None = typer.Option(
        None, "--family", help="moving_force or interaction (default: both)"),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="print nothing"),
    into: Path | None = typer.Option(
        None, "--into", metavar="DIR",
        help="compile them for a generic CPU into this cache directory instead: a study "
             "with NUMBA_CACHE_DIR=DIR (or a copy of DIR on another machine with the same "
             "Python, numba and vsi_numba) loads them"),
):
    """Compile the numba kernels into the cache (or load them from it), once per machine:
    what a first run would otherwise do before its first batch."""
    from vsi_numba.cli.compile_kernels import compile_command

    raise typer.Exit(compile_command(family, quiet, into))


@app.command()
def init(
    path: Path = typer.Argument(Path("study.toml"), metavar="PATH",
                                help="file to write (never overwritten)"),
    template: str = typer.Option("default", "--template",
                                 help="default (an EN 1991-2 dynamic check) or "
                                      "compatibility (a train on an existing bridge)"),
):
    """Write a commented starter configuration that validates and runs as is."""
    from vsi_numba.cli.init import init_command

    raise typer.Exit(init_command(path, template))


@app.command()
def schema(
    output: Path | None = typer.Option(None, "-o", "--output",
                                       help="write the schema to this file"),
):
    """Print the JSON Schema of a configuration file (key completion and checks in TOML
    editors: taplo, Even Better TOML)."""
    from vsi_numba.cli.schema import schema_command

    raise typer.Exit(schema_command(output))


@app.command()
def trains(
    name: str | None = typer.Argument(None, help="train name (or an axle-load CSV file): "
                                                  "print its axle table"),
    signature: bool = typer.Option(False, "--signature",
                                   help="print the train's DER/LIR dynamic signature and "
                                        "compare it with the HSLM-A envelope"),
    damping: float | None = typer.Option(None, "--damping",
                                         help="damping ratio of the signature in % "
                                              "(default: the code profile's, 1 %)"),
    plot: Path | None = typer.Option(None, "--plot", help="draw the signature into this "
                                     "file (the format from its suffix: .png, .pdf, .svg)"),
):
    """List the train library, or print one train's axles (or its dynamic signature)."""
    if signature or plot is not None:
        from vsi_numba.cli.trains import signature_command

        raise typer.Exit(signature_command(name, damping, plot))
    from vsi_numba.cli.trains import trains_command

    raise typer.Exit(trains_command(name))


@app.command()
def modes(
    config: Path = typer.Argument(..., metavar="CONFIG", help="TOML configuration file"),
    output: Path | None = typer.Option(None, "-o", "--output",
                                       help="plot the mode shapes to this file (the format "
                                            "from its suffix: .png, .pdf, .svg)"),
):
    """Print the bridge's retained modes (and effective masses) and plot their shapes."""
    from vsi_numba.cli.model import modes_command

    raise typer.Exit(modes_command(config, output))


# The options of the commands that run forward models on a backend and keep their
# evaluations (calibrate, reliability).
_Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="no progress or warnings")]
_Workers = Annotated[int | None, typer.Option(
    "--workers", "-w", help="start a Dask LocalCluster (127.0.0.1) with N workers"
    " (with --backend threads or processes: N of those)")]
_Scheduler = Annotated[str | None, typer.Option(
    "--scheduler", help="address of an existing Dask scheduler, tcp://HOST:PORT")]
_Backend = Annotated[str | None, typer.Option(
    "--backend", help="serial, threads (the default), processes or dask (the default "
    "with --workers or --scheduler); the same seed gives the same numbers on every one")]
_Fresh = Annotated[bool, typer.Option(
    "--fresh", help="discard the evaluations an interrupted run stored "
    "(OUTPUT.evaluations) and start over; otherwise the run continues from them")]


@app.command()
def calibrate(
    config: Path = typer.Argument(..., metavar="CONFIG",
                                  help="TOML configuration with a [calibration] section"),
    output: Path = typer.Option(..., "-o", "--output", help="netCDF posterior file"),
    quiet: _Quiet = False,
    workers: _Workers = None,
    scheduler: _Scheduler = None,
    backend: _Backend = None,
    fresh: _Fresh = False,
):
    """Bayesian updating of configuration keys from measured records (emcee); resumable."""
    from vsi_numba.cli.existing import calibrate_command

    raise typer.Exit(calibrate_command(config, output, quiet, workers, scheduler, backend, fresh))


@app.command()
def reliability(
    config: Path = typer.Argument(..., metavar="CONFIG",
                                  help="TOML configuration with a [reliability] section"),
    output: Path = typer.Option(..., "-o", "--output", help="netCDF reliability file"),
    quiet: _Quiet = False,
    workers: _Workers = None,
    scheduler: _Scheduler = None,
    backend: _Backend = None,
    fresh: _Fresh = False,
):
    """Probability that a check is exceeded and reliability index (subset simulation);
    resumable."""
    from vsi_numba.cli.existing import reliability_command

    raise typer.Exit(reliability_command(config, output, quiet, workers, scheduler, backend, fresh))


@app.command()
def report(
    results: Path = typer.Argument(..., metavar="RESULTS",
                                   help="netCDF results of `vsi run` or `vsi sweep`"),
    outdir: Path | None = typer.Option(None, "-o", "--output", help="report directory"),
):
    """Write the EN 1990 A2 checks, figures and a Markdown report for a results file."""
    from vsi_numba.cli.common import EXIT_USAGE, Printer
    from vsi_numba.io.paths import path_length_problem

    for path, what in ((results, "results file"), (outdir, "report directory")):
        problem = None if path is None else path_length_problem(
            path, what, "choose a shorter path" if what == "results file" else
            "choose a shorter report directory (-o DIR)")
        if problem is not None:
            Printer().line(f"vsi report: {problem}", stderr=True)
            raise typer.Exit(EXIT_USAGE)
    from vsi_numba.cli.report import report_command

    raise typer.Exit(report_command(results, outdir))


@app.command()
def profile(
    config: Path = typer.Argument(..., metavar="CONFIG", help="TOML configuration file"),
    plot: Path | None = typer.Option(None, "--plot", help="draw the profiles into this "
                                     "file (the format from its suffix: .png, .pdf, .svg)"),
):
    """Show the track irregularity profiles a configuration would use."""
    from vsi_numba.cli.model import profile_command

    raise typer.Exit(profile_command(config, plot))


from vsi_numba.cli.verify import verify  # noqa: E402 - options kept with the command

app.command()(verify)


def main():  # pragma: no cover - console entry
    """Console entry: run the command, then leave without the interpreter's teardown.

    Every command has written and closed its files (and stopped its workers) when it
    returns; what is left is finalising numba/LLVM and the imported libraries, ~0.3-0.4 s
    of nothing a user waits for.  The standard streams are flushed first.
    """
    import os
    import sys

    code = 0
    try:
        app()
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        if not isinstance(exc.code, int | None):
            print(exc.code, file=sys.stderr)
    except KeyboardInterrupt:
        code = 130
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(code)


if __name__ == "__main__":  # pragma: no cover
    main()
