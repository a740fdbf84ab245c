"""An avatar folder is checked on load: manifest fields, file names confined to the folder, sizes
and sha256 sums, and the arrays the rasterizers index with; each problem is one InputError line.

The folders here are written by the same functions ``morf export`` uses (no torch, no ONNX: the
renderer files are placeholder bytes, which loading does not open)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from morf.errors import InputError
from morf.export.avatar_folder import (MANIFEST, load_exported_avatar, read_manifest, write_arrays,
                                       write_manifest)
from morf.export.skeleton import SkinningSkeleton
from morf.io import load_npz, save_npz
from morf.raster.neural_raster import SkinnedMesh
from morf.raster.texture_quant import QuantizedTexture

FIELDS = {"renderer": {"input_layout": "nhwc", "size_multiple": 8},
          "int8_quality": {"psnr_db": 41.0, "psnr_person_db": float("inf")},
          "trained_scale": {"max_pixels_per_metre": 120.0}}


def make_avatar(root: Path, fields: dict = FIELDS) -> Path:
    """A two-bone, one-triangle avatar folder with a manifest as ``morf export`` writes it."""
    root.mkdir(parents=True)
    eye = np.tile(np.eye(3), (2, 1, 1))
    skeleton = SkinningSkeleton.from_arrays({"bone_names": np.array(["root", "spine"]),
                                             "bone_parents": np.array([-1, 0]), "rest_rotations": eye,
                                             "rest_heads": np.array([[0, 0, 0], [0, 0, 0.5]]),
                                             "reference_rotations": eye})
    weights = np.zeros((3, 8), np.float32)
    weights[:, 0] = 1
    mesh = SkinnedMesh(rest_vertices=np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32),
                       uvs=np.array([[0, 0], [1, 0], [0, 1]], np.float32), faces=np.array([[0, 1, 2]], np.int32),
                       bone_indices=np.array([[0] * 8, [1] * 8, [0] * 8], np.int32), bone_weights=weights)
    write_arrays(root, QuantizedTexture(np.full((4, 4, 16), 128, np.uint8), np.full(16, 0.01, np.float32)), mesh,
                 skeleton)
    (root / "renderer.onnx").write_bytes(b"fp32 graph " * 100)
    (root / "renderer_int8.onnx").write_bytes(b"int8 graph " * 100)
    write_manifest(root, json.loads(json.dumps(fields)))
    return root


@pytest.fixture
def avatar(tmp_path) -> Path:
    return make_avatar(tmp_path / "avatar")


def edit_manifest(root: Path, change) -> None:
    m = json.loads((root / MANIFEST).read_text())
    change(m)
    (root / MANIFEST).write_text(json.dumps(m))


def refused(root: Path, verify: bool = True) -> str:
    with pytest.raises(InputError) as e:
        load_exported_avatar(root, verify=verify)
    text = str(e.value)
    assert "\n" not in text
    return text


def test_a_sound_folder_loads(avatar):
    av = load_exported_avatar(avatar)
    assert av.input_layout == "nhwc" and av.size_multiple == 8 and av.skeleton.num_bones == 2
    assert av.mesh.faces.tolist() == [[0, 1, 2]] and av.texture.data.shape == (4, 4, 16)
    assert read_manifest(avatar)["int8_quality"]["psnr_person_db"] == float("inf")  # int8 == fp32 exactly


def _set(path: str, value):
    def change(m):
        *parents, last = path.split(".")
        d = m
        for p in parents:
            d = d[p]
        d[last] = value
    return change


def _delete(key: str):
    return lambda m: m.pop(key)


MANIFEST_DAMAGE = {
    "no renderer section": (_delete("renderer"), "no 'renderer' section"),
    "renderer is a list": (_set("renderer", ["nhwc"]), "'renderer' section must be an object, got"),
    "no input layout": (lambda m: m["renderer"].pop("input_layout"), "renderer.input_layout"),
    "unknown input layout": (_set("renderer.input_layout", "nhwcx"), "renderer.input_layout"),
    "size multiple as text": (_set("renderer.size_multiple", "8"), "renderer.size_multiple"),
    "size multiple zero": (_set("renderer.size_multiple", 0), "renderer.size_multiple"),
    "size multiple a bool": (_set("renderer.size_multiple", True), "renderer.size_multiple"),
    "version as text": (_set("version", "1"), "'version'"),
    "version newer": (_set("version", 99), "newer than this morf"),
    "files a list": (_set("files", []), "'files' must map"),
    "file entry without sum": (lambda m: m["files"]["mesh.npz"].pop("sha256"), "'files' entry mesh.npz"),
    "file size as text": (lambda m: m["files"]["mesh.npz"].__setitem__("bytes", "12"), "'files' entry mesh.npz"),
    "texture not listed": (lambda m: m["files"].pop("texture.npz"), "does not list texture.npz"),
    "trained scale NaN": (_set("trained_scale.max_pixels_per_metre", float("nan")), "max_pixels_per_metre"),
    "trained scale a list": (_set("trained_scale", [3]), "max_pixels_per_metre"),
    "int8 check as text": (_set("int8_quality.psnr_db", "good"), "psnr_db"),
    "native tail a list": (_set("renderer.native_tail", [1]), "native_tail"),
    "native tail channel out of range": (_set("renderer.native_tail", {"int8": {"coverage_channel": 99}}),
                                         "coverage_channel"),
    "native tail zero point": (_set("renderer.native_tail", {"fp32": {"zero_point": -1}}), "zero_point"),
    "native tail head stage": (_set("renderer.native_tail", {"int8": {"head_stage": {"weight": [[1.0]], "bias": []}}}),
                               "head_stage"),
}


@pytest.mark.parametrize("case", sorted(MANIFEST_DAMAGE))
def test_manifest_fields_of_the_wrong_type_are_one_line(avatar, case):
    change, words = MANIFEST_DAMAGE[case]
    edit_manifest(avatar, change)
    text = refused(avatar)
    assert words in text, text
    if case != "version newer":
        assert "export the avatar again" in text
    with pytest.raises(InputError):
        read_manifest(avatar)  # what 'morf play' reads first gives the same error, never a traceback


@pytest.mark.parametrize("content", [b"\xff\xfe\x00binary", b"[" * 100_000, b"{\"format\": ", b"[1, 2]", b"null"])
def test_a_manifest_that_is_no_json_object_is_one_line(avatar, content):
    (avatar / MANIFEST).write_bytes(content)
    refused(avatar)


def test_a_huge_manifest_is_not_read(avatar):
    with open(avatar / MANIFEST, "ab") as f:
        f.truncate(8 * 2**20)
    assert "far more than a manifest holds" in refused(avatar)


@pytest.mark.parametrize("name", ["../outside.txt", "../../outside.txt", "/etc/passwd", "sub/mesh.npz", "..", ".",
                                  "", "a\\b", MANIFEST])
def test_file_names_must_be_plain_names_inside_the_folder(avatar, name):
    edit_manifest(avatar, lambda m: m["files"].__setitem__(name, m["files"]["mesh.npz"]))
    assert "not the name of a file inside the avatar folder" in refused(avatar)


def test_the_error_does_not_tell_whether_an_outside_path_exists(avatar, tmp_path):
    (tmp_path / "exists.txt").write_text("private")
    texts = []
    for name in ("../exists.txt", "../missing.txt"):
        copy = tmp_path / f"copy-{len(texts)}"
        shutil.copytree(avatar, copy)
        edit_manifest(copy, lambda m: m["files"].__setitem__(name, m["files"]["mesh.npz"]))
        texts.append(refused(copy).replace(name, "NAME").replace(str(copy), "FOLDER"))
    assert texts[0] == texts[1]


def test_links_out_of_the_folder_are_refused_alike(avatar, tmp_path):
    (tmp_path / "elsewhere.npz").write_bytes((avatar / "mesh.npz").read_bytes())
    texts = []
    for target in (tmp_path / "elsewhere.npz", tmp_path / "nothing-here.npz"):
        copy = tmp_path / f"copy-{len(texts)}"
        shutil.copytree(avatar, copy)
        (copy / "mesh.npz").unlink()
        os.symlink(target, copy / "mesh.npz")
        texts.append(refused(copy, verify=False).replace(str(copy), "FOLDER"))
    assert texts[0] == texts[1] and "link to a place outside the folder" in texts[0]
    os.symlink(tmp_path / "elsewhere.npz", tmp_path / "manifest-link")
    (avatar / MANIFEST).unlink()
    os.symlink(tmp_path / "manifest-link", avatar / MANIFEST)
    assert "manifest.json is a link to a place outside" in refused(avatar)


def test_a_link_inside_the_folder_is_followed(avatar):
    shutil.move(avatar / "mesh.npz", avatar / "mesh-data.npz")
    os.symlink("mesh-data.npz", avatar / "mesh.npz")
    assert load_exported_avatar(avatar).mesh.faces.shape == (1, 3)


def test_a_bit_flip_is_caught_by_the_sums(avatar):
    data = bytearray((avatar / "renderer_int8.onnx").read_bytes())
    data[len(data) // 2] ^= 0x04
    (avatar / "renderer_int8.onnx").write_bytes(bytes(data))
    text = refused(avatar)
    assert "renderer_int8.onnx" in text and "sha256" in text and "export the avatar again" in text
    assert load_exported_avatar(avatar, verify=False)  # a caller that has just verified may skip the sums


def test_a_cut_file_is_caught_by_its_size_even_without_the_sums(avatar):
    data = (avatar / "renderer.onnx").read_bytes()
    (avatar / "renderer.onnx").write_bytes(data[:-10])
    assert "renderer.onnx" in refused(avatar, verify=False) and "bytes" in refused(avatar, verify=False)


def test_a_missing_file_says_so(avatar):
    (avatar / "skeleton.npz").unlink()
    assert "avatar file missing" in refused(avatar)


def _rewrite(root: Path, file: str, **changes) -> None:
    """Change arrays of ``file`` and record the new sums, as a foreign exporter would."""
    arrays = load_npz(root / file)
    arrays.update(changes)
    for key in [k for k, v in changes.items() if v is None]:
        arrays.pop(key)
    save_npz(root / file, **arrays)
    fields = {k: v for k, v in json.loads((root / MANIFEST).read_text()).items()
              if k not in ("format", "version", "files")}
    write_manifest(root, fields)


ARRAY_DAMAGE = {
    "face index past the vertices": ("mesh.npz", {"faces": np.array([[0, 1, 3]], np.int32)}, "faces"),
    "negative face index": ("mesh.npz", {"faces": np.array([[0, -1, 2]], np.int32)}, "faces"),
    "bone index past the skeleton": ("mesh.npz", {"bone_indices": np.full((3, 8), 2, np.int32)}, "bone_indices"),
    "NaN vertex": ("mesh.npz", {"rest_vertices": np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]], np.float32)},
                   "rest_vertices"),
    "uvs for fewer vertices": ("mesh.npz", {"uvs": np.zeros((2, 2), np.float32)}, "uvs"),
    "float faces": ("mesh.npz", {"faces": np.array([[0, 1, 2]], np.float32)}, "faces"),
    "no weights": ("mesh.npz", {"bone_weights": None}, "bone_weights"),
    "texture of 8 channels": ("texture.npz", {"texture": np.full((4, 4, 8), 128, np.uint8)}, "texture"),
    "float texture": ("texture.npz", {"texture": np.zeros((4, 4, 16), np.float32)}, "texture"),
    "infinite scale": ("texture.npz", {"scales": np.full(16, np.inf, np.float32)}, "scales"),
    "parents out of order": ("skeleton.npz", {"bone_parents": np.array([-1, 1])}, "parents"),
    "heads for one bone": ("skeleton.npz", {"rest_heads": np.zeros((1, 3))}, "rest_heads"),
}


@pytest.mark.parametrize("case", sorted(ARRAY_DAMAGE))
def test_arrays_the_rasterizers_index_with_are_checked(avatar, case):
    file, changes, words = ARRAY_DAMAGE[case]
    _rewrite(avatar, file, **changes)
    text = refused(avatar)
    assert file in text and words in text, text


def _with_view_colours(root: Path, anchors: np.ndarray, colours: np.ndarray) -> None:
    """Add view_colours.npz and record it in the manifest, as ``morf export`` does."""
    from morf.avatar.view_colour import ViewColourBytes
    from morf.export.avatar_folder import write_view_colours

    write_view_colours(root, ViewColourBytes(anchors, colours))
    fields = {k: v for k, v in json.loads((root / MANIFEST).read_text()).items()
              if k not in ("format", "version", "files")}
    write_manifest(root, fields)


def test_view_colours_load_and_bad_ones_are_one_line(avatar):
    eye = np.tile(np.eye(3, dtype=np.float32), (2, 1, 1))
    _with_view_colours(avatar, eye, np.full((2, 4, 4, 3), 150, np.uint8))
    views = load_exported_avatar(avatar).view_colours
    assert views.anchors.shape == (2, 3, 3) and views.data.shape == (2, 4, 4, 3)
    for anchors, colours, words in ((eye, np.full((2, 8, 8, 3), 150, np.uint8), "colours"),  # other texel count
                                    (eye, np.full((3, 4, 4, 3), 150, np.uint8), "colours"),  # other anchor count
                                    (eye, np.zeros((2, 4, 4, 3), np.float32), "colours"),  # not bytes
                                    (eye[:, :2], np.full((2, 4, 4, 3), 150, np.uint8), "anchors"),
                                    (eye * np.nan, np.full((2, 4, 4, 3), 150, np.uint8), "anchors")):
        save_npz(avatar / "view_colours.npz", anchors=anchors, colours=colours)
        fields = {k: v for k, v in json.loads((avatar / MANIFEST).read_text()).items()
                  if k not in ("format", "version", "files")}
        write_manifest(avatar, fields)
        text = refused(avatar)
        assert "view_colours.npz" in text and words in text, text
    (avatar / "view_colours.npz").write_bytes(b"not an npz")  # damaged after export: the sums say so
    assert "view_colours.npz" in refused(avatar)
