"""What every ``vsi`` command shares: one printer (rich) and one configuration loader.

Output of a command goes through :class:`Printer`: tables and results to stdout,
errors, warnings and progress lines to stderr.  Text that comes from the user or from a
file (paths, messages) is always printed literally (no rich markup, no emoji codes, no
control character: :func:`terminal`) and without hard line breaks (``soft_wrap``), so
that a message greps as one line whatever the terminal width.

:func:`load_config` is the one way a command reads its TOML file: a configuration error
is printed as ``error: PATH: invalid configuration`` followed by every message, and the
command exits with 2.
"""

from __future__ import annotations

from pathlib import Path

#: Exit code of a command that cannot run as asked (bad configuration, bad options, an
#: output that cannot be written); see the commands' docstrings for the others.
EXIT_USAGE = 2


def terminal(text) -> str:
    """``text`` as a terminal may show it: control characters other than line feed and tab
    (an escape sequence would recolour the terminal, retitle it or make a hyperlink; a
    carriage return would overwrite the line) shown as their Unicode control pictures
    (``␛``, ``␍``, ``␀``), C1 controls and bidirectional overrides as ``⟨U+202E⟩``: the
    terminal's sanitiser (those of the files are :mod:`vsi_numba.analysis.sanitize`)."""
    import unicodedata

    out = []
    for ch in str(text):
        if ch in "\n\t" or unicodedata.category(ch) not in ("Cc", "Cf"):
            out.append(ch)
        elif ord(ch) < 0x20:
            out.append(chr(0x2400 + ord(ch)))
        else:
            out.append("␡" if ch == "\x7f" else f"⟨U+{ord(ch):04X}⟩")
    return "".join(out)


class Printer:
    """The console of a command: ``out`` (stdout) and ``err`` (stderr) rich consoles.

    Made per command call (the consoles look at the streams and the environment when
    they are made, as the commands did before).
    """

    def __init__(self):
        from rich.console import Console

        self.out = Console()
        self.err = Console(stderr=True)

    # -- literal text --------------------------------------------------------------
    def line(self, text, *, stderr: bool = False) -> None:
        """Print ``text`` literally (no markup, highlighting or emoji) as one line."""
        (self.err if stderr else self.out).print(
            terminal(text), markup=False, highlight=False, emoji=False, soft_wrap=True)

    def error(self, text) -> None:
        """``error: TEXT`` on stderr (``error`` in bold red on a terminal)."""
        from rich.markup import escape

        self.err.print(f"[bold red]error[/]: {escape(terminal(text))}", highlight=False,
                       emoji=False, soft_wrap=True)

    def warning(self, text) -> None:
        """``warning: TEXT`` on stderr (``warning`` in yellow on a terminal)."""
        from rich.markup import escape

        self.err.print(f"[yellow]warning[/]: {escape(terminal(text))}", highlight=False,
                       emoji=False, soft_wrap=True)

    def config_error(self, path, exc) -> None:
        """``error: PATH: invalid configuration`` then every message of ``exc``."""
        self.error(f"{path}: invalid configuration")
        self.line(exc, stderr=True)

    # -- rich renderables (tables) and styled text of our own -------------------------
    def show(self, renderable, **kwargs) -> None:
        """Print a rich renderable (or text with markup written by the command) to stdout."""
        self.out.print(renderable, **kwargs)


def load_config(path, printer: Printer):
    """Load the configuration ``path`` for a command; None after printing why it cannot.

    A :class:`~vsi_numba.config.ConfigError` prints ``error: PATH: invalid
    configuration`` and its messages; an unreadable file prints ``error: cannot read
    PATH: REASON``.  The command then returns :data:`EXIT_USAGE`.
    """
    from vsi_numba.config import ConfigError
    from vsi_numba.config import load_config as _load

    try:
        return _load(Path(path))
    except ConfigError as exc:
        printer.config_error(path, exc)
    except OSError as exc:
        printer.error(f"cannot read {path}: {exc.strerror or exc}")
    return None


def load_config_and_output(config, output, printer: Printer):
    """``(cfg, output path)`` of a command that writes results (``vsi run``, ``vsi
    sweep``), both checked before any computation; None after printing why not.

    The output defaults to the configuration's ``study.output``; it must not be a file
    the configuration reads (the configuration itself, a profile, modes, matrix or train
    file), a directory, device, FIFO or socket, a name too long for the file system, or
    in a place that cannot be written (:func:`output_problem`).
    """
    cfg = load_config(config, printer)
    if cfg is None:
        return None
    out_path = Path(output) if output is not None else Path(cfg.output_path)
    problem = output_problem(config, out_path, cfg)
    if problem is not None:
        printer.error(problem)
        return None
    return cfg, out_path


def same_file(a: Path, b: Path) -> bool:
    """Whether two paths name the same file (existing or not)."""
    try:
        if a.exists() and b.exists():
            return a.samefile(b)
        return a.expanduser().resolve() == b.expanduser().resolve()
    except (OSError, ValueError, RuntimeError):
        return False


def output_problem(config: Path, out_path: Path, cfg=None) -> str | None:
    """Why ``out_path`` cannot take the results of ``config`` (checked before any
    computation): an input of the configuration, not a regular file, a name too long,
    an unwritable location (see :func:`vsi_numba.io.paths.output_conflict`); else None."""
    from vsi_numba.io.paths import output_conflict
    from vsi_numba.study.store import OutputNotWritableError, check_writable

    problem = output_conflict(out_path, cfg)
    if problem is not None:
        return problem
    if same_file(Path(config), out_path):
        return (f"the output {out_path} is the configuration file itself: refusing to "
                "overwrite the input; choose another output (-o PATH, ending in .nc)")
    try:
        check_writable(out_path.parent if str(out_path.parent) else Path("."),
                       "results file")
    except OutputNotWritableError as exc:
        return str(exc)
    return None


class sigterm_as_interrupt:  # noqa: N801 - used as a context manager
    """SIGTERM raises KeyboardInterrupt (in the main thread): a terminated sweep keeps its
    finished batches and says so, like Ctrl-C; a terminated report leaves a whole one."""

    def __enter__(self):
        import signal

        def handler(signum, frame):
            raise KeyboardInterrupt

        try:
            self._old = signal.signal(signal.SIGTERM, handler)
        except ValueError:  # not the main thread
            self._old = None
        return self

    def __exit__(self, *exc):
        import signal

        if self._old is not None:
            signal.signal(signal.SIGTERM, self._old)
        return None
