"""The progress bar of a study (rich): runs done, running and failed."""

from __future__ import annotations


class Progress:
    """A rich progress bar of runs done, running and failed (does nothing when disabled)."""

    def __init__(self, total: int, done: int, failed: int, enabled: bool):
        self.enabled, self.failed, self._running = enabled, failed, 0
        if enabled:
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

            self.bar = Progress(TextColumn("runs"), BarColumn(), MofNCompleteColumn(),
                                TextColumn("done · {task.fields[running]} running · {task.fields[failed]} failed"),
                                TimeElapsedColumn())
            self.task = self.bar.add_task("study", total=total, completed=done, running=0, failed=failed)

    def __enter__(self):
        if self.enabled:
            self.bar.start()
        return self

    def __exit__(self, *exc):
        if self.enabled:
            self.bar.stop()

    def running(self, n: int) -> None:
        if self.enabled and n != self._running:
            self._running = n
            self.bar.update(self.task, running=n)

    def done(self, failed: bool) -> None:
        if self.enabled:
            self.failed += failed
            self.bar.update(self.task, advance=1, failed=self.failed)

