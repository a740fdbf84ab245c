"""Every number a motion file brings is checked where it enters: NaN, inf and absurd values are one
line naming the file, the field and the first bad frame, the same from every reader."""

import numpy as np
import pytest

from morf.errors import InputError
from morf.motion import load_motion
from morf.motion.bvh import read_bvh
from morf.motion.checks import (MAX_ANGLE_RAD, check_duration, check_fps, check_pose_arrays, check_range,
                                number_text)
from motion_files import write_aist, write_amass_smplh, write_amass_smplx, write_capture_fits
from motion_helpers import write_bvh

BAD = {"nan": np.nan, "inf": np.inf, "-inf": -np.inf, "1e30": 1e30}
SHOWN = {"nan": "NaN", "inf": "inf", "-inf": "-inf", "1e30": "1e+30"}


def poke(a: np.ndarray, frame: int, value: float, index=(0,)) -> np.ndarray:
    a = np.array(a, np.float64)
    a[(frame,) + tuple(index)] = value
    return a


def one_line(e) -> str:
    msg = str(e.value)
    assert "\n" not in msg and "Traceback" not in msg
    return msg


def test_number_text_and_range_messages():
    assert [number_text(v) for v in (np.nan, np.inf, -np.inf, 1e30, 0.5)] == ["NaN", "inf", "-inf", "1e+30", "0.5"]
    check_range(np.zeros((4, 3)), "f.npz", "'x'", 1.0, "m", "translation")
    with pytest.raises(InputError) as e:
        check_range(poke(np.zeros((6, 2, 3)), 4, 7.0, (1, 2)), "f.npz", "'x'", 1.0, "m", "translation")
    assert one_line(e) == ("f.npz: 'x' is 7 m at frame 4; every translation must be a finite number within +-1 m: "
                           "fix or cut that frame")
    with pytest.raises(InputError, match=r"'x' is NaN at frame 2;"):  # no unit after NaN
        check_range(poke(np.zeros((6, 3)), 2, np.nan), "f.npz", "'x'", 1.0, "m", "translation")
    with pytest.raises(InputError, match=r"^f.npz: 'x' is -5; every value"):  # no frames, no unit
        check_range(np.array([0.0, -5.0]), "f.npz", "'x'", 1.0, "", "value", frame_axis=False)


def test_first_bad_frame_is_the_earliest_over_every_joint():
    r = poke(poke(np.zeros((10, 5, 3)), 7, np.nan, (0, 0)), 3, 1e30, (4, 2))
    with pytest.raises(InputError, match="is 1e\\+30 rad at frame 3"):
        check_pose_arrays(r, np.zeros((10, 3)), 30.0, "m.npz")


@pytest.mark.parametrize("fps", [0.0, -30.0, np.nan, np.inf, 1e9, 1e-9])
def test_frame_rates_out_of_range(fps):
    with pytest.raises(InputError, match="a motion's frame rate must be between 0.01 and 10000 fps"):
        check_fps(fps, "m.npz")
    assert check_fps(np.float32(120.0), "m.npz") == 120.0


def test_duration_bounds_the_resampled_length():
    check_duration(100, 30.0, "m.npz")
    with pytest.raises(InputError, match="last 27.8 hours; a motion may last at most 8 hours"):
        check_duration(1001, 0.01, "m.npz")


def test_pose_array_shapes():
    with pytest.raises(InputError, match=r"'rotvecs' has shape \(0, 104, 3\) and 'transl' \(0, 3\)"):
        check_pose_arrays(np.zeros((0, 104, 3)), np.zeros((0, 3)), 30.0, "m.npz")
    with pytest.raises(InputError, match="expected \\(T, J, 3\\) and \\(T, 3\\)"):
        check_pose_arrays(np.zeros((8, 312)), np.zeros((8, 3)), 30.0, "m.npz")
    assert check_pose_arrays(np.full((2, 3, 3), MAX_ANGLE_RAD), np.zeros((2, 3)), 24, "m.npz") == 24.0


# ---- each reader, through load_motion (what animate, play, export --gltf --motion and the studio use) ----

def _player(d, rotvecs=None, transl=None, **extra):
    r = np.zeros((6, 104, 3)) if rotvecs is None else rotvecs
    t = np.zeros((6, 3)) if transl is None else transl
    np.savez(d / "m.npz", rotvecs=r, transl=t, **({"fps": 30.0} | extra))
    return d / "m.npz"


