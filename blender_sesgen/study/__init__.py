"""Verification studies (``python -m blender_sesgen study``; docs/studies.md): change one
thing about the world or the camera, run the user's own VO on every variant, report where
it breaks.

Pure (numpy + the standard library), like the rest of the package; Ray is used only
through :mod:`blender_sesgen.farm`, and ``vo_reference`` (exports, evaluation, the report)
only as child processes. Modules, each with one job:

- :mod:`.spec`:     the study file (TOML) -> :class:`~.spec.Study`, errors naming the key;
- :mod:`.script`:   edit an SES script statement by statement (comments kept);
- :mod:`.factors`:  the factor registry: each factor's unit, doc line and how it edits a
                    script; user factors (a statement's tag, a generator option);
- :mod:`.paths`:    "same path" factors: the base's continuous path resampled;
- :mod:`.design`:   one factor at a time, a full grid, a seeded Latin hypercube;
- :mod:`.variants`: the study's plan: variants, their scripts, the distinct renders and
                    the sensor-only variants developed from another render's EXRs;
- :mod:`.systems`:  systems under test: built in, or a command template; one run of one
                    as a child process (timeout, read-only dataset, its own folder);
- :mod:`.results`:  results.json (versioned): aggregates, breaking points, ``compare``;
- :mod:`.runner`:   a whole study: renders, exports, runs, evaluation, report, resumable;
- :mod:`.cli`:      ``study run`` and ``study compare``.
"""
