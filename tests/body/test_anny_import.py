"""Loading the body model leaves torch's compiler unloaded, and torch._dynamo still works after."""

import subprocess
import sys

import pytest
import torch

from morf.body.anny_import import broadcast_shapes

CODE = """
import sys, torch
from morf.body import load_body_model
model = load_body_model("anny")
assert "torch._dynamo" not in sys.modules, "the body model imported torch's compiler"
assert "_dynamo" not in vars(torch)
rest = model.rest(model.default_shape())["rest_vertices"]  # roma's rigid transforms, broadcast_shapes
assert rest.ndim == 3 and "sympy" not in sys.modules, "building the rest model imported sympy"
import roma
wrapped = roma.mappings._procrustes_apply_eager  # left unwrapped by the stand-in
assert wrapped is not None
real = torch._dynamo  # the real module now loads on access
assert "torch._dynamo" in sys.modules and hasattr(real, "optimize")
print("ok")
"""


def test_body_model_load_skips_torch_compiler():
    out = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().endswith("ok")


def test_opt_out_imports_the_real_compiler():
    code = ("import os, sys; os.environ['MORF_FULL_TORCH_IMPORT'] = '1'\n"
            "from morf.body.anny_import import import_anny\nimport_anny()\n"
            "assert 'torch._dynamo' in sys.modules\nprint('ok')")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]


@pytest.mark.parametrize("shapes", [
    ((2, 3), (3,)), ((1,), (4, 1, 5)), ((), (2, 2)), (torch.Size([7, 1]), torch.Size([1, 9])), (3, (2, 3)),
    ((0,), (1,)), ((5, 0, 2), (1, 2)), ((), ()), ((2,),),
])
def test_broadcast_shapes_matches_torch(shapes):
    assert broadcast_shapes(*shapes) == torch.broadcast_shapes(*shapes)
    assert type(broadcast_shapes(*shapes)) is torch.Size


@pytest.mark.parametrize("shapes", [((2, 3), (4,)), ((0,), (2,)), ((2,), (-1,))])
def test_broadcast_shapes_raises_as_torch_does(shapes):
    with pytest.raises(RuntimeError) as ours:
        broadcast_shapes(*shapes)
    with pytest.raises(RuntimeError) as theirs:
        torch.broadcast_shapes(*shapes)
    assert str(ours.value) == str(theirs.value)