def _clip(d, rotvecs=None, transl=None, fps=30.0):
    r = np.zeros((6, 104, 3)) if rotvecs is None else rotvecs
    t = np.zeros((6, 3)) if transl is None else transl
    np.savez(d / "m.npz", morf_motion_version=np.int32(1), rotvecs=r, transl=t, fps=np.float64(fps),
             name=np.str_("c"), source=np.str_("test"))
    return d / "m.npz"


def _amass(d, key, frame, value, index=(0,)):
    path = write_amass_smplh(d / "m.npz", T=8)
    arrays = dict(np.load(path))
    arrays[key] = poke(arrays[key], frame, value, index)
    np.savez(path, **arrays)
    return path


def _amass_x(d, key, frame, value):
    path = write_amass_smplx(d / "m.npz", T=8)
    with np.load(path, allow_pickle=True) as z:  # the published layout carries a pickled dict; rewrite without it
        arrays = {k: z[k] for k in z.files if k != "markers_latent_vids"}
    del arrays["poses"]  # the split keys are what is read then
    arrays[key] = poke(arrays[key], frame, value)
    np.savez(path, **arrays)
    return path


def _aist(d, key, frame, value):
    path = write_aist(d / "m.npz", T=8)
    arrays = dict(np.load(path))
    arrays[key] = poke(arrays[key], frame, value)
    np.savez(path, **arrays)
    return path


# (writer, field named in the message, frame named)
READERS = {
    "player rotvecs": (lambda d, v: _player(d, rotvecs=poke(np.zeros((6, 104, 3)), 4, v, (9, 1))), "'rotvecs'", 4),
    "player transl": (lambda d, v: _player(d, transl=poke(np.zeros((6, 3)), 2, v)), "'transl'", 2),
    "clip rotvecs": (lambda d, v: _clip(d, rotvecs=poke(np.zeros((6, 104, 3)), 5, v)), "'rotvecs'", 5),
    "clip transl": (lambda d, v: _clip(d, transl=poke(np.zeros((6, 3)), 1, v, (2,))), "'transl'", 1),
    "amass poses": (lambda d, v: _amass(d, "poses", 3, v, (100,)), "'poses'", 3),  # a finger: read, so checked
    "amass trans": (lambda d, v: _amass(d, "trans", 6, v), "'trans'", 6),
    "smplx root_orient": (lambda d, v: _amass_x(d, "root_orient", 2, v), "'root_orient'", 2),
    "smplx pose_body": (lambda d, v: _amass_x(d, "pose_body", 7, v), "'pose_body'", 7),
    "aist poses": (lambda d, v: _aist(d, "smpl_poses", 1, v), "'smpl_poses'", 1),
    "aist trans": (lambda d, v: _aist(d, "smpl_trans", 5, v), "'smpl_trans' divided by 'smpl_scaling'", 5),
}


@pytest.mark.parametrize("value", list(BAD))
@pytest.mark.parametrize("reader", list(READERS))
def test_every_reader_refuses_bad_numbers_the_same_way(tmp_path, body_model, reader, value):
    write, field, frame = READERS[reader]
    path = write(tmp_path, BAD[value])
    with pytest.raises(InputError) as e, np.errstate(all="raise"):  # no numpy warning on the way either
        load_motion(path, body_model)
    shown = number_text(1e30 / 93) if "smpl_scaling" in field and value == "1e30" else SHOWN[value]  # metres
    msg = one_line(e)
    assert msg.startswith(f"{path}: {field} is {shown}") and f"at frame {frame};" in msg


@pytest.mark.parametrize("key,value", [("fps", 0.0), ("fps", np.nan), ("fps", -1.0), ("fps", 1e12)])
def test_stored_frame_rates(tmp_path, body_model, key, value):
    with pytest.raises(InputError, match=f"'{key}' is .* fps; a motion's frame rate must be between"):
        load_motion(_player(tmp_path, fps=value), body_model)
    with pytest.raises(InputError, match="'fps' is .* fps; a motion's frame rate"):
        load_motion(_clip(tmp_path, fps=value), body_model)
    path = write_amass_smplh(tmp_path / "a.npz", T=4, fps=value)
    with pytest.raises(InputError, match="'mocap_framerate' is .* fps"):
        load_motion(path, body_model)


