"""Reports: the study report, the diagnosis report, IOHprofiler export."""
