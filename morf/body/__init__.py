"""Skinned body models behind one interface (Anny by default; SMPL-X pluggable)."""

from morf.body.model import BodyModel, BodyOutput, BodyPose
from morf.body.render_mesh import RenderMesh, build_render_mesh

__all__ = ["BodyModel", "BodyOutput", "BodyPose", "RenderMesh", "build_render_mesh", "load_body_model"]


def load_body_model(name: str = "anny", device: str = "cpu", **kwargs) -> BodyModel:
    """Create a body model by name. ``"anny"`` needs no files; others need the user's own."""
    if name == "anny":
        from morf.body.anny_model import AnnyBodyModel

        return AnnyBodyModel(**kwargs).to(device)
    raise ValueError(f"unknown body model {name!r}; available: anny")
