"""The frame model: types (types.py), validation (validate.py), model files and the shipped
models (io.py), edits that add an effect to a copy (edits.py), and generated
models: every element split, regular frames (generate.py).

Units are SI throughout: metres, pascals, kilograms, newtons per metre (translational
springs) and newton-metres per radian (rotational springs).
"""

from .edits import add_mass, crack_element, release_element_end, split_element, with_formulation
from .generate import BASES, BASES_3D, regular_frame, regular_frame_3d, split_elements
from .io import MODEL_FORMAT, load_model, model_from_dict, model_to_dict, save_model, shipped_models
from .types import DIRECTIONS, Element, FrameModel, LumpedMass, Material, Node, Section, Spring, Support
from .validate import ModelFileError

__all__ = [
    "BASES", "BASES_3D", "DIRECTIONS", "Element", "FrameModel", "LumpedMass", "MODEL_FORMAT", "Material", "ModelFileError", "Node",
    "Section", "Spring", "Support", "add_mass", "crack_element", "load_model", "model_from_dict", "model_to_dict",
    "regular_frame", "regular_frame_3d", "release_element_end", "save_model", "shipped_models", "split_element", "split_elements", "with_formulation",
]
