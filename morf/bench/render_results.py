"""What ``morf bench render`` measures, as typed results: the onnxruntime profile of the renderer
graph, one avatar's playback timings (they travel from the torch-free measuring child as JSON),
and ``render.json``."""

from __future__ import annotations

from dataclasses import dataclass

from morf.bench.records import FlatRecord


@dataclass(frozen=True)
class OpTime(FlatRecord):
    """One onnxruntime op type of the renderer graph's profile.

    Fields:
        kind: see :func:`morf.bench.render.op_kind`; nodes: graph nodes of this type that ran; ms: their kernel time a run.
    """

    kind: str
    nodes: int
    ms: float


@dataclass(frozen=True)
class GraphProfile:
    """What onnxruntime ran for the renderer graph (:func:`graph_profile`).

    Fields:
        ops: op type -> OpTime, costliest first; kind_share: kind -> share of the kernel time;
        composite_share: share of the kernel time in the compositing nodes (None for a graph that
            does not composite).
    """

    ops: dict[str, OpTime]
    kind_share: dict[str, float]
    composite_share: float | None

    def to_dict(self) -> dict:
        return {"ops": {op: o.to_dict() for op, o in self.ops.items()}, "kind_share": dict(self.kind_share),
                "composite_share": self.composite_share}

    @staticmethod
    def from_dict(d: dict) -> GraphProfile:
        return GraphProfile({op: OpTime.from_dict(o) for op, o in d["ops"].items()}, dict(d["kind_share"]),
                            d["composite_share"])


@dataclass(frozen=True)
class PlaybackMeasurement:
    """Timings of one avatar (:func:`measure`); travels from the measuring child as JSON.

    Fields:
        breakdown_ms: the player's steps, median ms a frame (with ``composite_ms`` split off the
            renderer's when the graph composites); renderer_only_ms: the renderer graph alone, median;
        peak_rss_mb: the measuring process's peak memory; kernels: the renderer graph's profile;
        composite_share_of_graph: compositing's share of the graph's kernel time (None: the graph
            does not composite; then left out of :meth:`to_dict`);
        threads: onnxruntime intra-op threads; frame_ms, fps_end_to_end: sequential, end to end;
        frame_ms_pipelined, fps_pipelined: through ``render_sequence``;
        int8_psnr_vs_fp32_image_db: the int8 player's frames against the fp32 player's;
        int8_psnr_vs_fp32_person_db: the same over the person (fp32 coverage above one half; None in
            records from before it was measured);
        tail: "compiled:LAYER" when the graph's full-resolution tail ran as the player's compiled pass
            (LAYER: numba's threading layer; ``renderer_only_ms`` and the breakdown's ``renderer_ms``
            then include it, ``graph_ms`` and ``tail_ms`` split them), "graph" when onnxruntime ran
            the whole graph.
        raster: "cpu" when the player rasterized with the numba loops (:mod:`morf.raster.cpu_raster`;
            the breakdown's ``raster_ms`` is then skinning, projection and triangle ids, its
            ``readback_ms`` the texture sampling into the renderer's input), "gl" for the GL draw
            and its read-back.
    """

    breakdown_ms: dict[str, float]
    renderer_only_ms: float
    peak_rss_mb: float
    kernels: GraphProfile
    threads: int
    frame_ms: float
    fps_end_to_end: float
    frame_ms_pipelined: float
    fps_pipelined: float
    int8_psnr_vs_fp32_image_db: float
    composite_share_of_graph: float | None = None
    tail: str = "graph"
    raster: str = "gl"
    int8_psnr_vs_fp32_person_db: float | None = None

    def to_dict(self) -> dict:
        d = {"breakdown_ms": dict(self.breakdown_ms), "renderer_only_ms": self.renderer_only_ms,
             "peak_rss_mb": self.peak_rss_mb, "kernels": self.kernels.to_dict()}
        if self.composite_share_of_graph is not None:
            d["composite_share_of_graph"] = self.composite_share_of_graph
        d.update(threads=self.threads, frame_ms=self.frame_ms, fps_end_to_end=self.fps_end_to_end,
                 frame_ms_pipelined=self.frame_ms_pipelined, fps_pipelined=self.fps_pipelined,
                 int8_psnr_vs_fp32_image_db=self.int8_psnr_vs_fp32_image_db, tail=self.tail, raster=self.raster)
        if self.int8_psnr_vs_fp32_person_db is not None:
            d["int8_psnr_vs_fp32_person_db"] = self.int8_psnr_vs_fp32_person_db
        return d

    @staticmethod
    def from_dict(d: dict) -> PlaybackMeasurement:
        return PlaybackMeasurement(
            breakdown_ms=dict(d["breakdown_ms"]), renderer_only_ms=d["renderer_only_ms"], peak_rss_mb=d["peak_rss_mb"],
            kernels=GraphProfile.from_dict(d["kernels"]), threads=d["threads"], frame_ms=d["frame_ms"],
            fps_end_to_end=d["fps_end_to_end"], frame_ms_pipelined=d["frame_ms_pipelined"],
            fps_pipelined=d["fps_pipelined"], int8_psnr_vs_fp32_image_db=d["int8_psnr_vs_fp32_image_db"],
            composite_share_of_graph=d.get("composite_share_of_graph"), tail=d.get("tail", "graph"),
            raster=d.get("raster", "gl"), int8_psnr_vs_fp32_person_db=d.get("int8_psnr_vs_fp32_person_db"))


