"""LPIPS (v0.1, vgg) from weights on disk: the formula, its properties, the loader's refusals."""

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from morf.avatar.lpips import LIN_CHANNELS, LIN_KEYS, LPIPS, find_lpips, load_lpips
from morf.avatar.vgg import VGG16Features
from morf.errors import InputError


@pytest.fixture(scope="module")
def metric(lpips_weights):
    return load_lpips(*lpips_weights)


def _smooth(seed: int, side: int = 32) -> torch.Tensor:
    """(1, 3, side, side) a smooth random image in [0, 1]."""
    g = torch.Generator().manual_seed(seed)
    return F.interpolate(torch.rand(1, 3, 4, 4, generator=g), size=(side, side), mode="bilinear",
                         align_corners=False)


def test_identical_zero_symmetric_positive(metric, lpips_weights):
    assert metric.files == lpips_weights
    assert not any(p.requires_grad for p in metric.parameters())
    x, y = torch.cat([_smooth(1), _smooth(2)]), torch.cat([_smooth(3), _smooth(4)])
    with torch.no_grad():
        assert metric(x, x).tolist() == [0.0, 0.0]
        assert metric(x, x, torch.ones(2, 32, 32)).tolist() == [0.0, 0.0]
        d, back = metric(x, y), metric(y, x)
    assert d.shape == (2,) and (d > 0).all()
    assert torch.allclose(d, back, rtol=1e-5, atol=0)


def test_grows_with_noise(metric):
    x = _smooth(5)
    noise = torch.randn(1, 3, 32, 32, generator=torch.Generator().manual_seed(6))
    with torch.no_grad():
        d = [float(metric(x, (x + s * noise).clamp(0, 1))) for s in (0.0, 0.02, 0.08, 0.3)]
    assert d[0] == 0 and d[1] < d[2] < d[3], d


def _plain_lpips(vgg, lin, a, b, mask=None):
    """Two levels (relu1_2, relu2_2), written out: scale, features, unit norm, lin, mean, sum."""
    shift, scale = np.array([-0.030, -0.088, -0.188]), np.array([0.458, 0.448, 0.450])
    total = 0.0
    for level, stop in enumerate((4, 9)):
        f = []
        for img in (a, b):
            x = (img[0].numpy().astype(np.float64) * 2 - 1 - shift[:, None, None]) / scale[:, None, None]
            with torch.no_grad():
                feat = vgg.features[:stop](torch.from_numpy(x).float()[None])[0].double().numpy()
            f.append(feat / (np.sqrt((feat ** 2).sum(0)) + 1e-10))
        w = lin[LIN_KEYS[level]].double().numpy().reshape(-1)
        d = np.einsum("c,chw->hw", w, (f[0] - f[1]) ** 2)
        if mask is None:
            total += d.mean()
        else:
            k = mask.shape[0] // d.shape[0]  # the mask averaged over k x k cells
            m = mask.reshape(d.shape[0], k, d.shape[1], k).mean((1, 3))
            total += (d * m).sum() / m.sum()
    return total


def test_matches_a_plain_two_level_implementation():
    torch.manual_seed(7)
    vgg = VGG16Features().eval()
    lin = {k: torch.rand(1, c, 1, 1) for k, c in zip(LIN_KEYS, LIN_CHANNELS)}
    for k in LIN_KEYS[2:]:
        lin[k] = torch.zeros_like(lin[k])  # only relu1_2 and relu2_2 count
    two = LPIPS(vgg, lin)
    a, b = _smooth(8), _smooth(9)
    mask = np.zeros((32, 32))
    mask[5:27, 9:20] = 1
    with torch.no_grad():
        assert float(two(a, b)) == pytest.approx(_plain_lpips(vgg, lin, a, b), rel=1e-4)
        person = float(two(a, b, torch.from_numpy(mask).float()[None]))
        assert float(two(a, b, torch.ones(1, 1, 32, 32))) == pytest.approx(float(two(a, b)), rel=1e-5)
        assert np.isnan(float(two(a, b, torch.zeros(1, 1, 32, 32))))  # no person: no value
    assert person == pytest.approx(_plain_lpips(vgg, lin, a, b, mask), rel=1e-4)
    with pytest.raises(ValueError, match="relu5_3"):
        LPIPS(VGG16Features(22), lin)
    with pytest.raises(ValueError, match="16 px"):
        two(torch.rand(1, 3, 8, 8), torch.rand(1, 3, 8, 8))


def test_loader_refuses_bad_files(tmp_path, lpips_weights):
    lin_path, vgg_path = lpips_weights
    lin = torch.load(lin_path, weights_only=True)
    with pytest.raises(InputError, match="LPIPS weights not found"):
        load_lpips(tmp_path / "none.pth", vgg_path)
    cases = {"missing": ({k: v for k, v in lin.items() if k != LIN_KEYS[3]}, f"missing {LIN_KEYS[3]}"),
             "shape": ({**lin, LIN_KEYS[1]: torch.rand(1, 64, 1, 1)}, "(1, 64, 1, 1), expected (1, 128, 1, 1)"),
             "tensor": (torch.rand(3), f"missing {LIN_KEYS[0]}")}
    for name, (content, words) in cases.items():
        torch.save(content, tmp_path / f"{name}.pth")
        with pytest.raises(InputError, match=words.replace("(", r"\(").replace(")", r"\)")):
            load_lpips(tmp_path / f"{name}.pth", vgg_path)
    torch.save({"lin": InputError("not a tensor")}, tmp_path / "object.pth")  # needs full unpickling
    with pytest.raises(InputError, match=r"object\.pth holds objects other than tensors \(morf\.errors\.InputError\), "
                                         r"so it is not loaded, for safety") as e:
        load_lpips(tmp_path / "object.pth", vgg_path)
    assert "weights_only" not in str(e.value)
    (tmp_path / "text.pth").write_text("not a torch file")
    with pytest.raises(InputError, match="damaged or not a PyTorch LPIPS weights"):
        load_lpips(tmp_path / "text.pth", vgg_path)
    with pytest.raises(InputError, match="VGG-16"):
        load_lpips(lin_path, lin_path)  # the lin file is no VGG-16


def test_paths_from_options_or_environment(monkeypatch, lpips_weights):
    lin_path, vgg_path = lpips_weights
    monkeypatch.delenv("MORF_LPIPS_WEIGHTS", raising=False)
    monkeypatch.delenv("MORF_VGG16_WEIGHTS", raising=False)
    assert find_lpips(None, vgg_path) is None  # no LPIPS weights named: not computed
    with pytest.raises(InputError, match="--vgg"):
        find_lpips(lin_path, None)
    monkeypatch.setenv("MORF_LPIPS_WEIGHTS", str(lin_path))
    monkeypatch.setenv("MORF_VGG16_WEIGHTS", str(vgg_path))
    assert find_lpips().files == (lin_path, vgg_path)
