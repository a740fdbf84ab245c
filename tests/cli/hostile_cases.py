"""The hostile and mistaken inputs tried through the real commands, one :class:`Case` each.

Every case runs in a folder of its own that is also the working directory (``P``: a private copy
of a tiny trained and exported capture; ``A``: a copy of its avatar folder; the user's other
files beside them), so each command line below reads as a user types it. docs/hostile-inputs.md
lists them with what each must give.
"""

from __future__ import annotations

import json
import shlex
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

import hostile_files as hf
from hostile_runner import leave_stale_lock


@dataclass(frozen=True)
class Case:
    """One command line and what it must give.

    Fields:
        id: the pytest id. area: the group it belongs to (docs/hostile-inputs.md sections).
        command: the arguments after ``morf``, as typed in the case folder; ``{fixture}`` is the
            shared project, ``{here}`` the case folder, ``{bvh}`` a good BVH, ``{bomb}`` a zip bomb.
        expect: what it must give, in words (for the docs).
        setup: ``setup(folder, fixture)`` makes the case's files before the command runs.
        needs: "project" (``P``), "avatar" (``A``) or None.
        rc: the exit codes it may end with; 2 alone for a user error.
        own: paths (files or folders, relative to the case folder) the command may write on success.
        keep: paths inside ``own`` that must still not change (the user's files there).
        says / never_says: text the error line must / must not hold (``{holder_pid}``: the pid of
            the process holding the lock).
        error_from: the command whose error line is expected (``morf run`` reports its stage's).
        hint: a second stderr line allowed after the error (``morf run``'s "run this again").
        check: ``check(folder, outcome) -> problem or None``, a further check of the outcome.
        lock: a project stage a second process holds while the command runs.
        read_only: a folder (relative to the case folder) made read-only first, everything in it
            (skipped where that does not bind).
    """

    id: str
    area: str
    command: str
    expect: str
    setup: Callable | None = None
    needs: str | None = "project"
    rc: tuple[int, ...] = (2,)
    own: tuple[str, ...] = ()
    keep: tuple[str, ...] = ()
    says: tuple[str, ...] = ()
    never_says: tuple[str, ...] = ()
    error_from: str | None = None
    hint: str | None = None
    check: Callable | None = None
    lock: str | None = None
    read_only: str | None = None

    @property
    def cmd(self) -> str:
        return shlex.split(self.command)[0]


def files(named: dict[str, str | bytes]) -> Callable:
    """A setup that writes the user's files ``{path relative to the case folder: content}``."""
    def setup(folder: Path, fixture) -> None:
        for key, content in named.items():
            p = folder / key
            p.parent.mkdir(parents=True, exist_ok=True)
            if isinstance(content, bytes):
                p.write_bytes(content)
            else:
                p.write_text(content)
    return setup


def steps(*setups: Callable) -> Callable:
    def setup(folder: Path, fixture) -> None:
        for s in setups:
            s(folder, fixture)
    return setup


def symlink(name: str, target: str) -> Callable:
    def setup(folder: Path, fixture) -> None:
        (folder / name).symlink_to(target)
    return setup


def made(build: Callable[[Path], object]) -> Callable:
    """A setup that writes the case's input file with ``build(folder)``."""
    return lambda folder, fixture: build(folder)


def bvh(name: str = "m.bvh", **change) -> Callable:
    return lambda folder, fixture: hf.bvh_variant(fixture.bvh, folder / name, **change)


def manifest(change: Callable[[dict], dict], where: str = "A") -> Callable:
    return lambda folder, fixture: hf.edit_json(folder / where / "manifest.json", change)


def project_manifest(change: Callable[[dict], dict]) -> Callable:
    return lambda folder, fixture: hf.edit_json(folder / "P" / "morf_project.json", change)


def openpose(change=None, frames: int = 12) -> Callable:
    return lambda folder, fixture: hf.openpose_folder(folder / "kp", frames=frames, change=change)


def evil_file(where: str) -> Callable:
    return lambda folder, fixture: hf.pickled_checkpoint(folder / where, folder / "CODE-RAN")


