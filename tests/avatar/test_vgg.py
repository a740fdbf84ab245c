import pytest
import torch

from morf.avatar.vgg import PerceptualLoss, VGG16Features, load_vgg16, resolve_vgg_path
from morf.errors import InputError


def test_loads_torchvision_format_state_dict(tmp_path):
    torch.manual_seed(0)
    src = VGG16Features()
    state = {f"features.{k.split('features.', 1)[1]}": v for k, v in src.state_dict().items()}
    state["classifier.0.weight"] = torch.zeros(2, 2)  # torchvision files carry the classifier too
    path = tmp_path / "vgg16.pth"
    torch.save(state, path)
    net = load_vgg16(path)
    assert torch.equal(net.features[0].weight, src.features[0].weight)
    assert not any(p.requires_grad for p in net.parameters())
    feats = net(torch.rand(1, 3, 32, 32), layers=(3, 8, 15, 22))
    assert [f.shape[1] for f in feats] == [64, 128, 256, 512]
    loss = PerceptualLoss(net)
    x = torch.rand(1, 3, 32, 32)
    assert float(loss(x, x)) == 0.0 and float(loss(x, torch.rand(1, 3, 32, 32))) > 0


def test_bad_files_are_one_line_errors(tmp_path, monkeypatch):
    with pytest.raises(InputError):
        load_vgg16(tmp_path / "missing.pth")
    bad = tmp_path / "bad.pth"
    torch.save({"features.0.weight": torch.zeros(1)}, bad)
    with pytest.raises(InputError):
        load_vgg16(bad)
    monkeypatch.setenv("MORF_VGG16_WEIGHTS", str(bad))
    assert resolve_vgg_path(None) == bad
    assert resolve_vgg_path("x.pth").name == "x.pth"
