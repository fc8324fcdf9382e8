"""Measured modal data: the `ModalData` type (types.py), the JSON file format
(json_format.py, docs/modal-data.md), UFF dataset 55 (uff.py), reading/writing by file type
and the shipped datasets (files.py), and synthetic measurements (synthetic.py)."""

from .files import load_modal_data, paper_table, save_modal_data, shipped_datasets
from .json_format import modal_data_from_dict, modal_data_to_dict
from .synthetic import synthetic_measurement
from .types import DATA_FORMAT, DEFAULT_FREQ_NOISE, DEFAULT_SHAPE_NOISE, DataFileError, ModalData
from .uff import read_uff55, write_uff55

__all__ = ["DATA_FORMAT", "DEFAULT_FREQ_NOISE", "DEFAULT_SHAPE_NOISE", "DataFileError", "ModalData", "load_modal_data", "modal_data_from_dict",
           "modal_data_to_dict", "paper_table", "read_uff55", "save_modal_data", "shipped_datasets",
           "synthetic_measurement", "write_uff55"]
