"""Every export target refuses an --opt it does not know: exit 2, one line naming it, nothing
written. Seven layouts (kitti-odometry, kitti-folder, kitti-stereo, kitti-sceneflow, tum,
euroc, png) ignored any option before, so a typo (``--opt background_depth=inf`` to png, an
option of another layout) gave an export other than the one asked for, silently."""
from __future__ import annotations

import pytest

from layout_scene import write_layout_render
from vo_reference.commands.main import main
from vo_reference.exporters.driver import EXPORTERS

pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")


@pytest.fixture(scope="module")
def render(tmp_path_factory):
    return write_layout_render(tmp_path_factory.mktemp("opt") / "r", n=2)


@pytest.mark.parametrize("target", sorted(EXPORTERS))
def test_an_unknown_option_is_refused(render, tmp_path, capsys, target):
    out = tmp_path / "out"
    assert main(["export", str(render), str(out), "--to", target, "--opt", "no_such_option=1", "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no_such_option" in err[0] and target.split("-")[0] in err[0], err
    assert not out.exists()
