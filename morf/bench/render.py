"""``morf bench render --out DIR [--avatar DIR]``: live playback speed at 640x640, end to end.

End to end = pose in, composited image out: numpy bone matrices -> GL neural rasterization ->
read-back (already the renderer's channels-last input) -> int8 renderer + composite (one
onnxruntime graph, 2 threads, no spinning; the compositing's share comes from its profiler).
Without ``--avatar`` it builds synthetic avatars (spectral texture + random-init renderers of
several sizes; speed does not depend on training). Building needs torch; every measurement runs
in a fresh process that never imports torch (their thread pools would interfere). The report also
names the CPU's features (AMX, AVX512-BF16, VNNI, AVX2) and what onnxruntime ran for the renderer
graph, from its profiler: which op types ran as int8 kernels, which converted, which stayed float.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.bench.render_results import (TABLE_COLUMNS, GraphProfile, MeasuredAvatar, OpTime, PlaybackMeasurement,
                                       RenderResult)

VARIANT_NAMES = ("plain_b16", "stem2_b16", "stem4_b16", "stem4_b24", "stem4_b32")  # see morf.sizing.sweep.RENDERERS
DEFAULT_VARIANT = "stem4_b16"  # the "cpu" training preset's renderer
THREADS = 2  # onnxruntime intra-op threads of the measured player


@dataclass(frozen=True)
class RenderOptions:
    """What ``morf bench render`` measures.

    Fields:
        out: folder for render.json and render.md; avatar: an exported avatar folder (None:
        synthetic avatars); size: output side in pixels; frames: timed frames a measurement;
        variants: also the other renderer sizes (synthetic avatars only); raster: auto | gl | cpu,
        the players' rasterization; no_amx: refuse AMX to the measurement; command: the command
        line recorded in render.json.
    """

    out: str
    avatar: str | None = None
    size: int = 640
    frames: int = 60
    variants: bool = True
    raster: str = "auto"
    no_amx: bool = False
    command: str = "morf bench render"


# ---- measurement (child process, torch-free) ------------------------------------------------------
def bench_motion(n: int, num_bones: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A smooth random motion: each joint swings on its own sine, the root turns."""
    rng = np.random.default_rng(seed)
    amp, freq, phase = rng.uniform(0, 0.25, (3, num_bones, 3))
    t = np.arange(n)[:, None, None] / 30.0
    rot = (amp * np.sin(2 * np.pi * (0.3 + freq) * t + 6 * phase)).astype(np.float32)
    rot[:, 0] = 0
    rot[:, 0, 2] = np.linspace(0, 2 * np.pi, n)
    return rot, np.zeros((n, 3), np.float32)