def test_text_where_numbers_belong(tmp_path, body_model):
    path = _player(tmp_path, rotvecs=np.array(["0"] * 6))
    with pytest.raises(InputError, match="'rotvecs' holds <U1 values, not numbers"):
        load_motion(path, body_model)
    np.savez(tmp_path / "s.npz", smpl_poses=np.zeros((4, 72)), smpl_trans=np.zeros((4, 3)),
             smpl_scaling=np.array(["big"]))
    with pytest.raises(InputError, match="'smpl_scaling' holds"):
        load_motion(tmp_path / "s.npz", body_model)


@pytest.mark.parametrize("scaling", [0.0, -2.0, np.nan])
def test_aist_scaling(tmp_path, body_model, scaling):
    path = write_aist(tmp_path / "a.npz", T=6, scaling=scaling)
    with pytest.raises(InputError, match="smpl_scaling"), np.errstate(all="raise"):
        load_motion(path, body_model)


def test_motion_fps_flag_is_checked(tmp_path, body_model):
    path = write_aist(tmp_path / "a.npz", T=6)
    for bad in (0.0, np.nan, -5.0):
        with pytest.raises(InputError, match="frame rate given for the motion"):
            load_motion(path, body_model, source_fps=bad)


def test_fits_with_nan_poses(tmp_path, body_model):
    rot = np.zeros((6, 104, 3), np.float32)
    transl = np.zeros((6, 3), np.float32)
    project = write_capture_fits(tmp_path / "cap", rot, transl)
    arrays = dict(np.load(project.fits_path))
    arrays["transl"] = poke(arrays["transl"], 3, np.inf).astype(np.float32)
    np.savez(project.fits_path, **arrays)
    with pytest.raises(InputError, match=r"fits.npz: 'transl' is inf at frame 3"):
        load_motion(project.fits_path, body_model)
    arrays["transl"][3] = 0.0
    arrays["shape"] = np.full((1, 6), np.nan, np.float32)
    np.savez(project.fits_path, **arrays)
    with pytest.raises(InputError, match=r"'shape' is NaN"):
        load_motion(project.fits_path, body_model)


# ---- BVH -------------------------------------------------------------------------------------------

def _bvh_lines(tmp_path, **kw):
    path = tmp_path / "m.bvh"
    write_bvh(path, frames=4, **kw)
    return path, path.read_text().splitlines()


def _edit(path, lines, fn):
    i = lines.index("MOTION")
    head, data = lines[:i + 3], lines[i + 3:]
    head, data = fn(head, data)
    path.write_text("\n".join(head + data) + "\n")
    return path


def _set_value(data, frame, column, value):
    tok = data[frame].split()
    tok[column] = value
    data[frame] = " ".join(tok)
    return data


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e30"])
def test_bvh_rotation_values(tmp_path, value):
    path, lines = _bvh_lines(tmp_path)
    _edit(path, lines, lambda h, d: (h, _set_value(d, 2, 10, value)))  # Spine: X Y Z position, X Y Z rotation
    with pytest.raises(InputError) as e, np.errstate(all="raise"):
        read_bvh(path)
    msg = one_line(e)
    assert msg.startswith(f"{path}: Yrotation of joint 'Spine' is {SHOWN[value]}") and "at frame 2;" in msg


def test_bvh_root_position_in_metres(tmp_path):
    path, lines = _bvh_lines(tmp_path)
    _edit(path, lines, lambda h, d: (h, _set_value(d, 3, 1, "1e9")))  # centimetres: 1e7 m
    with pytest.raises(InputError, match=r"Yposition of joint 'Hips' is 1e\+07 m at frame 3; every translation"):
        read_bvh(path)


@pytest.mark.parametrize("offset", ["nan", "1e30"])
def test_bvh_offsets(tmp_path, offset):
    path, lines = _bvh_lines(tmp_path)
    i = next(k for k, s in enumerate(lines) if s.strip().startswith("OFFSET") and k > 5)
    lines[i] = f"OFFSET 0 {offset} 0"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"the OFFSET of joint '\w+' is (NaN|1e\+27 m); every bone offset"), \
            np.errstate(all="raise"):
        read_bvh(path)


@pytest.mark.parametrize("frame_time", ["0", "-0.0333", "nan", "inf", "-inf"])
def test_bvh_frame_time_must_be_a_time(tmp_path, frame_time):
    path, lines = _bvh_lines(tmp_path)
    _edit(path, lines, lambda h, d: (h[:-1] + [f"Frame Time: {frame_time}"], d))
    with pytest.raises(InputError) as e:
        read_bvh(path)
    assert "is not a time between frames; write the seconds per frame there (0.0333333 for 30 fps)" in one_line(e)


