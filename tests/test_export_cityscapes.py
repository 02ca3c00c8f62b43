"""``--to cityscapes`` read by the tools Cityscapes users run: cityscapesscripts'
``csCreateTrainIdLabelImgs`` (a real subprocess) redraws our train ids from our
``_polygons.json``, its ``json2labelImg`` our label ids, and torchvision's Cityscapes file
rule (reimplemented from its source: torch does not install here) finds every target."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from synthetic_render import write_render

cv2 = pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
labels_cs = pytest.importorskip("cityscapesscripts.helpers.labels")
W, H = 56, 40
# object id -> class: instances of car and person, stuff, an indoor class, a license plate
CLASSES = {1: "road", 2: "building", 3: "car", 4: "car", 5: "person", 6: "table", 7: "license plate",
           8: "vegetation"}


def id_map(k: int) -> np.ndarray:
    """Nested and speckled regions: a building with a car in a hole, a person in front of
    the car, vegetation speckle, a plate on the second car, sky (0) above."""
    rng = np.random.default_rng(k)
    ids = np.zeros((H, W), np.int32)
    ids[H // 2:, :] = 1
    ids[8:H // 2 + 6, 4:40] = 2
    ids[14:30, 10 + k:26 + k] = 3
    ids[18:34, 16 + k:20 + k] = 5
    ids[24:36, 40:52] = 4
    ids[30:32, 44:48] = 7
    ids[2:10, 44:54] = 6
    speck = rng.uniform(size=(H, W)) > 0.93
    ids[speck & (ids == 2)] = 8
    return ids


@pytest.fixture(scope="module")
def render(tmp_path_factory):
    root = tmp_path_factory.mktemp("cs") / "r"
    K = np.array([[40.0, 0, W / 2 - 0.5], [0, 40.0, H / 2 - 0.5], [0, 0, 1]])
    z = np.full((H, W), 5.0, np.float32)
    frames = [{v: (np.full((H, W, 3), 0.3, np.float32), z, id_map(k)) for v in ("left", "right")} for k in range(2)]
    objects = [{"id": i, "name": f"o{i}", "shape": "quad", "class": c} for i, c in CLASSES.items()]
    return write_render(root, K=K, baseline_m=0.2, T_world_left=np.tile(np.eye(4), (2, 1, 1)), frames=frames,
                        objects=objects)


@pytest.fixture(scope="module")
def exported(render, tmp_path_factory):
    from vo_reference.products.exports import export
    return export(render, "cityscapes", tmp_path_factory.mktemp("cs_out") / "cityscapes", noise=None,
                  progress=False, extra={"city": "bochum", "split": "val"})


def torchvision_targets(root: Path, split: str, mode: str = "gtFine"):
    """torchvision.datasets.Cityscapes' file list: leftImg8bit/SPLIT/CITY/* and, per image,
    gtFine/SPLIT/CITY/<stem>_gtFine_{instanceIds.png,labelIds.png,color.png,polygons.json}."""
    images_dir, targets_dir = root / "leftImg8bit" / split, root / mode / split
    if not images_dir.is_dir() or not targets_dir.is_dir():
        raise RuntimeError("Dataset not found or incomplete")
    out = []
    for city in os.listdir(images_dir):
        for name in os.listdir(images_dir / city):
            stem = name.split("_leftImg8bit")[0]
            out.append((images_dir / city / name, [targets_dir / city / f"{stem}_{mode}_{s}" for s in
                                                   ("instanceIds.png", "labelIds.png", "color.png", "polygons.json")]))
    return out


def test_torchvision_file_rule_finds_every_target(exported):
    pairs = torchvision_targets(exported, "val")
    assert len(pairs) == 2
    for image, targets in pairs:
        assert image.is_file() and all(t.is_file() for t in targets), targets
    with pytest.raises(RuntimeError):
        torchvision_targets(exported, "train")
    assert (exported / "rightImg8bit/val/bochum/bochum_000000_000001_rightImg8bit.png").is_file()


def test_cityscapesscripts_creates_our_train_ids(exported, render, tmp_path):
    """csCreateTrainIdLabelImgs draws _labelTrainIds.png from our polygons, over our own:
    the same image, and the train id of each pixel's class in cityscapesscripts' table."""
    root = tmp_path / "cs"
    shutil.copytree(exported, root)
    ours = {p.name: cv2.imread(str(p), cv2.IMREAD_UNCHANGED) for p in (root / "gtFine").rglob("*_labelTrainIds.png")}
    for p in (root / "gtFine").rglob("*_labelTrainIds.png"):
        p.unlink()
    tool = Path(sys.executable).parent / "csCreateTrainIdLabelImgs"
    r = subprocess.run([str(tool)], env={**os.environ, "CITYSCAPES_DATASET": str(root)}, capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    from vo_reference.io.render import RenderSequence
    seq = RenderSequence(render)
    train = {i: labels_cs.name2label[c].trainId if labels_cs.name2label.get(c) else 255 for i, c in CLASSES.items()}
    train = {i: 255 if t < 0 else t for i, t in train.items()}
    train[0] = labels_cs.name2label["sky"].trainId
    for k in range(2):
        name = f"bochum_000000_{k:06d}_gtFine_labelTrainIds.png"
        made = cv2.imread(str(root / "gtFine/val/bochum" / name), cv2.IMREAD_UNCHANGED)
        assert made is not None and made.dtype == np.uint8
        assert np.array_equal(made, ours[name])
        assert np.array_equal(made, np.vectorize(train.get)(seq.ids(k, "left")))


def test_json2labelimg_redraws_our_label_ids(exported, render, tmp_path):
    from cityscapesscripts.preparation.json2labelImg import json2labelImg
    stem = exported / "gtFine/val/bochum/bochum_000000_000000_gtFine"
    json2labelImg(f"{stem}_polygons.json", str(tmp_path / "ids.png"), "ids")
    drawn = cv2.imread(str(tmp_path / "ids.png"), cv2.IMREAD_UNCHANGED)
    ours = cv2.imread(f"{stem}_labelIds.png", cv2.IMREAD_UNCHANGED)
    from vo_reference.io.render import RenderSequence
    ids = RenderSequence(render).ids(0, "left")
    cityscapes = ~np.isin(ids, [6, 7])            # table (indoor) is drawn as static, the plate unlabeled
    assert np.array_equal(drawn[cityscapes], ours[cityscapes])
    assert (drawn[ids == 6] == labels_cs.name2label["static"].id).all()
    poly = json.loads(Path(f"{stem}_polygons.json").read_text())
    assert (poly["imgWidth"], poly["imgHeight"]) == (W, H)
    by_label = {o["label"] for o in poly["objects"]}
    assert {"sky", "road", "building", "car", "person", "vegetation", "static", "unlabeled"} == by_label
    assert {o.get("sesgenClass") for o in poly["objects"] if o["label"] == "static"} == {"table"}
    # one polygon per region and a few one-pixel ones at most: an annotation, not a pixel list
    assert len(poly["objects"]) < 0.1 * W * H


def test_options(render, tmp_path, capsys):
    from vo_reference.cli import main
    assert main(["export", str(render), str(tmp_path / "a"), "--to", "cityscapes", "--opt", "split=dev", "-q"]) == 2
    assert "split" in capsys.readouterr().err and not (tmp_path / "a").exists()
    assert main(["export", str(render), str(tmp_path / "b"), "--to", "cityscapes", "--opt", "town=x", "-q"]) == 2
    assert main(["export", str(render), str(tmp_path / "c"), "--to", "cityscapes", "-q"]) == 0
    assert (tmp_path / "c/gtFine/train/sesgen/sesgen_000000_000000_gtFine_labelTrainIds.png").is_file()
