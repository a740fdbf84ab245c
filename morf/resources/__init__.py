"""Files shipped inside the package: the neural rasterizer's shaders, the font of the comparison
sheets and the studio, and the sample motions (``python -m morf.motion.procedural`` writes them).

Every module finds them through these paths, so an installed wheel has them as a source checkout
does (``pyproject.toml`` lists them as package data).
"""

from pathlib import Path

ROOT = Path(__file__).resolve().parent
SHADERS = ROOT / "shaders"  # neural_raster_{vs,fs}.glsl
FONT = ROOT / "fonts" / "DejaVuSans.ttf"  # with its licence beside it
MOTIONS = ROOT / "motions"  # idle_sway, walk_in_place, walk_forward (.npz)
