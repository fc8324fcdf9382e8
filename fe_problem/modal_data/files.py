"""Reading and writing modal data by file type (JSON, UFF dataset 55), and the datasets that
ship with the project (``paper``), loaded by name."""

from __future__ import annotations

from pathlib import Path

from ..safe_files import write_text
from ..jsonutil import dumps, read_json_file
from ..shipped import resolve, shipped_names
from .json_format import modal_data_from_dict, modal_data_to_dict
from .types import DataFileError, ModalData
from .uff import read_uff55, write_uff55

DATA_SUFFIX = ".modal.json"
UFF_SUFFIXES = (".uff", ".unv")


def shipped_datasets() -> tuple[str, ...]:
    """Names of the modal datasets that ship with the project."""
    return shipped_names(DATA_SUFFIX)


def load_modal_data(name_or_path: str | Path | ModalData) -> ModalData:
    """Read measured modal data: a shipped dataset (``"paper"``), a JSON file, or a UFF file
    (``.uff``/``.unv``, dataset 55). Unknown nodes of the named model are refused."""
    if isinstance(name_or_path, ModalData):
        return name_or_path
    path = resolve(name_or_path, DATA_SUFFIX, "data")
    if path.suffix.lower() in UFF_SUFFIXES:
        data = read_uff55(path)
    else:
        data = modal_data_from_dict(read_json_file(path, DataFileError), source=str(path))
    if data.model is None:  # an identification without a model: checked when one is given
        return data
    try:
        model = data.load_model()
    except (FileNotFoundError, ValueError) as exc:
        raise DataFileError(f"{path}: field 'model': {exc}") from None
    data.check_model(model)
    return data


def save_modal_data(data: ModalData, path: str | Path) -> Path:
    """Write JSON (``.json``) or UFF dataset 55 (``.uff``/``.unv``); returns the path."""
    path = Path(path)
    if path.suffix.lower() in UFF_SUFFIXES:
        write_uff55(data, path)
    else:
        write_text(path, dumps(modal_data_to_dict(data)) + "\n")
    return path


def paper_table() -> dict:
    """Table 1 of the paper and the figures quoted in its text (shipped with the 'paper' data)."""
    return load_modal_data("paper").meta["table1"]
