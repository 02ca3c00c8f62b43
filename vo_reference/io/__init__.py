"""Readers and writers: render folders, EXR, trajectories, datasets."""