def half_run(name: str = "half", checkpoint: bool = True) -> Callable:
    """``P/runs/NAME``: the finished run's config with no avatar.pt (stopped before it finished),
    holding a checkpoint that runs code when unpickled."""
    def setup(folder: Path, fixture) -> None:
        run = folder / "P" / "runs" / name
        run.mkdir()
        shutil.copy2(folder / "P" / "runs" / "morf-tiny" / "config.json", run / "config.json")
        if checkpoint:
            hf.pickled_checkpoint(run / "checkpoint.pt", folder / "CODE-RAN")
    return setup


def stale_lock(stage: str) -> Callable:
    return lambda folder, fixture: leave_stale_lock(folder / "P", stage)


def flipped(path: str, at: float = 0.5) -> Callable:
    return lambda folder, fixture: hf.flip_byte(folder / path, at)


def removed(path: str) -> Callable:
    return lambda folder, fixture: (folder / path).unlink()


def overlays_cut_after(kept: int) -> Callable:
    """The fit's overlays after the first ``kept`` gone, as a fit killed while writing them left them."""
    def setup(folder: Path, fixture) -> None:
        for p in sorted((folder / "P" / "fits" / "overlays").iterdir())[kept:]:
            p.unlink()
    return setup


def _set(doc: dict, keys: tuple, value) -> dict:
    d = doc
    for k in keys[:-1]:
        d = d[k]
    d[keys[-1]] = value
    return doc


def _without(doc: dict, key: str) -> dict:
    doc.pop(key)
    return doc


def _escape_files(name: str) -> Callable[[dict], dict]:
    def change(doc: dict) -> dict:
        doc["files"][name] = {"bytes": 6, "sha256": "0" * 64}
        return doc
    return change


def info_runs(folder: Path, outcome) -> str | None:
    """``morf info --json`` lists the real runs only (not runs/.cache, not a stray file)."""
    try:
        runs = json.loads(outcome.stdout)["runs"]
    except (ValueError, KeyError, TypeError) as e:
        return f"morf info --json printed no runs list ({e}): {outcome.stdout[:300]!r}"
    return None if runs == ["morf-tiny"] else f"morf info lists runs {runs}, expected ['morf-tiny']"


def avatar_exported(folder: Path, outcome) -> str | None:
    """The re-export left a loadable avatar (a manifest naming every file, all present)."""
    m = folder / "P" / "avatar" / "manifest.json"
    try:
        names = json.loads(m.read_text())["files"]
    except (OSError, ValueError, KeyError) as e:
        return f"no readable {m} after export ({e})"
    missing = [n for n in names if not (m.parent / n).is_file()]
    return f"avatar files missing after export: {missing}" if missing else None


def overlays_complete(folder: Path, outcome) -> str | None:
    frames = len(list((folder / "P" / "frames").iterdir()))
    got = len(list((folder / "P" / "fits" / "overlays").iterdir()))
    return None if got == frames else f"{got} fit overlays for {frames} frames after morf fit"


def frames_written(folder: Path, outcome) -> str | None:
    got = sorted(p.name for p in (folder / "frames").glob("0*.png"))
    return None if got == ["000000.png", "000001.png"] else f"expected 2 PNG frames in frames/, found {got}"


def video_written(folder: Path, outcome) -> str | None:
    p = folder / "out.mp4"
    return None if p.is_file() and p.stat().st_size > 0 else "out.mp4 was not written"


CLIP = shlex.quote(str(hf.CLIP))  # a good motion shipped with morf


def play(motion: str = CLIP, out: str = "out.mp4", max_frames: int = 2, size: int = 64, more: str = "",
         what: str = "play A") -> str:
    """A ``morf play`` command line (two small frames: cheap when it works)."""
    return f"{what} --motion {motion} --out {out} --max-frames {max_frames} --size {size}" + (f" {more}" if more else "")


def animate(motion: str = CLIP, **kw) -> str:
    return play(motion, what="animate P", **kw)


INGEST_KP = "ingest N --frames {fixture}/frames --masks {fixture}/ground_truth/masks --keypoints kp"
USER_NOTE = "my notes, not morf's\n"
USER_FRAME = b"\x89PNG\r\n\x1a\n a frame the user drew"
NEVER_PICKLE = ("weights_only", "allow_pickle")

