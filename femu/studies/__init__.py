"""Studies: tasks, executors and the result store."""

#: Wall-clock seconds per run when `femu study` is not given --time-limit: far beyond an
#: honest run of the suite's budgets on one core, so that only a hanging plugin meets it.
#: (Here, not in study.py, so that `femu study --help` shows it without loading the study.)
DEFAULT_TIME_LIMIT_S = 3600.0
