"""Regenerate the assets in this folder (our own work, GPL-3.0-or-later like the project).

- meshes/torus.obj: a torus (R = 0.5, r = 0.18, 48 x 24 segments), Y up, for MESH examples.
- meshes/pyramid.ply / pyramid.stl: a square pyramid (base 1 x 1 on y = 0, apex y = 1).
- textures/poster.png: a 512x512 multi-scale pattern (discs, bars, speckle) for image textures.
Run with the project venv: python assets/make_assets.py
"""
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def torus_obj(path: Path, R=0.5, r=0.18, nu=48, nv=24) -> None:
    u = np.linspace(0, 2 * np.pi, nu, endpoint=False)
    v = np.linspace(0, 2 * np.pi, nv, endpoint=False)
    lines = ["# torus R=%g r=%g, Y up" % (R, r)]
    for a in u:
        for b in v:
            x, z, y = (R + r * np.cos(b)) * np.cos(a), (R + r * np.cos(b)) * np.sin(a), r * np.sin(b)
            lines.append(f"v {x:.6f} {y:.6f} {z:.6f}")
    for i in range(nu):
        for j in range(nv):
            a, b = i * nv + j + 1, ((i + 1) % nu) * nv + j + 1
            c, d = ((i + 1) % nu) * nv + (j + 1) % nv + 1, i * nv + (j + 1) % nv + 1
            lines.append(f"f {a} {d} {c} {b}")
    path.write_text("\n".join(lines) + "\n")


PYRAMID_V = [(-0.5, 0, -0.5), (0.5, 0, -0.5), (0.5, 0, 0.5), (-0.5, 0, 0.5), (0, 1, 0)]
PYRAMID_F = [(0, 1, 2), (0, 2, 3), (0, 4, 1), (1, 4, 2), (2, 4, 3), (3, 4, 0)]


def pyramid_ply(path: Path) -> None:
    head = ["ply", "format ascii 1.0", f"element vertex {len(PYRAMID_V)}", "property float x",
            "property float y", "property float z", f"element face {len(PYRAMID_F)}",
            "property list uchar int vertex_indices", "end_header"]
    body = [" ".join(map(str, v)) for v in PYRAMID_V] + ["3 " + " ".join(map(str, f)) for f in PYRAMID_F]
    path.write_text("\n".join(head + body) + "\n")


def pyramid_stl(path: Path) -> None:
    out = ["solid pyramid"]
    for f in PYRAMID_F:
        p = np.array([PYRAMID_V[i] for i in f], float)
        n = np.cross(p[1] - p[0], p[2] - p[0])
        n /= np.linalg.norm(n)
        out.append(f"  facet normal {n[0]:.6f} {n[1]:.6f} {n[2]:.6f}\n    outer loop")
        out += [f"      vertex {x:.6f} {y:.6f} {z:.6f}" for x, y, z in p]
        out.append("    endloop\n  endfacet")
    out.append("endsolid pyramid")
    path.write_text("\n".join(out) + "\n")


def poster_png(path: Path, size=512, seed=3) -> None:
    import cv2
    rng = np.random.default_rng(seed)
    img = np.full((size, size, 3), 235, np.uint8)
    for _ in range(140):  # discs at several scales
        c = tuple(int(x) for x in rng.integers(0, size, 2))
        rad = int(rng.choice([4, 8, 16, 32]))
        cv2.circle(img, c, rad, tuple(int(x) for x in rng.integers(0, 200, 3)), -1, cv2.LINE_AA)
    for _ in range(60):  # bars
        p = rng.integers(0, size, 2)
        q = p + rng.integers(-80, 80, 2)
        cv2.line(img, tuple(int(x) for x in p), tuple(int(x) for x in q),
                 tuple(int(x) for x in rng.integers(0, 120, 3)), int(rng.integers(2, 7)), cv2.LINE_AA)
    speckle = rng.integers(-30, 30, (size // 4, size // 4, 1))
    speckle = cv2.resize(speckle.astype(np.float32), (size, size), interpolation=cv2.INTER_NEAREST)
    img = np.clip(img.astype(np.float32) + speckle[:, :, None], 0, 255).astype(np.uint8)
    cv2.imwrite(str(path), img)


if __name__ == "__main__":
    torus_obj(HERE / "meshes" / "torus.obj")
    pyramid_ply(HERE / "meshes" / "pyramid.ply")
    pyramid_stl(HERE / "meshes" / "pyramid.stl")
    poster_png(HERE / "textures" / "poster.png")
    print("assets written to", HERE)
