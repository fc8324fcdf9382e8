"""Ending a run's process with everything it started: the functions live in adapters.processes
(the sandbox of adapters ends an optimizer's worker the same way); kept here under their names."""

from adapters.processes import GRACE_S, kill_descendants, kill_tree

__all__ = ["GRACE_S", "kill_descendants", "kill_tree"]
