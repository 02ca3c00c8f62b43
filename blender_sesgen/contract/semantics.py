"""Semantic classes: the ``class NAME`` of every object, as Cityscapes label ids and colours.

numpy + standard library only (both packages import it). The table is Cityscapes'
(Cordts et al., CVPR 2016; ``cityscapesscripts/helpers/labels.py``): ids 0..33 and -1
with their train ids, categories and palette, unchanged, so that a render's semantic maps
are read by every Cityscapes tool. Indoor classes, which Cityscapes lacks, follow at ids
34..48 in the category ``indoor`` (train id 255, ignored in a Cityscapes evaluation).

Names are case-insensitive in scripts and ``_``/``-`` stand for spaces
(``class traffic_light`` = ``class "traffic light"``). An object without ``class`` gets
its library material's class (asphalt -> road, brick -> building, ...; see
``material_library``) or else ``static`` (Cityscapes' "other man-made object", void);
pixels that see no object are ``sky``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np


@dataclass(frozen=True)
class Label:
    name: str
    id: int
    train_id: int
    category: str
    category_id: int
    has_instances: bool
    ignore_in_eval: bool
    colour: tuple[int, int, int]


_T, _F = True, False
LABELS: tuple[Label, ...] = tuple(Label(*row) for row in (
    # Cityscapes (labels.py), in its order
    ("unlabeled", 0, 255, "void", 0, _F, _T, (0, 0, 0)),
    ("ego vehicle", 1, 255, "void", 0, _F, _T, (0, 0, 0)),
    ("rectification border", 2, 255, "void", 0, _F, _T, (0, 0, 0)),
    ("out of roi", 3, 255, "void", 0, _F, _T, (0, 0, 0)),
    ("static", 4, 255, "void", 0, _F, _T, (0, 0, 0)),
    ("dynamic", 5, 255, "void", 0, _F, _T, (111, 74, 0)),
    ("ground", 6, 255, "void", 0, _F, _T, (81, 0, 81)),
    ("road", 7, 0, "flat", 1, _F, _F, (128, 64, 128)),
    ("sidewalk", 8, 1, "flat", 1, _F, _F, (244, 35, 232)),
    ("parking", 9, 255, "flat", 1, _F, _T, (250, 170, 160)),
    ("rail track", 10, 255, "flat", 1, _F, _T, (230, 150, 140)),
    ("building", 11, 2, "construction", 2, _F, _F, (70, 70, 70)),
    ("wall", 12, 3, "construction", 2, _F, _F, (102, 102, 156)),
    ("fence", 13, 4, "construction", 2, _F, _F, (190, 153, 153)),
    ("guard rail", 14, 255, "construction", 2, _F, _T, (180, 165, 180)),
    ("bridge", 15, 255, "construction", 2, _F, _T, (150, 100, 100)),
    ("tunnel", 16, 255, "construction", 2, _F, _T, (150, 120, 90)),
    ("pole", 17, 5, "object", 3, _F, _F, (153, 153, 153)),
    ("polegroup", 18, 255, "object", 3, _F, _T, (153, 153, 153)),
    ("traffic light", 19, 6, "object", 3, _F, _F, (250, 170, 30)),
    ("traffic sign", 20, 7, "object", 3, _F, _F, (220, 220, 0)),
    ("vegetation", 21, 8, "nature", 4, _F, _F, (107, 142, 35)),
    ("terrain", 22, 9, "nature", 4, _F, _F, (152, 251, 152)),
    ("sky", 23, 10, "sky", 5, _F, _F, (70, 130, 180)),
    ("person", 24, 11, "human", 6, _T, _F, (220, 20, 60)),
    ("rider", 25, 12, "human", 6, _T, _F, (255, 0, 0)),
    ("car", 26, 13, "vehicle", 7, _T, _F, (0, 0, 142)),
    ("truck", 27, 14, "vehicle", 7, _T, _F, (0, 0, 70)),
    ("bus", 28, 15, "vehicle", 7, _T, _F, (0, 60, 100)),
    ("caravan", 29, 255, "vehicle", 7, _T, _T, (0, 0, 90)),
    ("trailer", 30, 255, "vehicle", 7, _T, _T, (0, 0, 110)),
    ("train", 31, 16, "vehicle", 7, _T, _F, (0, 80, 100)),
    ("motorcycle", 32, 17, "vehicle", 7, _T, _F, (0, 0, 230)),
    ("bicycle", 33, 18, "vehicle", 7, _T, _F, (119, 11, 32)),
    ("license plate", -1, -1, "vehicle", 7, _F, _T, (0, 0, 142)),
    # indoor classes (this project's; not in Cityscapes)
    ("floor", 34, 255, "indoor", 8, _F, _T, (140, 100, 60)),
    ("ceiling", 35, 255, "indoor", 8, _F, _T, (200, 200, 160)),
    ("door", 36, 255, "indoor", 8, _T, _T, (180, 60, 180)),
    ("window", 37, 255, "indoor", 8, _T, _T, (100, 200, 255)),
    ("furniture", 38, 255, "indoor", 8, _T, _T, (255, 140, 0)),
    ("table", 39, 255, "indoor", 8, _T, _T, (255, 200, 100)),
    ("chair", 40, 255, "indoor", 8, _T, _T, (220, 120, 40)),
    ("shelf", 41, 255, "indoor", 8, _T, _T, (160, 80, 0)),
    ("sofa", 42, 255, "indoor", 8, _T, _T, (255, 100, 150)),
    ("cabinet", 43, 255, "indoor", 8, _T, _T, (130, 60, 30)),
    ("bed", 44, 255, "indoor", 8, _T, _T, (255, 180, 200)),
    ("lamp", 45, 255, "indoor", 8, _T, _T, (255, 255, 120)),
    ("picture", 46, 255, "indoor", 8, _T, _T, (0, 180, 160)),
    ("screen", 47, 255, "indoor", 8, _T, _T, (0, 255, 255)),
    ("stairs", 48, 255, "indoor", 8, _F, _T, (120, 0, 60)),
))

BY_NAME: dict[str, Label] = {label.name: label for label in LABELS}
BY_ID: dict[int, Label] = {label.id: label for label in LABELS}
DEFAULT_OBJECT_CLASS = "static"    # an object with no class and no library material's class
BACKGROUND_CLASS = "sky"           # pixels that see no object (object id 0)


def canonical(name: str) -> str:
    """The table's spelling of a class name: lower case, ``_``/``-`` and runs of spaces as one space."""
    return " ".join(name.lower().replace("_", " ").replace("-", " ").split())


