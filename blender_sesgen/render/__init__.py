"""Render orchestration (pure; bpy only behind ``job``): the plan, the output folder, its locks, sealing, Ctrl-C handling and the sensor plan."""
