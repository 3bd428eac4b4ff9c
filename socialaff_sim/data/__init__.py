"""Data layer: the interaction model, skeleton layouts, file formats and loaders."""

from .dataset import Dataset, actor_disjoint_folds, pair_disjoint_folds
from .interaction import MIN_FRAMES, Interaction
from .npz_format import FORMAT_VERSION, load_interaction, load_npz_dataset, save_dataset, save_interaction
from .skeletons import KEY_JOINTS, LAYOUTS, N_KEY, SkeletonLayout, get_layout
from .specs import DATASET_KINDS, load_dataset

__all__ = [
    "DATASET_KINDS",
    "Dataset",
    "FORMAT_VERSION",
    "Interaction",
    "KEY_JOINTS",
    "LAYOUTS",
    "MIN_FRAMES",
    "N_KEY",
    "SkeletonLayout",
    "actor_disjoint_folds",
    "pair_disjoint_folds",
    "get_layout",
    "load_dataset",
    "load_interaction",
    "load_npz_dataset",
    "save_dataset",
    "save_interaction",
]
