"""The progress bar of a study: runs done, running and failed (rich's bar when rich is installed,
it comes with the 'all' extra; else one plain line on stderr per finished run)."""

from __future__ import annotations


class Progress:
    """A rich progress bar of runs done, running and failed (does nothing when disabled)."""

    def __init__(self, total: int, done: int, failed: int, enabled: bool):
        self.enabled, self.failed, self._running = enabled, failed, 0
        self.total, self.completed, self.bar = total, done, None
        if enabled and has_rich():
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

            self.bar = Progress(TextColumn("runs"), BarColumn(), MofNCompleteColumn(),
                                TextColumn("done · {task.fields[running]} running · {task.fields[failed]} failed"),
                                TimeElapsedColumn())
            self.task = self.bar.add_task("study", total=total, completed=done, running=0, failed=failed)

    def __enter__(self):
        if self.bar is not None:
            self.bar.start()
        return self

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.stop()

    def running(self, n: int) -> None:
        if self.enabled and n != self._running:
            self._running = n
            if self.bar is not None:
                self.bar.update(self.task, running=n)

    def done(self, failed: bool) -> None:
        if self.enabled:
            self.failed += failed
            self.completed += 1
            if self.bar is not None:
                self.bar.update(self.task, advance=1, failed=self.failed)
            else:
                import sys

                print(f"runs {self.completed}/{self.total} done · {self._running} running · {self.failed} failed",
                      file=sys.stderr, flush=True)



def has_rich() -> bool:
    """Whether rich (the progress bars' library, not in the core install) can be imported."""
    from adapters.extras import has

    return has("rich")
