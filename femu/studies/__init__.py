"""Studies: tasks, executors and the result store."""
