"""Semantic segmentation in the Cityscapes layout: ``export --to cityscapes``.

Every object of a render carries a semantic ``class`` (manifest ``objects[i].class``; the
label table is ``blender_sesgen.contract.semantics``: Cityscapes' ids and palette, plus
indoor classes at 34..48). From the exact per-pixel object ids this writes, per frame, the
tree of Cityscapes' ``leftImg8bit_trainvaltest`` and ``gtFine_trainvaltest``::

    OUT/leftImg8bit/SPLIT/CITY/CITY_000000_NNNNNN_leftImg8bit.png       colour image (noise as --noise)
    OUT/gtFine/SPLIT/CITY/CITY_000000_NNNNNN_gtFine_labelIds.png        8-bit Cityscapes label ids
    OUT/gtFine/SPLIT/CITY/CITY_000000_NNNNNN_gtFine_labelTrainIds.png   8-bit train ids (255 = ignored)
    OUT/gtFine/SPLIT/CITY/CITY_000000_NNNNNN_gtFine_color.png           the Cityscapes palette
    OUT/gtFine/SPLIT/CITY/CITY_000000_NNNNNN_gtFine_instanceIds.png     16-bit: label*1000 + instance
                                                                        for classes with instances,
                                                                        else the label id
    OUT/gtFine/SPLIT/CITY/CITY_000000_NNNNNN_gtFine_polygons.json       the annotation: one polygon
                                                                        per object region (below)
    OUT/gtFine/SPLIT/CITY/CITY_000000_NNNNNN_gtFine_objectIds.png       16-bit: the render's object ids (ours)
    OUT/classes.json                                                    the label table and, per object,
                                                                        its class, label id and instance id

and, for a stereo render, the same for the right camera under ``rightImg8bit/`` and
``gtFineRight/``. SPLIT is ``--opt split=train|val|test`` (default ``train``), CITY
``--opt city=NAME`` (default ``sesgen``). Pixels that see no object are ``sky`` (23);
objects of a render made before classes existed are ``static``. An object's instance number
is its rank (from 0, by object id) among the objects of its class, the same in every frame.

``_polygons.json`` (``imgWidth``, ``imgHeight``, ``objects``: ``label``, ``polygon``) is made
so that cityscapesscripts' ``json2labelImg`` / ``csCreateTrainIdLabelImgs`` redraw our label
and train-id images exactly (:mod:`.label_polygons`). Its labels are Cityscapes' names; a class
Cityscapes lacks (the indoor ones) is written ``static`` (void, train id 255, as the class) and
one its tools skip (``license plate``, id -1) ``unlabeled``, each with the class itself in
``sesgenClass``.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic, semantics

from ..errors import VoError
from ..io.files import write_png16, write_png_rgb
from .label_polygons import label_polygons

STEREO_FOLDERS = {"left": ("leftImg8bit", "gtFine"), "right": ("rightImg8bit", "gtFineRight")}
SPLITS = ("train", "val", "test")


def object_classes(seq) -> dict[int, str]:
    """{object id: class name} from the manifest (``static`` where a row has no class)."""
    out = {}
    for row in seq.objects:
        name = row.get("class") or semantics.DEFAULT_OBJECT_CLASS
        if semantics.lookup(name) is None:
            raise VoError(f"{seq.root}: object {row.get('id')} has the unknown class {name!r}")
        out[int(row["id"])] = semantics.canonical(name)
    return out


def instance_numbers(classes: dict[int, str]) -> dict[int, int]:
    """{object id: instance number}: rank by id among the objects of the same class."""
    ranks: dict[str, int] = {}
    out = {}
    for obj_id in sorted(classes):
        cls = classes[obj_id]
        out[obj_id] = ranks.get(cls, 0)
        ranks[cls] = out[obj_id] + 1
    return out


class SemanticMaps:
    """Look-up tables from object ids to label ids and Cityscapes instance ids."""

    def __init__(self, seq):
        self.classes = object_classes(seq)
        self.instances = instance_numbers(self.classes)
        size = max(self.classes, default=0) + 1
        self.label_lut = semantics.label_lut(self.classes, size)
        self.instance_lut = self.label_lut.astype(np.uint16)
        for obj_id, cls in self.classes.items():
            label = semantics.BY_NAME[cls]
            if label.has_instances:
                if self.instances[obj_id] >= 1000:
                    raise VoError(f"more than 1000 objects of class {cls!r}: Cityscapes instance ids "
                                  "(label * 1000 + instance) cannot hold them")
                self.instance_lut[obj_id] = label.id * 1000 + self.instances[obj_id]
        self.palette = semantics.palette()
        self.train_lut = np.array([_train_id(semantics.BY_ID[int(i)]) if int(i) in semantics.BY_ID else 255
                                   for i in range(256)], np.uint8)
        # the label each object's polygons carry: a name cityscapesscripts knows and draws
        self.polygon_label = {obj_id: _polygon_label(cls) for obj_id, cls in self.classes.items()}
        self.polygon_label[0] = semantics.BACKGROUND_CLASS

    def _lookup(self, lut: np.ndarray, ids: np.ndarray) -> np.ndarray:
        ids = np.asarray(ids)
        if ids.size and (ids.min() < 0 or ids.max() >= len(lut)):
            unknown = sorted(set(np.unique(ids[(ids < 0) | (ids >= len(lut))]).tolist()))
            raise VoError(f"object id(s) {unknown[:5]} in the image are not in the manifest's object table")
        return lut[ids]

    def labels(self, ids: np.ndarray) -> np.ndarray:
        return self._lookup(self.label_lut, ids)

    def instance_ids(self, ids: np.ndarray) -> np.ndarray:
        return self._lookup(self.instance_lut, ids)

    def colour(self, labels: np.ndarray) -> np.ndarray:
        return self.palette[labels]

    def train_ids(self, labels: np.ndarray) -> np.ndarray:
        """uint8 Cityscapes train ids of label ids (255: ignored in training)."""
        return self.train_lut[labels]

    def polygons(self, ids: np.ndarray) -> dict:
        """The ``_polygons.json`` of one id map (module docstring)."""
        H, W = ids.shape
        drawn = {obj_id: semantics.BY_NAME[name].id for obj_id, name in self.polygon_label.items()}
        objects = []
        for p in label_polygons(ids, drawn):
            row = {"label": self.polygon_label[p.region], "polygon": [list(xy) for xy in p.points]}
            cls = self.classes.get(p.region, semantics.BACKGROUND_CLASS)
            if cls != row["label"]:
                row["sesgenClass"] = cls
            objects.append(row)
        return {"imgHeight": int(H), "imgWidth": int(W), "objects": objects}

    def table(self) -> dict:
        return {
            "labels": [{"name": lab.name, "id": lab.id, "trainId": lab.train_id, "category": lab.category,
                        "categoryId": lab.category_id, "hasInstances": lab.has_instances,
                        "ignoreInEval": lab.ignore_in_eval, "color": list(lab.colour)} for lab in semantics.LABELS],
            "background": semantics.BACKGROUND_CLASS,
            "objects": [{"id": obj_id, "class": cls, "labelId": int(self.label_lut[obj_id]),
                         "instanceId": int(self.instance_lut[obj_id])} for obj_id, cls in sorted(self.classes.items())],
        }


def _train_id(label) -> int:
    return 255 if label.train_id < 0 else int(label.train_id)


def _polygon_label(cls: str) -> str:
    """The Cityscapes label an object's polygons carry (module docstring)."""
    label = semantics.BY_NAME[cls]
    if label.category == "indoor":
        return semantics.DEFAULT_OBJECT_CLASS
    return "unlabeled" if label.id < 0 else cls