TABLE_COLUMNS = ["avatar", "renderer ms", "frame ms", "fps", "fps pipelined", "int8 PSNR dB", "peak RSS MB", "tail"]


@dataclass(frozen=True)
class MeasuredAvatar:
    """One avatar of ``morf bench render``: its measurement and what its export's manifest says.

    Fields:
        measurement: the timings; int8_psnr_vs_fp32_db, int8_ssim_vs_fp32: the export's int8 check
        against fp32; renderer_config: the renderer's config (None when the manifest has none);
        input_layout: the renderer's input layout (nhwc | nchw); int8_check_db: the export's check
        the player goes by, the lowest of image and person at every scale it measured
        (:func:`morf.export.avatar_folder.int8_check_db`).
    """

    measurement: PlaybackMeasurement
    int8_psnr_vs_fp32_db: float
    int8_ssim_vs_fp32: float
    renderer_config: dict | None
    input_layout: str
    int8_check_db: float | None = None

    @staticmethod
    def from_manifest(measurement: PlaybackMeasurement, manifest: dict) -> MeasuredAvatar:
        from morf.export.avatar_folder import int8_check_db

        return MeasuredAvatar(measurement, manifest["int8_quality"]["psnr_db"], manifest["int8_quality"]["ssim"],
                              manifest["renderer"]["config"], manifest["renderer"]["input_layout"],
                              int8_check_db(manifest))

    def to_dict(self) -> dict:
        return {**self.measurement.to_dict(), "int8_psnr_vs_fp32_db": self.int8_psnr_vs_fp32_db,
                "int8_ssim_vs_fp32": self.int8_ssim_vs_fp32, "renderer_config": self.renderer_config,
                "input_layout": self.input_layout, "int8_check_db": self.int8_check_db}

    def table_row(self, name: str) -> dict:
        """This avatar's row of the report's table (:data:`TABLE_COLUMNS`)."""
        m = self.measurement
        return {"avatar": name, "renderer ms": m.renderer_only_ms, "frame ms": m.frame_ms, "fps": m.fps_end_to_end,
                "fps pipelined": m.fps_pipelined, "int8 PSNR dB": self.int8_psnr_vs_fp32_db,
                "peak RSS MB": m.peak_rss_mb, "tail": m.tail}


@dataclass(frozen=True)
class RenderResult:
    """``render.json``: the headline numbers are those of ``avatars[main]``.

    Fields:
        size, threads, frames: the measurement's image side, onnxruntime threads and timed frames;
        machine: :func:`morf.bench.common.machine_info`; cpu_features: :func:`morf.machine.features.cpu_summary`;
        command: the command line; avatar: what was measured (a folder, or the synthetic avatars);
        main: the headline avatar ("given" or :data:`DEFAULT_VARIANT`); avatars: name -> MeasuredAvatar;
        seconds: wall time of building and measuring;
        compute_limit: :func:`morf.bench.compute_limit.compute_limit` of the headline avatar (None:
            its renderer config is unknown; then left out of :meth:`to_dict`).
    """

    size: int
    threads: int
    frames: int
    machine: dict
    cpu_features: dict
    command: str
    avatar: str
    main: str
    avatars: dict[str, MeasuredAvatar]
    seconds: float
    compute_limit: dict | None = None

    @property
    def headline(self) -> MeasuredAvatar:
        return self.avatars[self.main]

    def to_dict(self) -> dict:
        a = self.headline
        m = a.measurement
        d = {"benchmark": "render", "size": self.size, "precision": "int8", "threads": self.threads,
             "frames": self.frames, "machine": self.machine, "cpu_features": self.cpu_features,
             "command": self.command, "avatar": self.avatar, "fps": m.fps_end_to_end, "fps_pipelined": m.fps_pipelined,
             "pipeline_gain_ms": m.frame_ms - m.frame_ms_pipelined, "breakdown_ms": dict(m.breakdown_ms),
             "peak_rss_mb": m.peak_rss_mb, "int8_psnr_vs_fp32": a.int8_psnr_vs_fp32_db,
             "int8_ssim_vs_fp32": a.int8_ssim_vs_fp32, "int8_psnr_vs_fp32_image": m.int8_psnr_vs_fp32_image_db,
             "int8_psnr_vs_fp32_person": m.int8_psnr_vs_fp32_person_db,
             "kernels": m.kernels.to_dict(), "avatars": {k: v.to_dict() for k, v in self.avatars.items()},
             "seconds": self.seconds}
        if self.compute_limit is not None:
            d["compute_limit"] = self.compute_limit
        return d
