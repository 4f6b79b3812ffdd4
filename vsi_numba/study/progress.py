"""What a study prints while it runs: a rich progress bar on a terminal, one-line
messages on stderr (none with ``quiet``)."""

from __future__ import annotations

import sys
import time as _time


class _Progress:
    """A rich progress bar on a terminal; silent otherwise."""

    def __init__(self, enabled: bool, total: int, done: int, label: str):
        self.bar = None
        if not enabled:
            return
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        console = Console(stderr=True)
        if not console.is_terminal:
            return
        self.bar = Progress(
            TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
            TextColumn("{task.fields[rate]}"), TimeElapsedColumn(), TextColumn("ETA"),
            TimeRemainingColumn(), console=console, transient=False,
        )
        self.task = self.bar.add_task(label, total=total, completed=done, rate="")
        self._t0 = _time.perf_counter()
        self._n = 0

    def __enter__(self):
        if self.bar is not None:
            self.bar.start()
        return self

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.stop()

    def advance(self, n: int = 1):
        if self.bar is None:
            return
        self._n += n
        rate = self._n / max(_time.perf_counter() - self._t0, 1e-9)
        self.bar.update(self.task, advance=n, rate=f"{rate:.1f} runs/s")


def _say(quiet: bool, message: str) -> None:
    if not quiet:
        print(message, file=sys.stderr, flush=True)