def time_player(p, rot, tr, cams, frames: int, steps: dict | None = None) -> tuple[float, float]:
    """Seconds per frame over frames 5.. of a motion (the first 5 are warm-up, played by the caller),
    and the median milliseconds of the renderer graph alone (network + compositing) on one rasterization. ``steps`` collects the
    player's per-step timings when given."""
    t0 = time.perf_counter()
    for i in range(5, len(rot)):
        p.render(rot[i], tr[i], cams[i])
        if steps is not None:
            for k, v in p.last_timings.items():
                steps.setdefault(k, []).append(v)
    seq = (time.perf_counter() - t0) / frames
    x = p.rasterize(rot[0], tr[0], cams[0])
    rt = []
    for _ in range(max(10, frames // 3)):
        t1 = time.perf_counter()
        p.shade(x)  # the renderer graph: network + compositing
        rt.append((time.perf_counter() - t1) * 1e3)
    return seq, float(np.median(rt))


def measure(avatar_dir: str, size: int, frames: int) -> PlaybackMeasurement:
    """Timings of one avatar (run in a process without torch)."""
    from morf.raster.camera_paths import front_camera
    from morf.playback.player import Player

    rot, tr = bench_motion(frames + 5, 104)
    cams = [front_camera(size, yaw_deg=10.0 * i) for i in range(len(rot))]
    with Player(avatar_dir, size=size, background=(255, 255, 255), threads=THREADS) as p:
        for i in list(range(5)) * 3:  # warm-up: shader compile, ORT's first-run allocations and arena growth
            p.render(rot[i], tr[i], cams[i])
        steps: dict[str, list[float]] = {}
        seq, renderer_ms = time_player(p, rot, tr, cams, frames, steps)
        t0 = time.perf_counter()
        images = list(p.render_sequence((rot[i], tr[i], cams[i]) for i in range(5, len(rot))))
        piped = (time.perf_counter() - t0) / frames
        breakdown = {k: float(np.median(v)) for k, v in steps.items()}
        peak_rss_mb = _peak_rss_mb()  # before the profiling session and the fp32 comparison below
        profile = graph_profile(p, p.rasterize(rot[0], tr[0], cams[0]))
        share = profile.composite_share
        if share is not None:  # the renderer graph also composites: split its time by the profile
            breakdown["composite_ms"] = breakdown["renderer_ms"] * share
            breakdown["renderer_ms"] -= breakdown["composite_ms"]
    compared = range(5, 5 + min(5, frames))
    with Player(avatar_dir, size=size, background=(255, 255, 255), precision="fp32") as p32:
        ref = [p32.render(rot[i], tr[i], cams[i]) for i in compared]
        p32.background = (0, 0, 0)  # the same frames over black: where they differ is the person's coverage
        over_black = [p32.render(rot[i], tr[i], cams[i]) for i in compared]
    image_db, person_db = int8_against_fp32(images[:len(ref)], ref, over_black)
    return PlaybackMeasurement(
        breakdown_ms=breakdown, renderer_only_ms=renderer_ms, peak_rss_mb=peak_rss_mb, kernels=profile,
        composite_share_of_graph=share, threads=THREADS, frame_ms=seq * 1e3, fps_end_to_end=1.0 / seq,
        frame_ms_pipelined=piped * 1e3, fps_pipelined=1.0 / piped,
        tail=_tail_kind(p), raster=p.raster_kind,
        int8_psnr_vs_fp32_image_db=image_db, int8_psnr_vs_fp32_person_db=person_db)


def int8_against_fp32(int8_images, fp32_over_white, fp32_over_black) -> tuple[float, float]:
    """PSNR (dB) of the int8 player's frames (over white) against the fp32 player's, over the
    whole image and over the person: the pixels whose fp32 coverage is above one half (from the
    fp32 frames over white and over black: coverage = 1 - (white - black) / 255)."""
    se_image, se_person, n_person = 0.0, 0.0, 0
    for a, w, b in zip(int8_images, fp32_over_white, fp32_over_black):
        se = ((a.astype(np.float32) - w.astype(np.float32)) / 255.0) ** 2
        coverage = 1.0 - (w.astype(np.float32) - b.astype(np.float32)).mean(-1) / 255.0
        person = coverage > 0.5
        se_image += float(se.mean())
        se_person += float(se[person].sum())
        n_person += int(person.sum()) * 3
    db = lambda mse: float(-10 * np.log10(max(mse, 1e-12)))  # noqa: E731
    return db(se_image / len(int8_images)), db(se_person / n_person) if n_person else float("nan")


# onnxruntime op types by what they compute in: int8 kernels, the float <-> int8 conversions between them
INT8_OPS = ("QLinearConv", "ConvInteger", "MatMulInteger", "MatMulIntegerToFloat", "QGemm", "DynamicQuantizeMatMul",
            "QLinearMatMul", "QLinearAdd", "QLinearMul", "QLinearLeakyRelu", "QLinearSigmoid", "QLinearAveragePool",
            "QLinearGlobalAveragePool", "QLinearConcat", "QLinearSoftmax", "QLinearReduceMean", "QLinearWhere")
CONVERSION_OPS = ("QuantizeLinear", "DequantizeLinear", "DynamicQuantizeLinear")
FLOAT_TYPES = ("float", "float16", "bfloat16", "double")


def _compiled_tail(player) -> bool:
    """Whether the player runs its graph cut before a compiled tail (:mod:`morf.playback.native_tail`)."""
    return getattr(player.renderer, "shader", None) is not None


def int8_line(avatar: MeasuredAvatar, size: int) -> str:
    m = avatar.measurement
    person = ("" if m.int8_psnr_vs_fp32_person_db is None
              else f", person (fp32 coverage > 0.5) {m.int8_psnr_vs_fp32_person_db:.1f} dB")
    return (f"int8 against fp32 on the benchmark's frames at {size} x {size}: image {m.int8_psnr_vs_fp32_image_db:.1f} dB"
            f"{person}; the export's own check on its held-out views: {avatar.int8_psnr_vs_fp32_db:.1f} dB"
            + ("" if avatar.int8_check_db is None else
               f" (the lowest of image and person at every scale it measured, which the player goes by: "
               f"{avatar.int8_check_db:.1f} dB)") + ".")


def raster_words(kind: str) -> str:
    return ("rasterized by the CPU loops (numba; raster_ms: skinning, projection, triangle ids; readback_ms: "
            "texture sampling)" if kind == "cpu" else "rasterized by GL (raster_ms: the draw; readback_ms: its read-back)")


def _tail_kind(player) -> str:
    """'graph', or 'compiled:LAYER' with numba's threading layer (omp, tbb or workqueue: which one
    numba found decides the pass's speed, 1.5 against 3.1 ms at 640x640 on a 2-core Intel Xeon)."""
    if not _compiled_tail(player):
        return "graph"
    import numba

    try:
        return f"compiled:{numba.threading_layer()}"
    except ValueError:  # no parallel region has run yet
        return "compiled"


def tail_words(kind: str) -> str:
    if kind == "graph":
        return "full-resolution tail in the onnxruntime graph"
    layer = kind.partition(":")[2]
    return "full-resolution tail as one compiled pass" + (f" (numba, {layer} threads)" if layer else "")


def op_kind(op: str, input_types: list[str]) -> str:
    """'int8' (an integer kernel), 'conversion' (quantize / dequantize), 'float' (an op left in float:
    its first input is floating point) or '8-bit data' (copies, resizes, shapes on integer tensors)."""
    if op in INT8_OPS:
        return "int8"
    if op in CONVERSION_OPS:
        return "conversion"
    if input_types and input_types[0] in FLOAT_TYPES:
        return "float"
    return "8-bit data"


def graph_profile(player, raster, runs: int = 10) -> GraphProfile:
    """What onnxruntime ran for the renderer graph, from its profiler (a separate session): every
    op type's kind, node count and ms a run (costliest first), each kind's share of the kernel
    time, and the compositing nodes' share (see :class:`GraphProfile`).
    """
    import onnxruntime as ort

    from morf.export.onnx_graph import COMPOSITE_PREFIX
    from morf.playback.onnx_renderer import image_only_graph, session_options

    opts = session_options(size=player.size)  # as the player opens it
    with tempfile.TemporaryDirectory() as tmp:
        opts.enable_profiling = True
        opts.profile_file_prefix = str(Path(tmp) / "profile")
        path = player.avatar.renderer_path(player.precision)
        native = _compiled_tail(player)
        graph = player.renderer.graph if native else (image_only_graph(path) or str(path))
        s = ort.InferenceSession(graph, opts, providers=["CPUExecutionProvider"])  # the graph the player runs
        feeds = {player.renderer.input_name: raster}
        if player.renderer.composites:
            feeds["background"] = player.background_planes
        outputs = [o.name for o in s.get_outputs()][:1 if not native else None]
        for _ in range(runs):
            s.run(outputs, feeds)
        events = json.loads(Path(s.end_profiling()).read_text())
    ops: dict[str, dict] = {}
    total = comp = 0.0
    nodes: dict[str, set] = {}
    for e in events:
        if e.get("cat") != "Node" or not e.get("name", "").endswith("_kernel_time"):
            continue
        a = e.get("args", {})
        op = a.get("op_name", "?")
        types = [next(iter(t)) for t in a.get("input_type_shape", []) if t]
        o = ops.setdefault(op, {"kind": op_kind(op, types), "ms": 0.0})
        nodes.setdefault(op, set()).add(e["name"])
        o["ms"] += e["dur"] / 1e3 / runs
        total += e["dur"]
        comp += e["dur"] if e["name"].startswith(COMPOSITE_PREFIX) else 0.0
    timed = {op: OpTime(o["kind"], len(nodes[op]), o["ms"]) for op, o in ops.items()}
    kinds: dict[str, float] = {}
    for o in timed.values():
        kinds[o.kind] = kinds.get(o.kind, 0.0) + o.ms
    total_ms = sum(kinds.values()) or 1.0
    return GraphProfile(ops=dict(sorted(timed.items(), key=lambda kv: -kv[1].ms)),
                        kind_share={k: v / total_ms for k, v in sorted(kinds.items(), key=lambda kv: -kv[1])},
                        composite_share=(comp / total if total else None) if player.renderer.composites else None)


def cpu_report(model: str, cores: int | None, features: dict) -> str:
    """'MODEL, N cores; AMX no, AVX512-BF16 yes, VNNI yes (AVX-512), AVX2 yes'. AMX that the CPU
    has but the kernel refused this process reads 'AMX refused' (records from before that check
    say only what the flags said)."""
    flags = set(features.get("flags", ()))
    yes = (lambda b: "yes" if b else "no")
    vnni = "yes (AVX-512)" if "avx512_vnni" in flags else ("yes (AVX)" if "avx_vnni" in flags else "no")
    amx = yes("amx_int8" in flags or "amx_bf16" in flags)
    if amx == "yes" and features.get("amx_usable") is False:
        amx = "refused (not usable by this process)"
    return (f"{model}, {cores} cores; AMX {amx}, "
            f"AVX512-BF16 {yes('avx512_bf16' in flags)}, VNNI {vnni}, AVX2 {yes('avx2' in flags)}")


def kernel_summary(profile: GraphProfile, top: int = 4) -> str:
    """One line per kind: its share of the renderer graph's time and its costliest op types."""
    lines = []
    for kind, share in profile.kind_share.items():
        ops = [(op, o) for op, o in profile.ops.items() if o.kind == kind]
        named = ", ".join(f"{op} x{o.nodes} {o.ms:.1f} ms" for op, o in ops[:top])
        more = f", {len(ops) - top} more" if len(ops) > top else ""
        lines.append(f"  {kind}: {100 * share:.0f}% ({named}{more})")
    return "\n".join(lines)


def limit_line(lim: dict, key: str) -> str:
    """One line on the renderer against the CPU's int8 GEMM rate (:mod:`morf.bench.compute_limit`)."""
    return (f"Compute limit ({key}): {lim['renderer_gmacs_per_frame']:.2f} GMAC a frame; int8 GEMM "
            f"{lim['best_gemm_gmacs']:.0f} GMAC/s at best (onnxruntime {lim['onnxruntime_square_gmacs']:.0f} square / "
            f"{lim['onnxruntime_conv-shaped_gmacs']:.0f} conv-shaped) = {lim['fps_at_limit']:.0f} fps for the renderer "
            f"alone; it runs at {lim['renderer_gmacs_achieved']:.0f} GMAC/s, {100 * lim['fraction_of_limit']:.0f} % of that")


def _peak_rss_mb() -> float:
    """This process's peak resident memory. /proc's VmHWM restarts at exec; getrusage's ru_maxrss
    would report the (larger, torch-holding) parent's peak inherited across fork + exec."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _child_main() -> None:
    args = json.loads(sys.argv[1])
    print(json.dumps(measure(args["avatar"], args["size"], args["frames"]).to_dict()))


def run_torch_free(module: str, entry: str, payload: dict, what: str) -> dict:
    """Run ``module.entry()`` in a fresh process that never imports torch (its thread pools would
    interfere), with ``payload`` as JSON in argv[1]; its last stdout line, parsed as JSON."""
    code = f"import sys; sys.modules['torch'] = None\nfrom {module} import {entry}; {entry}()"
    r = subprocess.run([sys.executable, "-c", code, json.dumps(payload)], capture_output=True, text=True,
                       timeout=1200)
    if r.returncode != 0:
        raise RuntimeError(f"{what} failed:\n{r.stderr[-3000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def measure_in_child(avatar: Path, size: int, frames: int) -> dict:
    """:func:`measure` in a fresh process that never imports torch; the measurement as the child
    wrote it (:meth:`PlaybackMeasurement.to_dict`; read it with :meth:`PlaybackMeasurement.from_dict`)."""
    return run_torch_free("morf.bench.render", "_child_main", {"avatar": str(avatar), "size": size, "frames": frames},
                          f"measurement of {avatar}")


# ---- orchestration ----------------------------------------------------------------------------------
def _build(tmp: Path, names: list[str], size: int) -> dict[str, Path]:
    from morf.avatar.renderer import RendererConfig, count_parameters, UNetRenderer
    from morf.body import load_body_model
    from morf.export.synthetic import build_synthetic_avatar

    body = load_body_model("anny")
    built = {}
    from morf.sizing.sweep import RENDERERS

    jobs = [(n, "nhwc") for n in names] + [(DEFAULT_VARIANT, "nchw")]
    for name, layout in jobs:
        key = name if layout == "nhwc" else f"{name}@{layout}"
        cfg = RendererConfig(in_channels=16, rgb_skip=True, **RENDERERS[name])  # as the presets train them
        print(f"building synthetic avatar {key} ({count_parameters(UNetRenderer(cfg)) / 1e6:.2f} M parameters)", file=sys.stderr)
        build_synthetic_avatar(tmp / key, body_model=body, renderer_cfg=cfg, image_size=size, calibration_views=6,
                               heldout_views=2, input_layout=layout)
        built[key] = tmp / key
    return built


def _measure_all(opts: RenderOptions) -> tuple[str, str, dict[str, MeasuredAvatar]]:
    """(main key, the avatar described, {key: MeasuredAvatar}): the given avatar, or synthetic
    avatars built for the occasion, each measured in a torch-free child."""
    with tempfile.TemporaryDirectory() as tmpd:
        if opts.avatar:
            avatars = {"given": Path(opts.avatar)}
            described = str(Path(opts.avatar).resolve())
        else:
            names = list(VARIANT_NAMES) if opts.variants else [DEFAULT_VARIANT]
            avatars = _build(Path(tmpd), names, opts.size)
            described = f"synthetic: spectral texture 256x256x16 + random-init renderer '{DEFAULT_VARIANT}' (cpu preset)"
        per: dict[str, MeasuredAvatar] = {}
        for key, path in avatars.items():
            print(f"measuring {key}", file=sys.stderr)
            m = PlaybackMeasurement.from_dict(measure_in_child(path, opts.size, opts.frames))
            per[key] = MeasuredAvatar.from_manifest(m, json.loads((path / "manifest.json").read_text()))
    return ("given" if opts.avatar else DEFAULT_VARIANT), described, per


def _markdown(result: RenderResult, cpu_line: str, kernels: str) -> str:
    from morf.bench.common import markdown_table

    main_key, size = result.main, result.size
    main = result.avatars[main_key]
    breakdown = main.measurement.breakdown_ms
    md = [f"# Playback speed at {size}x{size} (int8, onnxruntime {THREADS} threads)\n",
          f"Avatar: {result.avatar}. Machine: {cpu_line}.\n",
          markdown_table([a.table_row(key) for key, a in result.avatars.items()], TABLE_COLUMNS),
          "\nBreakdown of one frame (median ms, sequential, " + main_key + "):\n",
          markdown_table([breakdown], list(breakdown)),
          f"\nThe renderer's {tail_words(main.measurement.tail)}; {raster_words(main.measurement.raster)}.\n",
          f"\n{int8_line(main, size)}\n",
          f"\nWhat onnxruntime ran for the renderer graph ({main_key}; share of its kernel time):\n",
          "```\n" + kernels + "\n```\n"]
    if result.compute_limit:
        md.append(limit_line(result.compute_limit, main_key) + "\n")
    return "\n".join(md)


def run_render(opts: RenderOptions) -> RenderResult:
    """Measure playback speed end to end and write render.json and render.md."""
    from morf.bench.common import machine_info, write_results

    t0 = time.time()
    if opts.no_amx:
        from morf.machine.amx_permission import refuse_amx

        refuse_amx()  # before onnxruntime loads here or in the measuring children (they inherit it)
    from morf.machine.features import cpu_summary

    if opts.raster != "auto":
        os.environ["MORF_RASTER"] = opts.raster  # the measuring children's players read it
    machine, features = machine_info(), cpu_summary()
    main_key, described, per = _measure_all(opts)
    main = per[main_key]
    seconds = round(time.time() - t0, 1)
    limit = None
    if main.renderer_config:
        from morf.bench.compute_limit import compute_limit

        print("timing int8 matrix multiplies (the CPU's limit)", file=sys.stderr)
        limit = compute_limit(main.renderer_config, opts.size, main.measurement.renderer_only_ms, THREADS)
    result = RenderResult(size=opts.size, threads=THREADS, frames=opts.frames, machine=machine, cpu_features=features,
                          command=opts.command, avatar=described, main=main_key, avatars=per, seconds=seconds,
                          compute_limit=limit)
    cpu_line = cpu_report(machine["cpu"], machine["cores"], features)
    kernels = kernel_summary(main.measurement.kernels)
    path = write_results(opts.out, "render", result.to_dict(), _markdown(result, cpu_line, kernels))
    print(f"CPU: {cpu_line}")
    print(f"renderer graph kernels ({main_key}; share of its kernel time, op types with node count and ms a run):")
    print(kernels)
    if limit:
        print(limit_line(limit, main_key))
    print(int8_line(main, opts.size))
    tail = tail_words(main.measurement.tail)
    print(f"{main_key}: {main.measurement.fps_end_to_end:.1f} fps end to end, "
          f"{main.measurement.fps_pipelined:.1f} fps pipelined ({tail}; {raster_words(main.measurement.raster)}); "
          f"wrote {path}")
    return result