CASES: list[Case] = [
    # ---- outputs: morf export ----------------------------------------------------------------
    Case("export-out-folder-with-user-file", "export output", "export P --out d",
         "refused: d holds a file export did not write; keep.txt stays", files({"d/keep.txt": USER_NOTE}),
         says=("keep.txt", "--force")),
    Case("export-out-is-project", "export output", "export P --out P", "refused: the output is the project"),
    Case("export-out-is-project-force", "export output", "export P --out P --force",
         "refused even with --force: the output is the project"),
    Case("export-out-project-parent-force", "export output", "export P --out . --force",
         "works: the avatar's files are written beside the project, which is not touched", rc=(0,),
         own=("manifest.json", "mesh.npz", "renderer.onnx", "renderer_int8.onnx", "skeleton.npz", "texture.npz")),
    Case("export-out-project-frames-force", "export output", "export P --out P/frames --force",
         "refused even with --force: one of the project's own folders"),
    Case("export-out-run-folder-force", "export output", "export P --out P/runs/morf-tiny --force",
         "refused even with --force: a training run's folder"),
    Case("export-out-symlink-to-project-force", "export output", "export P --out link --force",
         "refused even with --force: a symlink to the project", symlink("link", "P")),
    Case("export-out-is-a-file", "export output", "export P --out notes.txt",
         "refused: the output is an existing file, not a folder", files({"notes.txt": USER_NOTE})),
    Case("export-out-dev-full", "export output", "export P --out /dev/full",
         "refused: not a regular file or folder"),
    Case("export-out-dev-full-force", "export output", "export P --out /dev/full --force",
         "refused even with --force: not a regular file or folder"),
    Case("export-gltf-beside-user-folder", "export output", "export P --gltf X.glb",
         "refused: the avatar folder beside X.glb (X/) holds the user's file", files({"X/keep.txt": USER_NOTE}),
         says=("keep.txt",)),
    Case("export-gltf-over-user-file", "export output", "export P --gltf X.glb --out fresh",
         "refused: X.glb exists and export did not write it", files({"X.glb": b"glTF the user's model"})),
    Case("export-gltf-into-project", "export output", "export P --gltf P/model.glb",
         "refused: export never writes into the project outside P/avatar"),
    Case("export-force-keeps-user-file", "export output", "export P --out d --force",
         "exports into d; the user's keep.txt stays as it was", files({"d/keep.txt": USER_NOTE}),
         rc=(0,), own=("d",), keep=("d/keep.txt",)),
    Case("export-own-place-after-killed-export", "export output", "export P",
         "re-exports P/avatar (its own place, no --force needed), taking over the lock a killed export "
         "left", stale_lock("export"), rc=(0,), own=("P/avatar",), check=avatar_exported),
    Case("export-own-place-with-user-file", "export output", "export P",
         "P/avatar/notes.txt (the user's) survives: refused, or exported around it",
         files({"P/avatar/notes.txt": USER_NOTE}), rc=(0, 2), own=("P/avatar",), keep=("P/avatar/notes.txt",)),

    # ---- outputs: morf play / morf animate ---------------------------------------------------
    Case("play-out-folder-with-user-frames", "playback output", play(out="frames"),
         "refused: the folder holds the user's 000000.png", files({"frames/000000.png": USER_FRAME}),
         needs="avatar", says=("--force",)),
    Case("play-out-user-video", "playback output", play(),
         "refused: out.mp4 exists and play did not write it", files({"out.mp4": b"the user's holiday video"}),
         needs="avatar"),
    Case("play-out-symlink-to-user-folder", "playback output", play(out="link"),
         "refused: the link leads to a folder of the user's frames",
         steps(files({"u/000000.png": USER_FRAME}), symlink("link", "u")), needs="avatar"),
    Case("play-out-dev-full", "playback output", play(out="/dev/full"),
         "refused: /dev/full is not a regular file or folder", needs="avatar"),
    Case("play-force-keeps-user-file", "playback output", play(out="frames", more="--force"),
         "writes 000000.png and 000001.png into frames/; the user's keep.txt stays",
         files({"frames/keep.txt": USER_NOTE}), needs="avatar", rc=(0,), own=("frames",),
         keep=("frames/keep.txt",), check=frames_written),
    Case("animate-out-is-project-force", "playback output", animate(out="P", more="--force"),
         "refused even with --force: the output is the project"),
    Case("animate-out-avatar-folder-force", "playback output",
         animate(out="P/avatar", more="--force"),
         "refused even with --force: the project's avatar folder"),
    Case("animate-new-video-beside-project", "playback output", animate(),
         "writes out.mp4 beside the project, as the README shows; nothing else changes", rc=(0,),
         own=("out.mp4",), check=video_written),

    # ---- run names -----------------------------------------------------------------------------
    Case("train-name-dotdot-restart", "run names", "train P --preset tiny --name .. --restart",
         "refused: '..' is not a run name; nothing deleted"),
    Case("train-name-up-up-restart", "run names", "train P --preset tiny --name ../../victim --restart",
         "refused: a path, not a name; victim/ (the user's) stays", files({"victim/keep.txt": USER_NOTE})),
    Case("train-name-dot-restart", "run names", "train P --preset tiny --name . --restart",
         "refused: '.' would be runs/ itself; nothing deleted"),
    Case("export-run-backslash", "run names", "export P --run 'a\\b'", "refused: holds a separator"),
    Case("train-name-hidden", "run names", "train P --preset tiny --name .hidden",
         "refused: names starting with '.' are the project's own (runs/.cache)"),
    Case("export-run-too-long", "run names", f"export P --run {'x' * 101}", "refused: longer than 100 characters"),
    Case("export-run-dot", "run names", "export P --run .", "refused: '.' is runs/ itself"),
    Case("export-run-dotdot", "run names", "export P --run ..", "refused: '..' is not a run name"),
    Case("export-run-path", "run names", "export P --run ../runs/morf-tiny", "refused: a path, not a name"),
    Case("export-run-hidden", "run names", "export P --run .cache", "refused: runs/.cache is not a run"),
    Case("export-run-empty", "run names", "export P --run ''", "refused: empty"),
    Case("eval-run-dotdot", "run names", "eval P --run ../..", "refused: a path, not a name"),

    # ---- one writer at a time --------------------------------------------------------------------
    Case("lock-train-same-run", "locks", "train P --preset tiny --name second",
         "refused: another process trains run 'second'; the message names it", lock="run-second",
         says=("pid {holder_pid}",)),
    Case("lock-train-restart-held-run", "locks", "train P --preset tiny --name morf-tiny --restart",
         "refused: the run is being written; nothing of it deleted", lock="run-morf-tiny",
         says=("pid {holder_pid}",)),
    Case("lock-fit", "locks", "fit P --preset tiny --restart", "refused: another process fits this project",
         lock="fit", says=("pid {holder_pid}",)),
    Case("lock-export", "locks", "export P", "refused: another process exports this project", lock="export",
         says=("pid {holder_pid}",)),
    Case("lock-run-export-stage", "locks", "run P --preset tiny",
         "morf run reaches its export stage (the avatar was removed) while another process exports: "
         "refused with one line, and the hint to run it again", steps(lambda f, fx: shutil.rmtree(f / "P" / "avatar")),
         lock="export", error_from="export", hint="morf run P", says=("pid {holder_pid}",)),
    Case("lock-eval", "locks", "eval P", "refused: another process evaluates this project", lock="eval",
         says=("pid {holder_pid}",)),

    # ---- resuming after a kill ----------------------------------------------------------------
    Case("fit-redoes-missing-overlays", "resume", "fit P --preset tiny",
         "a fit killed while writing overlays (5 of 12 missing, marked done) is completed: the missing "
         "overlays are made again", overlays_cut_after(7), rc=(0,), own=("P/fits",), check=overlays_complete),

    # ---- numbers given on the command line --------------------------------------------------------
    Case("train-steps-zero", "command-line numbers", "train P --preset tiny --name zero --steps 0",
         "refused: 0 steps would leave an untrained run marked finished"),
    Case("export-calibration-views-zero", "command-line numbers", "export P --out fresh --calibration-views 0",
         "refused"),
    Case("play-max-frames-negative", "command-line numbers", play(max_frames=-5),
         "refused: --max-frames must be 0 or more", needs="avatar"),
    Case("animate-max-frames-negative", "command-line numbers", animate(max_frames=-5),
         "refused, and the message says 'morf animate'"),
    Case("play-fps-nan", "command-line numbers", play(more="--fps nan"), "refused: not a frame rate",
         needs="avatar"),
    Case("play-fps-inf", "command-line numbers", play(more="--fps inf"), "refused: not a frame rate",
         needs="avatar"),
    Case("play-size-zero", "command-line numbers", play(size=0), "refused",
         needs="avatar"),
    Case("play-size-huge", "command-line numbers", play(size=1000000),
         "refused: a 10^12-pixel frame cannot be drawn", needs="avatar"),
    Case("ingest-max-frames-negative", "command-line numbers",
         "ingest N --frames {fixture}/frames --masks {fixture}/ground_truth/masks --max-frames -5", "refused",
         needs=None),
    Case("ingest-every-zero", "command-line numbers",
         "ingest N --frames {fixture}/frames --masks {fixture}/ground_truth/masks --every 0", "refused",
         needs=None),
    Case("ingest-fps-nan", "command-line numbers",
         "ingest N --frames {fixture}/frames --masks {fixture}/ground_truth/masks --fps nan", "refused",
         needs=None),

    # ---- configs ---------------------------------------------------------------------------------
    Case("train-set-nan", "configs", "train P --preset tiny --name cfg --set lr_texture=NaN",
         "refused: not a finite number"),
    Case("train-config-wrong-type", "configs", "train P --name cfg --config cfg.json",
         "refused: steps is not a number", files({"cfg.json": '{"steps": "many"}'})),
    Case("fit-set-inf", "configs", "fit P --preset tiny --restart --set keypoint_weight=1e999",
         "refused: not a finite number; the fits stay"),

    # ---- motions: npz ----------------------------------------------------------------------------
    Case("motion-nan-rotvecs", "motions", play("m.npz"), "refused: NaN in rotvecs", needs="avatar",
         setup=made(lambda d: hf.player_npz(d / "m.npz", rotvecs=_poke(hf.good_poses()[0], np.nan)))),
    Case("motion-inf-transl", "motions", play("m.npz"), "refused: inf in transl", needs="avatar",
         setup=made(lambda d: hf.player_npz(d / "m.npz", transl=_poke(hf.good_poses()[1], np.inf)))),
    Case("motion-1e30-rotvecs", "motions", play("m.npz"), "refused: a rotation of 1e30 rad", needs="avatar",
         setup=made(lambda d: hf.player_npz(d / "m.npz", rotvecs=_poke(hf.good_poses()[0], 1e30)))),
    Case("motion-1e30-transl", "motions", play("m.npz"), "refused: a translation of 1e30 m", needs="avatar",
         setup=made(lambda d: hf.player_npz(d / "m.npz", transl=_poke(hf.good_poses()[1], 1e30)))),
    Case("motion-wrong-bone-count", "motions", play("m.npz"), "refused: 5 bones, not 104", needs="avatar",
         setup=made(lambda d: hf.player_npz(d / "m.npz", rotvecs=np.zeros((8, 5, 3), np.float32)))),
    Case("motion-zero-frames", "motions", play("m.npz"), "refused: no frames", needs="avatar",
         setup=made(lambda d: hf.player_npz(d / "m.npz", rotvecs=np.zeros((0, 104, 3), np.float32),
                                              transl=np.zeros((0, 3), np.float32)))),
    Case("motion-length-mismatch", "motions", play("m.npz"), "refused: 8 rotations, 5 translations",
         needs="avatar", setup=made(lambda d: hf.player_npz(d / "m.npz", transl=hf.good_poses()[1][:5]))),
    Case("motion-fps-zero", "motions", play("m.npz"), "refused: a stored frame rate of 0", needs="avatar",
         setup=made(lambda d: hf.player_npz(d / "m.npz", fps=0.0))),
    Case("clip-nan-rotvecs", "motions", play("m.npz"), "refused: NaN in a MoRF clip", needs="avatar",
         setup=made(lambda d: hf.clip_npz(d / "m.npz", rotvecs=_poke(hf.good_poses()[0], np.nan)))),
    Case("amass-nan-pose", "motions", play("m.npz"), "refused: NaN in AMASS poses", needs="avatar",
         setup=made(lambda d: hf.amass_npz(d / "m.npz", nan_pose=True))),
    Case("npz-that-is-text", "motions", play("m.npz"), "refused: not an .npz; no allow_pickle hint",
         files({"m.npz": "rotvecs,transl\n0,0\n"}), needs="avatar", never_says=NEVER_PICKLE),
    Case("npz-of-pickled-objects", "motions", play("m.npz"), "refused: objects are never unpickled",
         made(lambda d: hf.npz_with_only_objects(d / "m.npz")), needs="avatar", never_says=NEVER_PICKLE),
    Case("npz-claims-huge-array", "motions", play("m.npz"),
         "refused before reading: rotvecs declares 1.2 TB", made(lambda d: hf.npz_claiming_huge_array(d / "m.npz")),
         needs="avatar"),
    Case("npz-zip-bomb", "motions", play("{bomb}"), "refused before reading: 1.5 MB expanding to 320 MiB",
         needs="avatar"),
    Case("motion-is-a-folder", "motions", play("m.npz"), "refused: a folder, not a motion file",
         files({"m.npz/x": "x"}), needs="avatar"),
    Case("gltf-motion-nan", "motions", "export P --gltf X.glb --motion m.npz",
         "refused: NaN motion; no X.glb, no X/",
         made(lambda d: hf.player_npz(d / "m.npz", rotvecs=_poke(hf.good_poses()[0], np.nan)))),

    # ---- motions: BVH ----------------------------------------------------------------------------
    Case("bvh-nan-value", "BVH", play("m.bvh"), "refused: 'nan' in the motion data", bvh(value="nan"),
         needs="avatar"),
    Case("bvh-1e30-offset", "BVH", play("m.bvh"), "refused: a bone 1e30 long", bvh(offset="1e30"),
         needs="avatar"),
    Case("bvh-frame-time-zero", "BVH", play("m.bvh"), "refused: Frame Time 0 is no frame rate (not 30 fps)",
         bvh(frame_time="0"), needs="avatar"),
    Case("bvh-frames-count-mismatch", "BVH", play("m.bvh"), "refused: Frames says 100, 8 follow",
         bvh(frames="100"), needs="avatar"),
    Case("bvh-truncated-motion", "BVH", play("m.bvh"), "refused: cut in the middle of a frame",
         bvh(cut_at=0.97), needs="avatar"),
    Case("bvh-empty", "BVH", play("m.bvh"), "refused: empty file", files({"m.bvh": ""}), needs="avatar"),
    Case("animate-bvh-nan", "BVH", animate("m.bvh"), "refused: 'nan' in the motion data", bvh(value="nan")),

    # ---- avatar folders ----------------------------------------------------------------------------
    Case("avatar-renderer-wrong-type", "avatar folders", play(), "refused: renderer is not an object",
         manifest(lambda m: _set(m, ("renderer",), "fast")), needs="avatar"),
    Case("avatar-no-renderer", "avatar folders", play(), "refused: the manifest has no renderer",
         manifest(lambda m: _without(m, "renderer")), needs="avatar"),
    Case("avatar-size-multiple-zero", "avatar folders", play(), "refused: the renderer's size multiple is 0",
         manifest(lambda m: _set(m, ("renderer", "size_multiple"), 0)), needs="avatar"),
    Case("avatar-size-multiple-wrong-type", "avatar folders", play(), "refused: size multiple 'eight'",
         manifest(lambda m: _set(m, ("renderer", "size_multiple"), "eight")), needs="avatar"),
    Case("avatar-pixels-per-metre-nan", "avatar folders", play(), "refused: a NaN trained scale",
         manifest(lambda m: _set(m, ("trained_scale", "max_pixels_per_metre"), float("nan"))), needs="avatar"),
    Case("avatar-int8-psnr-nan", "avatar folders", play(),
         "refused: the int8 check the player trusts is NaN",
         manifest(lambda m: _set(m, ("int8_quality", "psnr_db"), float("nan"))), needs="avatar"),
    Case("avatar-files-not-a-mapping", "avatar folders", play(), "refused: files is a list",
         manifest(lambda m: _set(m, ("files",), list(m["files"]))), needs="avatar"),
    Case("avatar-file-name-escapes-to-existing", "avatar folders", play(),
         "refused: a file name outside the folder, whether or not it exists",
         steps(files({"secret.txt": "secret\n"}), manifest(_escape_files("../secret.txt"))), needs="avatar"),
    Case("avatar-file-name-escapes-to-missing", "avatar folders", play(),
         "refused the same way: the message does not tell whether the path exists",
         manifest(_escape_files("../nothing.txt")), needs="avatar"),
    Case("avatar-file-name-absolute", "avatar folders", play(), "refused: an absolute file name",
         manifest(_escape_files("/etc/hostname")), needs="avatar"),
    Case("avatar-int8-renderer-flipped-byte", "avatar folders", play(),
         "refused: renderer_int8.onnx does not match its sha256", flipped("A/renderer_int8.onnx", 0.6),
         needs="avatar"),
    Case("avatar-texture-flipped-byte", "avatar folders", play(),
         "refused: texture.npz does not match its sha256", flipped("A/texture.npz", 0.5), needs="avatar"),
    Case("avatar-int8-renderer-missing", "avatar folders", play(),
         "refused: renderer_int8.onnx is missing", removed("A/renderer_int8.onnx"), needs="avatar"),
    Case("avatar-manifest-not-json", "avatar folders", play(), "refused: damaged manifest",
         files({"A/manifest.json": "{\"format\": \"morf-avatar\", "}), needs="avatar"),
    Case("avatar-is-the-project", "avatar folders", play(what="play P"),
         "refused: P is a capture project, not an avatar folder"),

    # ---- pickles ----------------------------------------------------------------------------------
    Case("export-pickled-avatar-file", "pickles", "export P --run morf-tiny --out fresh",
         "refused: avatar.pt is not loaded with pickle; no code runs; no torch hint",
         evil_file("P/runs/morf-tiny/avatar.pt"), never_says=NEVER_PICKLE),
    Case("train-resume-pickled-checkpoint", "pickles", "train P --preset tiny --name half",
         "refused: the checkpoint is not unpickled; no code runs; no torch hint", half_run(),
         never_says=NEVER_PICKLE),

    # ---- OpenPose ---------------------------------------------------------------------------------
    Case("openpose-good", "OpenPose", INGEST_KP, "a good import: only the new project N is written",
         openpose(), needs=None, rc=(0,), own=("N",)),
    Case("openpose-1e30-px", "OpenPose", INGEST_KP, "refused: a keypoint at 1e30 px", needs=None,
         setup=openpose(lambda i, d: _set(d, ("people", 0, "pose_keypoints_2d", 0), 1e30) if i == 3 else d)),
    Case("openpose-nan", "OpenPose", INGEST_KP, "refused: NaN keypoint", needs=None,
         setup=openpose(lambda i, d: _set(d, ("people", 0, "pose_keypoints_2d", 1), float("nan")) if i == 5 else d)),
    Case("openpose-confidence-7", "OpenPose", INGEST_KP, "refused: a confidence outside [0, 1]", needs=None,
         setup=openpose(lambda i, d: _set(d, ("people", 0, "pose_keypoints_2d", 2), 7.0) if i == 2 else d)),
    Case("openpose-people-not-a-list", "OpenPose", INGEST_KP, "refused: people is an object", needs=None,
         setup=openpose(lambda i, d: _set(d, ("people",), d["people"][0]) if i == 1 else d)),
    Case("openpose-short-keypoint-list", "OpenPose", INGEST_KP, "refused: 10 values", needs=None,
         setup=openpose(lambda i, d: _set(d, ("people", 0, "pose_keypoints_2d"), [1.0] * 10) if i == 4 else d)),
    Case("openpose-not-json", "OpenPose", INGEST_KP, "refused: not JSON", needs=None,
         setup=openpose(lambda i, d: "{people: [" if i == 0 else d)),
    Case("openpose-count-mismatch", "OpenPose", INGEST_KP,
         "refused: 11 files for 12 frames, said as a count (not blamed on the names)", needs=None,
         setup=openpose(frames=11), says=("11", "12"), never_says=("do not say",)),

    # ---- ingest and run --------------------------------------------------------------------------
    Case("ingest-over-trained-project", "ingest", "ingest P --frames {fixture}/frames --masks {fixture}/ground_truth/masks",
         "refused without --force: P has fits, runs and an avatar"),
    Case("ingest-into-user-folder", "ingest", "ingest d --frames {fixture}/frames --masks {fixture}/ground_truth/masks",
         "refused: d holds the user's file", files({"d/keep.txt": USER_NOTE}), needs=None),
    Case("ingest-video-without-person", "ingest", "ingest N --video 'grey clip.mp4'",
         "refused (non-zero): no person in any frame; no project left behind",
         made(lambda d: hf.video_without_person(d / "grey clip.mp4")), needs=None),
    Case("ingest-video-is-text", "ingest", "ingest N --video clip.mp4", "refused: not a video",
         files({"clip.mp4": "not a video\n"}), needs=None),
    Case("run-video-without-person", "ingest", "run 'my capture' --video 'grey clip.mp4'",
         "refused by its ingest; the retry hint keeps --video and quotes the paths",
         made(lambda d: hf.video_without_person(d / "grey clip.mp4")), needs=None, error_from="ingest",
         hint=shlex.join(["morf", "run", "my capture", "--video", "grey clip.mp4"])),

    # ---- projects -----------------------------------------------------------------------------------
    Case("info-runs-cache", "projects", "info P --json", "runs/.cache and a stray file are not runs",
         files({"P/runs/notes.txt": USER_NOTE, "P/runs/.cache/x.bin": b"\0" * 8}), rc=(0,),
         check=info_runs),
    Case("info-project-is-a-file", "projects", "info notes.txt", "refused: a file, not a project folder",
         files({"notes.txt": USER_NOTE}), needs=None),
    Case("info-manifest-wrong-type", "projects", "info P", "refused: num_frames is not a number",
         project_manifest(lambda m: _set(m, ("num_frames",), "twelve"))),
    Case("info-manifest-fps-negative", "projects", "info P", "refused: fps must be positive",
         project_manifest(lambda m: _set(m, ("fps",), -30.0))),
    Case("info-manifest-not-json", "projects", "info P", "refused: damaged manifest",
         files({"P/morf_project.json": "{\"format\": "})),
    Case("train-project-is-avatar-folder", "projects", "train P/avatar --preset tiny",
         "refused: an avatar folder, not a capture project"),
    Case("export-unfinished-run", "projects", "export P --run half --out fresh",
         "refused: the run has not finished (no avatar.pt)", half_run(checkpoint=False)),

    # ---- read-only projects ----------------------------------------------------------------------
    Case("read-only-train", "read-only", "train P --preset tiny --name ro", "refused: cannot write, one line",
         read_only="P"),
    Case("read-only-fit", "read-only", "fit P --preset tiny --restart", "refused: cannot write, one line",
         read_only="P"),
    Case("read-only-export", "read-only", "export P", "refused: cannot write, one line", read_only="P"),
    Case("read-only-fits-folder", "read-only", "fit P --preset tiny --restart",
         "refused with one line: P/fits cannot be written (the rest of the project can); the fits stay",
         read_only="P/fits"),
    Case("read-only-avatar-folder", "read-only", "export P",
         "refused with one line: P/avatar cannot be replaced; the avatar stays", read_only="P/avatar"),
    Case("read-only-runs-folder", "read-only", "train P --preset tiny --name ro --steps 2",
         "refused with one line: no run can be made in P/runs", read_only="P/runs"),
]


def _poke(a: np.ndarray, value: float) -> np.ndarray:
    """``a`` (float32) with one value of frame 3 replaced."""
    a = np.array(a, dtype=np.float32)
    a.reshape(a.shape[0], -1)[3, 1] = value
    return a


def by_id() -> dict[str, Case]:
    out = {}
    for c in CASES:
        if c.id in out:
            raise ValueError(f"two cases named {c.id}")
        out[c.id] = c
    return out