def export_cityscapes(seq, out: Path, opts) -> None:
    from .exports import image_rgb, progress_bar
    extra = dict(opts.extra)
    city = str(extra.pop("city", "sesgen"))
    split = str(extra.pop("split", "train"))
    if extra:
        raise VoError(f"cityscapes export: unknown option(s) {', '.join(sorted(extra))} (city, split)")
    if not city or any(c in city for c in "/\\_") or city.startswith("."):
        raise VoError(f"--opt city={city!r}: a plain name without '/', '\\\\' or '_' is needed")
    if split not in SPLITS:
        raise VoError(f"--opt split={split!r}: expected one of {', '.join(SPLITS)} (Cityscapes' splits)")
    maps = SemanticMaps(seq)
    views = [v for v in ("left", "right") if v in seq.views]
    frames = list(opts.frames)
    with progress_bar(opts, len(frames) * len(views), "cityscapes") as bar:
        for i, k in enumerate(frames):
            stem = f"{city}_000000_{i:06d}"
            for view in views:
                img_dir, gt_dir = STEREO_FOLDERS[view]
                ids = seq.ids(k, view)
                labels = maps.labels(ids)
                write_png_rgb(out / img_dir / split / city / f"{stem}_{img_dir}.png", image_rgb(seq, k, view, opts))
                gt = out / gt_dir / split / city
                write_png_rgb(gt / f"{stem}_gtFine_labelIds.png", labels)
                write_png_rgb(gt / f"{stem}_gtFine_labelTrainIds.png", maps.train_ids(labels))
                write_png_rgb(gt / f"{stem}_gtFine_color.png", maps.colour(labels))
                write_png16(gt / f"{stem}_gtFine_instanceIds.png", maps.instance_ids(ids))
                write_png16(gt / f"{stem}_gtFine_objectIds.png", ids.astype(np.uint16))
                atomic.write_text(gt / f"{stem}_gtFine_polygons.json", json.dumps(maps.polygons(ids)) + "\n")
                bar.update()
    atomic.write_text(out / "classes.json", json.dumps(maps.table(), indent=1) + "\n")


export_cityscapes.keeps_lens = True   # no camera model: a distorted render's images and labels as they are