def lookup(name: str) -> Optional[Label]:
    return BY_NAME.get(canonical(name))


def object_class(explicit: Optional[str], material_class: Optional[str]) -> str:
    """The class of an object: its ``class`` tag, else its library material's, else static."""
    if explicit:
        return canonical(explicit)
    return material_class or DEFAULT_OBJECT_CLASS


def label_lut(object_classes: dict[int, str], size: Optional[int] = None) -> np.ndarray:
    """An array mapping object id -> Cityscapes label id (uint8), index 0 (background) = sky.

    ``object_classes``: {object id: class name}; ids not in it map to ``static``."""
    n = max(size or 0, max(object_classes, default=0) + 1, 1)
    lut = np.full(n, BY_NAME[DEFAULT_OBJECT_CLASS].id, dtype=np.uint8)
    lut[0] = BY_NAME[BACKGROUND_CLASS].id
    for obj_id, name in object_classes.items():
        lut[int(obj_id)] = BY_NAME[canonical(name)].id % 256   # license plate (-1) -> 255, as uint8 stores it
    return lut


def palette() -> np.ndarray:
    """(256, 3) uint8: the colour of each label id (black where no label has that id)."""
    pal = np.zeros((256, 3), np.uint8)
    for label in LABELS:
        if label.id >= 0:
            pal[label.id] = label.colour
    return pal
