"""The scene model (pure): objects, motion, materials, textures, lighting, procedural assets, the quality presets a RENDER statement names."""
