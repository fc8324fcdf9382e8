"""From frequency response functions to modal data: a synthetic test rig, FRF files, and
identification (LSCF poles over model orders via sdypy-EMA, automatic stable-pole selection,
LSFD residues, real normal modes at the measured coordinates)."""

from .frf_io import FRFFileError, FRFSet, read_frf, write_csv, write_npz, write_uff58
from .synthetic import synthetic_frf
from .core import Identification, identify
from .timeseries_io import Recording, Setup, TimeSeriesError, read_timeseries
from .ambient import AmbientIdentification, identify_ambient

__all__ = ["FRFFileError", "FRFSet", "Identification", "identify", "read_frf", "synthetic_frf", "write_csv", "write_npz", "write_uff58",
           "AmbientIdentification", "Recording", "Setup", "TimeSeriesError", "identify_ambient", "read_timeseries"]
