"""int8 playback on another x86 CPU's instruction set: the renderer graph run under QEMU's user-mode
emulation of that CPU, compared with this machine's run and with fp32.

onnxruntime picks its int8 kernels from CPUID: AMX, AVX-512 VNNI, AVX-VNNI or plain AVX2, whose
u8 x s8 products go through different instructions (AVX2's ``vpmaddubsw`` saturates 16-bit sums).
``qemu-x86_64 -cpu MODEL`` reports MODEL's CPUID to the process, so the graph takes that CPU's
kernels; timings under emulation mean nothing, the images are what this checks.

    apt-get install qemu-user
    python tools/isa_check.py AVATAR_DIR [--cpu EPYC-Rome] [--frames 4]

EPYC-Rome (AMD Zen 2) reports AVX2 without AVX-512 or VNNI; QEMU 7.2 emulates no AVX-512, so the
AVX2 kernels are the ones this can reach.

    python tools/isa_check.py AVATAR_DIR --cpu-as avx2|avx512-vnni

runs the other side natively instead, with this CPU's CPUID masked to that class
(:mod:`morf.machine.cpuid_mask`; Linux CPUs with ``cpuid_fault``, a C compiler): the same kernels as on
such a CPU, on this silicon, in seconds, and an AVX-512 class QEMU cannot emulate.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

def images(graph: str | Path, rasters: np.ndarray, threads: int = 0) -> np.ndarray:
    """The graph's ``image`` output over white for each (H, W, 16) raster (``threads`` 0: onnxruntime's default)."""
    import onnxruntime as ort

    opts = ort.SessionOptions()
    opts.intra_op_num_threads = threads
    s = ort.InferenceSession(str(graph), opts, providers=["CPUExecutionProvider"])
    bg = np.full((1, 3, 1, 1), 255, np.float32)
    return np.stack([s.run(["image"], {s.get_inputs()[0].name: x[None], "background": bg})[0][0] for x in rasters])


def child(graph: str, rasters: str, out: str) -> None:
    """The emulated side: say which CPU the process sees, and write the int8 graph's images."""
    import llvmlite.binding as llvm

    f = llvm.get_host_cpu_features()
    print("other CPU:", llvm.get_host_cpu_name(), *(name if f.get(name) else f"no {name}"
                                                       for name in ("avx2", "avx512f", "avx512vnni", "amx-int8")))
    np.save(out, images(graph, np.load(rasters), threads=1))


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return float("inf") if mse == 0 else float(10 * np.log10(255.0 ** 2 / mse))


def main() -> int:
    if sys.argv[1:2] == ["--child"]:  # run by the parent under qemu-x86_64
        child(*sys.argv[2:5])
        return 0
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("avatar", help="an exported avatar folder")
    p.add_argument("--cpu", default="EPYC-Rome", help="a QEMU CPU model (qemu-x86_64 -cpu help)")
    p.add_argument("--cpu-as", default=None, metavar="CLASS",
                   help="mask this CPU's CPUID to a class (avx2 | avx512-vnni) instead of emulating --cpu")
    p.add_argument("--frames", type=int, default=4)
    args = p.parse_args()
    qemu = shutil.which("qemu-x86_64")
    if args.cpu_as:
        from morf.machine.cpuid_mask import masked_environ
        from morf.errors import InputError

        try:
            masked = masked_environ(args.cpu_as)
        except InputError as e:
            print(f"isa_check: {e}", file=sys.stderr)
            return 2
        prefix, extra, other = [], masked, f"the {args.cpu_as} class"
    elif qemu is None:
        print("isa_check: qemu-x86_64 not found (apt-get install qemu-user)", file=sys.stderr)
        return 2
    else:
        prefix, extra, other = [qemu, "-cpu", args.cpu], {}, args.cpu
    from morf.bench.render import bench_motion
    from morf.playback.player import Player
    from morf.raster.camera_paths import front_camera

    avatar = Path(args.avatar)
    rot, tr = bench_motion(10 * args.frames + 5, 104)
    idx = [5 + 10 * i for i in range(args.frames)]
    with Player(avatar, size=640, native=False) as player:
        rasters = np.stack([player.rasterize(rot[i], tr[i], front_camera(640, yaw_deg=10.0 * i))[0].copy()
                            for i in idx])
    out = {"int8": images(avatar / "renderer_int8.onnx", rasters), "fp32": images(avatar / "renderer.onnx", rasters)}
    with tempfile.TemporaryDirectory() as tmp:
        np.save(Path(tmp) / "rasters.npy", rasters)
        site = [q for q in sys.path if q.endswith("site-packages")]
        env = {**os.environ, **extra,
               "PYTHONPATH": os.pathsep.join(site + [str(Path(__file__).resolve().parents[1])])}
        run = subprocess.run([*prefix, os.path.realpath(sys.executable), os.path.realpath(__file__), "--child",
                              str(avatar / "renderer_int8.onnx"), str(Path(tmp) / "rasters.npy"),
                              str(Path(tmp) / "out.npy")], env=env, capture_output=True, text=True)
        if run.returncode != 0:
            print(run.stderr[-3000:], file=sys.stderr)
            return 1
        print(run.stdout.strip())
        out["other"] = np.load(Path(tmp) / "out.npy")
    print(f"{args.frames} frames at 640 x 640 of {avatar}:")
    print(f"  int8 on this CPU vs fp32:   {psnr(out['int8'], out['fp32']):.1f} dB")
    print(f"  int8 on {other} vs fp32: {psnr(out['other'], out['fp32']):.1f} dB")
    diff = np.abs(out["other"].astype(int) - out["int8"].astype(int)).max(-1)
    print(f"  int8 on {other} vs this CPU: {psnr(out['other'], out['int8']):.1f} dB, "
          f"{int((diff > 4).sum())} of {diff.size} pixels differ by more than 4 levels (max {int(diff.max())})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
