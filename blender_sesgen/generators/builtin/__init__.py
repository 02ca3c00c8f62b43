"""The built-in scene generators (``generate NAME``): each module defines
``generate(seed, **options) -> str`` and a small command line
(``python -m blender_sesgen.generators.builtin.NAME --seed S``); ``sesgen_layout`` holds
their shared helpers. Seed 0 of each is the checked-in ``scenes/NAME.ses``."""
