"""Scenes: the validated scene model and its two front ends.

:mod:`sphkit.scene.schema` is the model (pydantic, SI units); :mod:`sphkit.scene.files` reads
sphkit's JSON/YAML scene files and the built-in scenes (:func:`sphkit.scene.files.load_scene`
is the entry point); :mod:`sphkit.scene.splishsplash` translates SPlisHSPlasH's JSON scenes.
"""
