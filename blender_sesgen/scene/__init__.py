"""The scene model (pure): objects, motion, materials, textures, lighting, procedural assets."""
