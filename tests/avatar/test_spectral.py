import numpy as np

from morf.avatar.spectral import graph_laplacian, laplacian_eigenvectors, mesh_spectral_coordinates


def grid_mesh(n=8):
    idx = np.arange(n * n).reshape(n, n)
    faces = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = idx[i, j], idx[i, j + 1], idx[i + 1, j], idx[i + 1, j + 1]
            faces += [[a, b, c], [b, d, c]]
    y, x = np.mgrid[0:n, 0:n]
    return np.array(faces), np.stack([x.ravel(), y.ravel(), np.zeros(n * n)], 1).astype(float)


def test_eigenvectors_satisfy_laplace_equation():
    faces, pos = grid_mesh(10)
    L = graph_laplacian(faces, len(pos))
    vals, vecs = laplacian_eigenvectors(L, 5)
    assert vecs.shape == (100, 5)
    assert np.all(vals > 1e-6)  # the constant (zero) eigenvector is skipped
    for k in range(5):
        assert np.allclose(L @ vecs[:, k], vals[k] * vecs[:, k], atol=1e-8)
    assert np.allclose(vecs.sum(0), 0, atol=1e-8)  # orthogonal to the constant


def test_shift_invert_path_matches_dense():
    faces, pos = grid_mesh(12)
    L = graph_laplacian(faces, len(pos))
    vals, _ = laplacian_eigenvectors(L, 4)
    dense = np.sort(np.linalg.eigvalsh(L.toarray()))[1:5]
    assert np.allclose(vals, dense, atol=1e-8)


def test_small_components_copy_nearest_main_vertex():
    faces, pos = grid_mesh(6)
    extra = np.array([[36, 37, 38]])
    pos2 = np.vstack([pos, [[0.1, 0.1, 0.0], [0.2, 0.1, 0], [0.1, 0.2, 0]]])
    coords = mesh_spectral_coordinates(np.vstack([faces, extra]), pos2, 3)
    assert np.allclose(coords[36], coords[0])
    assert np.allclose(np.abs(coords).max(0), 1.0)


def test_body_spectral_texture(body_model, tmp_path, monkeypatch):
    from morf.avatar.spectral import spectral_texture

    monkeypatch.setenv("MORF_CACHE_DIR", str(tmp_path))
    tex = spectral_texture(body_model, 4, 64, 64)
    assert tex.shape == (4, 64, 64) and np.isfinite(tex).all()
    bare = spectral_texture(body_model, 4, 64, 64, dilate=0)
    cover = (np.abs(bare).sum(0) > 0).mean()
    assert 0.5 < cover < 0.8  # UV islands filled (Anny's atlas covers ~63%), background left at zero
    assert (np.abs(tex).sum(0) > 0).mean() > cover  # dilation grows the islands
    assert list(tmp_path.glob("spectral_*.npz"))  # cached
    assert np.array_equal(spectral_texture(body_model, 4, 64, 64), tex)
