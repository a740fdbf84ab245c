"""MoRF Studio: realistic full-body neural avatars from a monocular video.

The package is split by pipeline stage: capture (ingest) -> body (model) -> fitting ->
raster -> avatar (texture, warp, renderer) -> train -> export -> playback -> bench.
"""

__version__ = "0.1.0"
