#!/usr/bin/env bash
# Check the renderer and the add-on against one Blender version (a venv with its bpy wheel).
# Not a test: a reproducible version check (docs/rendering.md, "Blender versions").
#
#   python3.11 -m venv /tmp/bpy42
#   /tmp/bpy42/bin/pip install 'bpy==4.2.*' 'numpy<2' OpenEXR pytest 'opencv-python-headless<4.12' scipy
#   bench/check_blender_versions.sh /tmp/bpy42 [REFERENCE_VENV] [--no-tests]
#
# 1. renders scenes/minimal.ses and scenes/paper_room.ses (2 frames, 1/4 size, 1 sample)
#    with VENV's bpy, and with REFERENCE_VENV's (default: the repo's .venv) when it differs;
# 2. lists the EXR parts and channel names that version writes and checks the manifest's
#    channel names are among them;
# 3. reads each render through vo_reference.io.sequence.open_sequence, and compares depth
#    and object ids with the reference render (same scene, same pixels: ids must agree,
#    depth to float32 precision);
# 4. runs the render and add-on test files with VENV's Python (unless --no-tests).
# Exit status: 0 when every check passed.
set -euo pipefail

REPO="$(cd "$(dirname "$0")/.." && pwd)"
VENV="${1:?usage: $0 VENV [REFERENCE_VENV] [--no-tests]}"
shift
REF="$REPO/.venv"
RUN_TESTS=1
for a in "$@"; do
    case "$a" in
        --no-tests) RUN_TESTS=0 ;;
        *) REF="$a" ;;
    esac
done
PY="$VENV/bin/python"
REF_PY="$REF/bin/python"
export PYTHONPATH="$REPO${PYTHONPATH:+:$PYTHONPATH}"
cd "$REPO"

"$PY" -c "import bpy, numpy, OpenEXR; print('bpy', bpy.app.version_string, '| numpy', numpy.__version__)"
TAG="$("$PY" -c "import bpy; print('%d.%d.%d' % tuple(bpy.app.version))")"
OUT="$(mktemp -d "${TMPDIR:-/tmp}/sesgen-blender-$TAG.XXXXXX")"
echo "renders in $OUT"

render() {  # python scene out
    "$1" -m blender_sesgen render "scenes/$2.ses" --out "$3" --resolution-scale 0.25 \
        --samples 1 --frames 0:2 --quiet
}
SAME_REF=0
# (venvs' pythons are links to one interpreter: compare the venv folders, not the binaries)
if [ "$(readlink -f "$REF")" = "$(readlink -f "$VENV")" ] || [ ! -x "$REF_PY" ]; then
    SAME_REF=1
fi
for scene in minimal paper_room; do
    render "$PY" "$scene" "$OUT/$scene"
    if [ "$SAME_REF" = 0 ]; then
        render "$REF_PY" "$scene" "$OUT/ref_$scene"
    fi
done

cat > "$OUT/check.py" <<'EOF'
import json, sys
from pathlib import Path
import numpy as np
import OpenEXR
from vo_reference.io.sequence import open_sequence

out = Path(sys.argv[1])
ok = True
for scene in ("minimal", "paper_room"):
    root = out / scene
    m = json.loads((root / "manifest.json").read_text())
    path = root / m["files"]["left"][0]
    with OpenEXR.File(str(path), separate_channels=True) as f:
        parts = [(p.name(), sorted(p.channels)) for p in f.parts]
    names = [n for _, ch in parts for n in ch]
    print(f"{scene}: Blender {m['generator']['blender']}: {len(parts)} EXR part(s), channels {names}")
    wanted = [*m["channels"]["rgb"], m["channels"]["depth"], m["channels"]["object_index"]]
    missing = [n for n in wanted if n not in names]
    if missing:
        ok = False
        print(f"  FAIL: manifest channels not in the file: {missing}")
    seq = open_sequence(root)
    ref_root = out / f"ref_{scene}"
    ref = open_sequence(ref_root) if ref_root.is_dir() else None
    for k in range(2):
        for v in seq.views:
            z, ids, rgb = seq.depth(k, v), seq.ids(k, v), seq.rgb_linear(k, v)
            line = f"  frame {k} {v}: ids {sorted(int(i) for i in np.unique(ids))}, finite depth {np.isfinite(z).mean():.0%}"
            if not np.all(np.isfinite(rgb)) or (ids > 0).sum() == 0:
                ok = False
                line += "  FAIL: no objects or non-finite RGB"
            if ref is not None:
                rz, rids = ref.depth(k, v), ref.ids(k, v)
                bad_ids = int((ids != rids).sum())
                inf_agree = bool((np.isfinite(z) == np.isfinite(rz)).all())
                both = np.isfinite(z) & np.isfinite(rz)
                rel = float((np.abs(z[both] - rz[both]) / rz[both]).max()) if both.any() else 0.0
                line += (f"; vs {ref.manifest['generator']['blender']}: id mismatches {bad_ids}/{ids.size}, "
                         f"depth rel max {rel:.1e}, RGB mean {rgb.mean():.3f} vs {ref.rgb_linear(k, v).mean():.3f}")
                if bad_ids > 0.001 * ids.size or not inf_agree or rel > 1e-4:
                    ok = False
                    line += "  FAIL"
            print(line)
print("geometry and passes: OK" if ok else "geometry and passes: FAILED")
sys.exit(0 if ok else 1)
EOF
STATUS=0
"$PY" "$OUT/check.py" "$OUT" || STATUS=1

if [ "$RUN_TESTS" = 1 ]; then
    "$PY" -m pytest tests/test_render_oracle.py tests/test_render_cli.py tests/test_render_textures.py \
        tests/test_addon_blender.py -q -p no:cacheprovider || STATUS=1
fi
exit $STATUS
