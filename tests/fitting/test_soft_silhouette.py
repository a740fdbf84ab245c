"""The soft silhouette rasterizer: gradients (float64 gradcheck), coverage, culling helpers."""

import torch

from morf.raster.soft_silhouette import front_facing, hard_coverage, signed_distance, soft_silhouette

SQUARE = torch.tensor([[[2.2, 1.3], [6.7, 2.1], [3.1, 6.8], [7.4, 6.2]]], dtype=torch.float64)
FACES = torch.tensor([[0, 1, 2], [1, 3, 2]])


def test_gradcheck_float64():
    v = SQUARE.clone().requires_grad_(True)
    assert torch.autograd.gradcheck(lambda x: soft_silhouette(x, FACES, 8, 9, sigma=0.7), (v,), eps=1e-6, atol=1e-5)


def test_inside_is_one_far_outside_is_zero_and_edges_are_soft():
    s = soft_silhouette(SQUARE, FACES, 8, 9, sigma=0.5)[0]
    assert s[4, 4] == 1.0  # pixel centre (4.5, 4.5) is inside
    assert s[7, 0] == 0.0  # far from both triangles (beyond the margin)
    ring = s[(s > 0) & (s < 1)]
    assert ring.numel() > 0 and ring.max() < 1


def test_signed_distance_sign_and_magnitude():
    tri = torch.tensor([[[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]]]).expand(3, 3, 2)
    pts = torch.tensor([[1.0, 1.0], [1.0, -2.0], [-3.0, 1.0]])
    d = signed_distance(tri, pts)
    assert abs(d[0].item() - 1.0) < 1e-6 and abs(d[1].item() + 2.0) < 1e-6 and abs(d[2].item() + 3.0) < 1e-6
    # winding does not matter
    assert torch.allclose(signed_distance(tri.flip(-2), pts), d)


def test_large_triangle_takes_the_slow_path_and_matches_area():
    tri = torch.tensor([[[0.0, 0.0], [64.0, 0.0], [0.0, 64.0]]])
    cov = hard_coverage(tri[:, None], torch.ones(1, 1, dtype=torch.bool), 64, 64)
    area = cov.sum().item()
    assert abs(area - 64 * 64 / 2) < 64 + 1  # one diagonal row of pixel centres either way


def test_front_facing_halves_a_closed_tetrahedron():
    v = torch.tensor([[[0.0, 0.0, 3.0], [1.0, 0.0, 3.5], [0.0, 1.0, 3.5], [0.3, 0.3, 2.5]]])
    faces = torch.tensor([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    centre = v[0].mean(0)
    tri = v[0][faces]
    n = torch.linalg.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    outward = ((tri[:, 0] - centre) * n).sum(-1) > 0
    faces = torch.where(outward[:, None], faces, faces.flip(1))  # make all windings outward
    front = front_facing(v, faces)[0]
    assert 1 <= int(front.sum()) <= 3
