"""Materials of SES objects: texture x colour on a Principled BSDF, a library material
(``library``) or a user's image set (bpy).

One data-block per distinct (texture, colour, MATERIAL, spherical mapping), shared by the
objects that use it (a library material's per-object variation comes from the objects'
own properties, see ``library``). Fog wraps the surface shader (RGB only). There is no
ambient term: all light comes from light sources.
"""
from __future__ import annotations

import dataclasses
from typing import Optional

import bpy
import numpy as np

from ..errors import SesgenError
from ..scene.materials import band_colour
from ..scene.model import Material, Scene, SceneObject, Sphere, TextureRef
from . import compat, library, lighting, textures
from .datablocks import tag

DEFAULT_ROUGHNESS = 0.6


class MaterialFactory:
    def __init__(self, scene: Scene, lod: bool = False):
        self.scene = scene
        self.lod = lod             # the library materials' level of detail (library/lod.py)
        self.library_made: list = []   # (material, Material, colour) of every library material
        self.cache: dict = {}
        self._library: dict = {}   # library material (colour aside) -> the first one built
        # a sensor without an IR-cut filter sees library materials in its own band
        self.nir_share = scene.sensor.nir_share if scene.sensor is not None else 0.0

    def get(self, obj: SceneObject):
        mat_model: Optional[Material] = None
        if obj.material:
            try:
                mat_model = self.scene.material(obj.material)
            except KeyError:
                raise SesgenError(f"object {obj.name}: unknown material '{obj.material}'") from None
        tex = obj.texture if obj.texture is not None else (mat_model.texture if mat_model else None)
        colour = tuple(np.multiply(obj.colour, mat_model.colour if mat_model else (1.0, 1.0, 1.0)))
        spherical = isinstance(obj, Sphere) and tex is not None and tex.kind == "image"
        key = (tex, colour, mat_model, spherical)
        if key not in self.cache:
            self.cache[key] = self._make(f"sesgen_{obj.name}", colour, tex, mat_model, spherical)
        return self.cache[key]

    def _make(self, name: str, colour, tex: Optional[TextureRef], m: Optional[Material], spherical: bool = False):
        if m is not None and m.library is not None:
            colour = band_colour(colour, m.library.name, self.nir_share)
            # a library material's graph depends on its colour only through one RGB node: the
            # same material in another colour is a copy of the first (a library graph built
            # through bpy costs ~15 ms: every write to a tree updates all of it)
            key = dataclasses.replace(m, colour=(1.0, 1.0, 1.0))
            first = self._library.get(key)
            if first is not None:
                mat = tag(first.copy())
                mat.name = name
                library.set_colour(compat.node_tree(mat), colour)
                self.library_made.append((mat, m, colour))
                return mat
        mat = tag(bpy.data.materials.new(name))
        nt = compat.node_tree(mat)
        nt.nodes.clear()
        out = nt.nodes.new("ShaderNodeOutputMaterial")
        out.target = "ALL"
        if m is not None and m.library is not None:
            self._library[key] = mat
            self.library_made.append((mat, m, colour))
            return self._finish(mat, nt, out, library.build_shader(nt, m, colour, lod=self.lod))
        if m is not None and m.maps is not None:
            bsdf = library.build_image_maps(nt, m.maps, colour, m.roughness, tag)
            bsdf.inputs["Metallic"].default_value = m.metallic
            return self._finish(mat, nt, out, bsdf.outputs["BSDF"])
        bsdf = nt.nodes.new("ShaderNodeBsdfPrincipled")
        if tex is not None:
            tex_col = textures.texture_colour(nt, tex, spherical)
            mul = nt.nodes.new("ShaderNodeMix")
            mul.data_type, mul.blend_type = "RGBA", "MULTIPLY"
            mul.inputs[0].default_value = 1.0
            nt.links.new(tex_col, mul.inputs[6])
            mul.inputs[7].default_value = (*colour, 1.0)
            nt.links.new(mul.outputs[2], bsdf.inputs["Base Color"])
        else:
            bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
        bsdf.inputs["Roughness"].default_value = m.roughness if m else DEFAULT_ROUGHNESS
        bsdf.inputs["Metallic"].default_value = m.metallic if m else 0.0
        compat.principled_input(bsdf, "Specular IOR Level").default_value = m.specular if m else 0.5
        emission = compat.principled_input(bsdf, "Emission Color")
        if m is not None and m.emission_strength > 0:
            emission.default_value = (*m.emission, 1.0)
            bsdf.inputs["Emission Strength"].default_value = m.emission_strength
        return self._finish(mat, nt, out, bsdf.outputs["BSDF"])

    def _finish(self, mat, nt, out, shader):
        if self.scene.fog is not None:
            shader = lighting.fog_mix(nt, shader, self.scene.fog)
        nt.links.new(shader, out.inputs["Surface"])
        return mat
