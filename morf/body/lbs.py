"""Linear blend skinning (pure function; the vertex shader in morf/playback does the same)."""

from __future__ import annotations

import torch


def linear_blend_skinning(rest_vertices: torch.Tensor, weights: torch.Tensor, bone_transforms: torch.Tensor) -> torch.Tensor:
    """Skin vertices.

    Args:
        rest_vertices: (B, V, 3) shaped rest-pose vertices.
        weights: (V, J) dense skinning weights (rows sum to 1).
        bone_transforms: (B, J, 4, 4) skinning matrices.
    Returns:
        (B, V, 3) posed vertices.
    """
    B, J = bone_transforms.shape[:2]
    blended = torch.einsum("vj,bjk->bvk", weights, bone_transforms[:, :, :3, :].reshape(B, J, 12))
    blended = blended.reshape(B, -1, 3, 4)
    return (blended[..., :3] @ rest_vertices.unsqueeze(-1)).squeeze(-1) + blended[..., 3]
