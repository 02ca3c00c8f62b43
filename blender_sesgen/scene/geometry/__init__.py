"""Pure mesh geometry of the scene model's primitives."""
