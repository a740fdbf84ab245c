"""``python -m morf.body.warmup``: build Anny's on-disk cache once (about a minute, 790 MB)."""

import time

from morf.body.anny_model import AnnyBodyModel, anny_cache_dir

if __name__ == "__main__":
    t0 = time.time()
    AnnyBodyModel()
    print(f"[install] body model ready ({time.time() - t0:.1f} s, cache {anny_cache_dir()})")
