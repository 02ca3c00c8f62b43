"""A terse builder for Cycles shader node graphs, and what every library recipe gets/returns.

``G`` wraps a node tree: each helper creates nodes and returns an *output socket*; any
input may be a socket (linked) or a constant (set). Recipes get a :class:`Ctx` (metric
pattern coordinates, normal, per-object random numbers, the material's parameters) and
return a :class:`Surface` (colour, roughness, relief height in metres, ...).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Optional

import bpy
import numpy as np

from ...scene.materials import LibraryEntry

Socket = Any   # bpy.types.NodeSocket
Value = Any    # a socket or a constant (float, or a 3/4-tuple)


def _same(current, value) -> bool:
    """Whether writing ``value`` over a property that reads ``current`` would change nothing
    (floats as the property stores them: single precision)."""
    if isinstance(current, (str, bool)) or isinstance(value, (str, bool)):
        return type(current) is type(value) and current == value
    if isinstance(current, (int, float)):
        return isinstance(value, (int, float)) and not isinstance(value, bool) and \
            bool(np.float32(current) == np.float32(value))
    try:
        cur = tuple(current)
    except TypeError:
        return False     # an ID, a pointer: always written
    try:
        return len(cur) == len(value) and bool(np.all(np.asarray(cur, np.float32) == np.asarray(value, np.float32)))
    except (TypeError, ValueError):
        return False


class G:
    """Every write to a node tree through bpy (a new node, a property, a socket value, a link,
    even a node's location) runs Blender's update of the whole tree, so the cost of a graph
    grows with its size per write (a library material of ~100 nodes: ~60 us a write): writes
    that change nothing are skipped, and the nodes' locations (layout only) are written in one
    ``foreach_set`` by :meth:`layout`, which does not update the tree."""

    def __init__(self, nt):
        self.nt = nt
        self._count = 0
        self._placed: dict[int, tuple[float, float]] = {}   # node (its pointer: names change) -> location

    # --- plumbing ----------------------------------------------------------------------

    def node(self, kind: str, inputs: Optional[dict] = None, **props):
        n = self.nt.nodes.new(kind)
        self._placed[n.as_pointer()] = (-200.0 * (self._count % 12), -180.0 * (self._count // 12))
        self._count += 1
        for k, v in props.items():
            if not _same(getattr(n, k), v):
                setattr(n, k, v)
        for k, v in (inputs or {}).items():
            self.set(n.inputs[k] if isinstance(k, int) else n.inputs[k], v)
        return n

    def layout(self) -> None:
        """Place the nodes made so far on a grid (for a person opening the .blend); one write."""
        if not self._placed:
            return
        nodes = self.nt.nodes
        loc = np.zeros(2 * len(nodes), dtype=np.float32)
        nodes.foreach_get("location", loc)
        for i, n in enumerate(nodes):
            xy = self._placed.get(n.as_pointer())
            if xy is not None:
                loc[2 * i:2 * i + 2] = xy
        nodes.foreach_set("location", loc)

    def set(self, socket, value: Value) -> None:
        if value is None:
            return
        if isinstance(value, bpy.types.NodeSocket):
            self.nt.links.new(value, socket)
            return
        if socket.type == "RGBA":
            value = (value,) * 3 + (1.0,) if isinstance(value, (int, float)) else tuple(value)
            value = value + (1.0,) if len(value) == 3 else value
        elif socket.type == "VECTOR" and isinstance(value, (int, float)):
            value = (float(value),) * 3
        if not _same(socket.default_value, value):
            socket.default_value = value

    # --- scalar maths ------------------------------------------------------------------

    def math(self, op: str, a: Value, b: Value = None, c: Value = None, clamp: bool = False) -> Socket:
        n = self.node("ShaderNodeMath", operation=op, use_clamp=clamp)
        for i, v in enumerate((a, b, c)):
            self.set(n.inputs[i], v)
        return n.outputs[0]

    def add(self, a, b):
        return self.math("ADD", a, b)

    def sub(self, a, b):
        return self.math("SUBTRACT", a, b)

    def mul(self, a, b):
        return self.math("MULTIPLY", a, b)

    def madd(self, a, b, c):
        """a * b + c"""
        return self.math("MULTIPLY_ADD", a, b, c)

    def lerp(self, a: Value, b: Value, t: Value) -> Socket:
        n = self.node("ShaderNodeMix", data_type="FLOAT", clamp_factor=True)
        self.set(n.inputs[0], t)
        self.set(n.inputs[2], a)
        self.set(n.inputs[3], b)
        return n.outputs[0]

    def remap(self, x: Value, a: float, b: float, c: Value = 0.0, d: Value = 1.0, smooth: bool = False,
              clamp: bool = True) -> Socket:
        """x from [a, b] to [c, d] (linear or smoothstep), clamped."""
        n = self.node("ShaderNodeMapRange", interpolation_type="SMOOTHSTEP" if smooth else "LINEAR",
                      clamp=clamp)
        for i, v in enumerate((x, a, b, c, d)):
            self.set(n.inputs[i], v)
        return n.outputs[0]

    # --- vectors -----------------------------------------------------------------------

    def vmath(self, op: str, a: Value, b: Value = None, scale: Value = None) -> Socket:
        n = self.node("ShaderNodeVectorMath", operation=op)
        self.set(n.inputs[0], a)
        if b is not None:
            self.set(n.inputs[1], b)
        if scale is not None:
            self.set(n.inputs["Scale"], scale)
        return n.outputs["Value"] if op in ("DOT_PRODUCT", "LENGTH", "DISTANCE") else n.outputs["Vector"]

    def vscale(self, v: Value, s: Value) -> Socket:
        """v * s: s a scalar (socket or number) or a per-axis 3-tuple."""
        if isinstance(s, tuple):
            return self.vmath("MULTIPLY", v, s)
        return self.vmath("SCALE", v, scale=s)

    def sep(self, v: Value) -> tuple[Socket, Socket, Socket]:
        n = self.node("ShaderNodeSeparateXYZ", {0: v})
        return n.outputs[0], n.outputs[1], n.outputs[2]

    def comb(self, x: Value, y: Value, z: Value) -> Socket:
        return self.node("ShaderNodeCombineXYZ", {0: x, 1: y, 2: z}).outputs[0]

    # --- colours -----------------------------------------------------------------------

    def cmix(self, a: Value, b: Value, t: Value, blend: str = "MIX") -> Socket:
        n = self.node("ShaderNodeMix", data_type="RGBA", blend_type=blend, clamp_factor=True)
        self.set(n.inputs[0], t)
        self.set(n.inputs[6], a)
        self.set(n.inputs[7], b)
        return n.outputs[2]

    def cmul(self, a: Value, b: Value) -> Socket:
        """Colour a times colour-or-scalar b."""
        if isinstance(b, (int, float)):
            b = (b, b, b)
        elif isinstance(b, bpy.types.NodeSocket) and b.type == "VALUE":
            b = self.node("ShaderNodeCombineColor", {0: b, 1: b, 2: b}).outputs[0]
        return self.cmix(a, b, 1.0, "MULTIPLY")

    def hsv(self, colour: Value, hue: Value = 0.5, saturation: Value = 1.0, value: Value = 1.0) -> Socket:
        n = self.node("ShaderNodeHueSaturation", {"Hue": hue, "Saturation": saturation, "Value": value,
                                                  "Factor": 1.0, "Color": colour})
        return n.outputs[0]

    def ramp(self, fac: Value, stops, interpolation: str = "LINEAR") -> Socket:
        """stops: [(position, (r, g, b)), ...] -> colour socket."""
        n = self.node("ShaderNodeValToRGB")
        self.set(n.inputs[0], fac)
        cr = n.color_ramp
        cr.interpolation = interpolation
        while len(cr.elements) < len(stops):
            cr.elements.new(0.5)
        for el, (pos, col) in zip(cr.elements, stops):
            el.position = pos
            el.color = (*col, 1.0)
        return n.outputs[0]

    # --- textures ----------------------------------------------------------------------

    def noise(self, p: Value, scale: Value, detail: float = 4.0, roughness: float = 0.5,
              lacunarity: float = 2.0, distortion: float = 0.0, colour: bool = False) -> Socket:
        """fBm noise, centred on 0.5 (normalised); ``scale`` = 1 / feature size."""
        n = self.node("ShaderNodeTexNoise", {"Vector": p, "Scale": scale, "Detail": detail,
                                             "Roughness": roughness, "Lacunarity": lacunarity,
                                             "Distortion": distortion},
                      noise_dimensions="3D", noise_type="FBM", normalize=True)
        return n.outputs["Color" if colour else "Factor"]

    def voronoi(self, p: Value, scale: Value, feature: str = "F1", randomness: float = 1.0,
                metric: str = "EUCLIDEAN", dims: str = "3D"):
        """The Voronoi node (outputs Distance, Color = per-cell random colour, Position)."""
        return self.node("ShaderNodeTexVoronoi", {"Vector": p, "Scale": scale, "Randomness": randomness},
                         voronoi_dimensions=dims, feature=feature, distance=metric)

    def white(self, w: Value) -> Socket:
        """A random number in 0..1 from a scalar (1-D white noise)."""
        return self.node("ShaderNodeTexWhiteNoise", {"W": w}, noise_dimensions="1D").outputs["Value"]

    def bricks(self, uv: Value, width: float, height: float, mortar: float, offset: float = 0.5,
               frequency: int = 2, smooth: float = 0.1) -> tuple[Socket, Socket]:
        """Running-bond cells on 2-D metric coordinates (uv's x, y): (random per cell in 0..1,
        mortar mask 0..1)."""
        n = self.node("ShaderNodeTexBrick", {"Vector": uv, "Color1": (0, 0, 0), "Color2": (1, 1, 1),
                                             "Mortar": (0, 0, 0), "Scale": 1.0, "Mortar Size": mortar,
                                             "Mortar Smooth": smooth, "Bias": 0.0, "Brick Width": width,
                                             "Row Height": height},
                      offset=offset, offset_frequency=frequency, squash=1.0, squash_frequency=2)
        rand = self.sep(n.outputs["Color"])[0]
        return rand, n.outputs["Factor"]


def box_uv(g: G, p, n):
    """Box mapping: ``p`` with its axes permuted so that the two lying in the surface come
    first (the axis nearest the normal last): normal ~y -> (x, z, y), ~x -> (z, y, x),
    ~z -> (x, y, z). Returns (uv, tangent_u, tangent_v) in object space."""
    nx, ny, nz = g.sep(g.vmath("ABSOLUTE", n))
    fy = g.math("GREATER_THAN", g.sub(ny, g.math("MAXIMUM", nx, nz)), 0.0)
    fx = g.mul(g.math("GREATER_THAN", g.sub(nx, g.math("MAXIMUM", ny, nz)), 0.0), g.sub(1.0, fy))
    fz = g.sub(g.sub(1.0, fy), fx)
    x, y, z = g.sep(p)

    def pick(a, b, c):  # fy * a + fx * b + fz * c
        return g.add(g.add(g.mul(fy, a), g.mul(fx, b)), g.mul(fz, c))
    uv = g.comb(pick(x, z, x), pick(z, y, y), pick(y, x, z))
    tu = g.comb(g.add(fy, fz), 0.0, fx)          # the object axis along u
    tv = g.comb(0.0, g.add(fx, fz), fy)          # the object axis along v
    return uv, tu, tv


@dataclass
class Ctx:
    """What a recipe gets. ``p``: metric object coordinates plus the object's offset, times
    the material's texture_scale; ``uv``: ``p`` with its first two axes in the surface
    (box mapping); ``n``: object-space normal; ``rand``: three per-object numbers in 0..1."""
    g: G
    p: Socket
    uv: Socket
    n: Socket
    rand: tuple[Socket, Socket, Socket]
    colour: Socket                 # the main albedo (an RGB node's output)
    roughness: float
    metallic: float
    wear: float
    entry: LibraryEntry


@dataclass
class Surface:
    """What a recipe returns (constants or sockets). ``height`` in metres (shading-only
    relief); ``grime`` scales the generic dirt layer (0 where the recipe ages itself);
    ``extra``: other Principled BSDF inputs by name."""
    colour: Value
    roughness: Value
    height: Value = None
    metallic: Value = 0.0
    grime: float = 1.0
    extra: dict = field(default_factory=dict)
