"""bench/quality_noise_source.py's light split (issue 29, quality17): ``sun_only`` / ``sky_only``
scale the built scene's sky sun lamp and world background, nothing else; a scene without
``WORLD sky`` is refused with exit code 2."""
import argparse
import importlib.util
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
_spec = importlib.util.spec_from_file_location("quality_noise_source", REPO / "bench" / "quality_noise_source.py")
qns = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(qns)

SKY = """\
CAMERA resolution 32 24 focal 30 baseline 0.1
START position 0 1 3
WORLD sky strength 1 elevation 40 azimuth 30
QUAD id 1 colour 0.5 0.5 0.5 vertices -3 0 -3  3 0 -3  3 0 4  -3 0 4
"""


def _lights(bench):
    s = bench.session(qns.qb.reference_preset(1))
    bscene = s.built.scene
    suns = [o.data.energy for o in bscene.objects if o.type == "LIGHT" and o.data.type == "SUN"]
    sky = [n.inputs["Strength"].default_value for n in bscene.world.node_tree.nodes if n.type == "BACKGROUND"]
    return suns, sky


def test_the_light_variants_scale_only_their_light(tmp_path):
    """The oracle: the plain bench's session of the same script (its sun lamp and background)."""
    path = tmp_path / "sky.ses"
    path.write_text(SKY)
    args = argparse.Namespace(scene=str(path), frame=0, scale=1.0, crop=1.0, crop_centre=(0.5, 0.5),
                              views="left", device="cpu")
    plain = qns.qb.Bench(args)
    plain.exposure = 1.0
    suns, sky = _lights(plain)
    assert len(suns) == 1 and suns[0] > 0 and len(sky) == 1 and sky[0] > 0
    for name, (k_sun, k_sky) in qns.LIGHT_SCALES.items():
        b = qns.LitBench(args, k_sun, k_sky)
        b.exposure = 1.0
        assert _lights(b) == ([k_sun * suns[0]], [k_sky * sky[0]]), name


def test_a_scene_without_a_sky_is_refused(tmp_path):
    path = tmp_path / "grey.ses"
    path.write_text(SKY.replace("WORLD sky strength 1 elevation 40 azimuth 30", "WORLD colour 0.3 0.3 0.3"))
    r = subprocess.run([sys.executable, str(REPO / "bench" / "quality_noise_source.py"), "--scene", str(path),
                        "--variants", "base", "sun_only"], capture_output=True, text=True, cwd=REPO)
    assert r.returncode == 2 and "no WORLD sky" in r.stderr and "Traceback" not in r.stderr
