"""Test session settings: one BLAS thread (fe_problem._threads, the one place that sets it),
imported before anything loads numpy."""

import fe_problem._threads  # noqa: F401