def test_bvh_frame_time_out_of_range_and_rounding(tmp_path):
    path, lines = _bvh_lines(tmp_path)
    _edit(path, lines, lambda h, d: (h[:-1] + ["Frame Time: 1e-9"], d))
    with pytest.raises(InputError, match=r"the frame rate of 'Frame Time: 1e-09' is 1e\+09 fps"):
        read_bvh(path)
    _edit(path, lines, lambda h, d: (h[:-1] + ["Frame Time: .0083333"], d))
    assert read_bvh(path).fps == 120.0
    _edit(path, lines, lambda h, d: (h[:-1] + ["Frame Time: 2"], d))
    assert read_bvh(path).fps == 0.5


def test_bvh_frame_and_channel_counts(tmp_path):
    path, lines = _bvh_lines(tmp_path)
    n = len(lines[-1].split())
    _edit(path, lines, lambda h, d: ([*h[:-2], "Frames: 6", h[-1]], d))
    with pytest.raises(InputError, match=r"'Frames: 6' but 4 frames of data follow; the file may be cut short; "
                                         "correct the Frames: line"):
        read_bvh(path)
    _edit(path, lines, lambda h, d: ([*h[:-2], "Frames: 3", h[-1]], d))
    with pytest.raises(InputError, match=r"'Frames: 3' but 4 frames of data follow; correct the Frames: line"):
        read_bvh(path)
    i_motion = lines.index("MOTION")
    _edit(path, lines, lambda h, d: (h, d[:1] + [d[1] + " 0.5"] + d[2:]))
    with pytest.raises(InputError, match=f"line {i_motion + 5} has {n + 1} values, but the "
                                         f"hierarchy's CHANNELS declare {n} per frame"):
        read_bvh(path)
    _edit(path, lines, lambda h, d: (h, _set_value(d, 0, 4, "abc")))
    with pytest.raises(InputError, match=f"line {i_motion + 4}: 'abc' is not a number"):
        read_bvh(path)
    for bad in ("-2", "x", "1.5"):
        _edit(path, lines, lambda h, d: ([*h[:-2], f"Frames: {bad}", h[-1]], d))
        with pytest.raises(InputError, match="Frames"):
            read_bvh(path)


def test_bvh_frames_wrapped_over_lines_still_read(tmp_path):
    path, lines = _bvh_lines(tmp_path)
    ref = read_bvh(path)

    def wrap(h, d):
        out = []
        for row in d:
            tok = row.split()
            out += [" ".join(tok[:10]), " ".join(tok[10:])]
        return h, out
    _edit(path, lines, wrap)
    np.testing.assert_array_equal(read_bvh(path).local_rotations, ref.local_rotations)


def test_bvh_and_npz_refused_alike_by_load_motion(tmp_path, body_model):
    """The one check module: a NaN rotation reads the same from a BVH and from Anny poses."""
    path, lines = _bvh_lines(tmp_path)
    _edit(path, lines, lambda h, d: (h, _set_value(d, 1, 9, "nan")))
    with pytest.raises(InputError, match=r"is NaN at frame 1; every rotation must be a finite number within"):
        load_motion(path, body_model)
    with pytest.raises(InputError, match=r"is NaN at frame 4; every rotation must be a finite number within"):
        load_motion(_player(tmp_path, rotvecs=poke(np.zeros((6, 104, 3)), 4, np.nan)), body_model)


def test_gltf_animation_refuses_bad_numbers(body_model):
    """The last gate before numbers are written into a .glb."""
    from morf.export.gltf_animation import joint_animation
    from morf.export.skeleton import skeleton_from_body_model

    sk = skeleton_from_body_model(body_model, body_model.default_shape())
    J = sk.num_bones
    with pytest.raises(InputError, match=r"motion 'walk': 'transl' is 1e\+30 m at frame 1"):
        joint_animation(sk, np.zeros((2, J, 3)), poke(np.zeros((2, 3)), 1, 1e30), 30.0, "walk")
    with pytest.raises(InputError, match=r"motion 'walk': frame rate is NaN fps"):
        joint_animation(sk, np.zeros((2, J, 3)), np.zeros((2, 3)), np.nan, "walk")
    assert joint_animation(sk, np.zeros((2, J, 3)), np.zeros((2, 3)), 30.0, "walk").num_frames == 2
