"""Where Ray runs and what a task holds.

An embedded local Ray (started in this process, all of this machine's CPUs, no dashboard, a small
object store: the tasks pass paths and small dicts) is the default. ``--address`` or the
``RAY_ADDRESS`` environment variable connects to a running cluster instead (``auto``: the one
``ray start`` began on this machine). A Ray that this process already connected to is used as it
is, so a caller (a test, a notebook) may ``ray.init`` its own first.

``import ray`` happens only in :func:`require_ray`, called by the functions that need Ray.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from morf.errors import InputError

EXTRA = "morf-studio[ray]"  # the optional extra in pyproject.toml
INSTALL_HINT = f"pip install '{EXTRA}' (bash scripts/install.sh installs it)"
HERE = "here"  # --address here: the tasks in this process, without Ray
LOCAL_OBJECT_STORE = 100 * 1024**2  # bytes; the tasks send paths and configs and get small dicts back


@dataclass(frozen=True)
class RayOptions:
    """How to reach Ray.

    Fields:
        address: a cluster ("HOST:6379", "ray://HOST:10001", "auto"); None: ``$RAY_ADDRESS`` when
            set, else a new local Ray in this process.
        num_cpus: CPUs a local Ray offers (None: all of this machine's); not used with a cluster.
        object_store_memory: bytes of a local Ray's object store (None: :data:`LOCAL_OBJECT_STORE`).
        log_to_driver: print the workers' output here (off: it stays in Ray's session logs).
        in_process: no Ray at all: the tasks run one after another in this process, each on its
            CPUs' worth of torch threads (``--address here``; works without the ``ray`` extra, but
            a task that crashes the process is not started again).
    """

    address: str | None = None
    num_cpus: int | None = None
    object_store_memory: int | None = None
    log_to_driver: bool = False
    in_process: bool = False

    @property
    def cluster_address(self) -> str | None:
        """The cluster to connect to, or None for a local Ray (or none, in process)."""
        if self.in_process:
            return None
        return self.address or os.environ.get("RAY_ADDRESS") or None

    @property
    def where(self) -> str:
        """For results files: the cluster's address, "local" (a local Ray) or "here" (in process)."""
        return HERE if self.in_process else self.cluster_address or "local"


@dataclass(frozen=True)
class Resources:
    """What one task holds while it runs; Ray starts it only where these are free.

    Fields:
        num_cpus: CPU cores (Ray sets ``OMP_NUM_THREADS`` to it; the task runs torch on as many threads).
        num_gpus: GPUs (Ray sets ``CUDA_VISIBLE_DEVICES`` to the ones it gives the task).
    """

    num_cpus: float = 1
    num_gpus: float = 0

    def __post_init__(self):
        if self.num_cpus < 0 or self.num_gpus < 0 or self.num_cpus + self.num_gpus == 0:
            raise InputError(f"a task needs at least one CPU or GPU, got {self.num_cpus} CPUs, {self.num_gpus} GPUs")


def resources_for(preset: str | None, num_cpus: float = 1) -> Resources:
    """A training's resources: ``num_cpus`` cores, and one GPU for the ``gpu`` preset."""
    return Resources(num_cpus=num_cpus, num_gpus=1 if preset == "gpu" else 0)


def require_ray():
    """The ``ray`` module, or an :class:`InputError` that says how to install it."""
    try:
        import ray
    except ModuleNotFoundError as e:
        if e.name != "ray":
            raise
        raise InputError(f"this needs Ray, the optional extra '{EXTRA}': {INSTALL_HINT}") from None
    return ray


def connect(options: RayOptions | None = None):
    """Connect to Ray as ``options`` say (see :class:`RayOptions`) unless this process already is;
    returns the ``ray`` module. A cluster that cannot be reached is an :class:`InputError`."""
    options = options or RayOptions()
    if options.in_process:
        raise ValueError("in-process options have no Ray to connect to")
    ray = require_ray()
    if ray.is_initialized():
        return ray
    address = options.cluster_address
    if address:
        try:
            ray.init(address=address, log_to_driver=options.log_to_driver)
        except (ConnectionError, RuntimeError, ValueError) as e:
            hint = "" if os.environ.get("RAY_AUTH_MODE", "").lower() == "token" else (
                "; a cluster that 'ray start --head' began checks a token: set RAY_AUTH_MODE=token and give "
                "its token (~/.ray/auth_token or RAY_AUTH_TOKEN), see docs/scale-out.md")
            raise InputError(f"cannot connect to the Ray cluster at {address}: {e}{hint}") from None
        return ray
    ray.init(address="local", num_cpus=options.num_cpus or os.cpu_count() or 1, include_dashboard=False,
             object_store_memory=options.object_store_memory or LOCAL_OBJECT_STORE,
             log_to_driver=options.log_to_driver)
    return ray


def describe(options: RayOptions | None = None) -> dict:
    """What the connected Ray is, for results files: address ("local", or "here" in process), nodes,
    CPUs, GPUs."""
    options = options or RayOptions()
    if options.in_process:
        import torch

        return {"address": options.where, "nodes": 1, "cpus": float(os.cpu_count() or 1),
                "gpus": float(torch.cuda.device_count())}
    ray = connect(options)
    alive = [n for n in ray.nodes() if n.get("Alive")]
    total = ray.cluster_resources()
    return {"address": options.where, "nodes": len(alive), "cpus": total.get("CPU", 0.0), "gpus": total.get("GPU", 0.0)}


def check_fits(resources: Resources, options: RayOptions | None = None) -> None:
    """An :class:`InputError` when no node of the connected Ray has ``resources`` (a task asking
    for them would wait for ever)."""
    ray = connect(options)
    nodes = [n.get("Resources", {}) for n in ray.nodes() if n.get("Alive")]
    fits = any(n.get("CPU", 0) >= resources.num_cpus and n.get("GPU", 0) >= resources.num_gpus for n in nodes)
    if not fits:
        most_cpus = max((n.get("CPU", 0) for n in nodes), default=0)
        most_gpus = max((n.get("GPU", 0) for n in nodes), default=0)
        raise InputError(f"each task asks for {resources.num_cpus:g} CPUs and {resources.num_gpus:g} GPUs, but no Ray "
                         f"node has them (the largest has {most_cpus:g} CPUs, {most_gpus:g} GPUs); ask for fewer "
                         "(--cpus-per-task, --preset) or add a node")


def add_arguments(p, cpus_help: str, default_cpus: int | None = 1) -> None:
    """The options every command that runs on Ray takes: --address, --workers, --cpus-per-task."""
    p.add_argument("--address", default=None, metavar="ADDR",
                   help="Ray cluster to run on (HOST:PORT, ray://HOST:10001, or 'auto' for the one 'ray start' "
                        "began here; default: $RAY_ADDRESS, else a local Ray on this machine's CPUs); 'here': no "
                        "Ray, one task after another in this process")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="run at most N tasks at once (default: as many as the CPUs and GPUs allow)")
    p.add_argument("--cpus-per-task", type=int, default=default_cpus, metavar="C", help=cpus_help)


def options_from_args(args) -> RayOptions:
    """RayOptions from :func:`add_arguments`' options (checked: positive counts)."""
    for flag, value in (("--workers", args.workers), ("--cpus-per-task", args.cpus_per_task)):
        if value is not None and value < 1:
            raise InputError(f"{flag} must be at least 1, got {value}")
    if args.address == HERE:
        return RayOptions(in_process=True)
    return RayOptions(address=args.address)
