"""Run by test_streaming.py in a fresh interpreter: simulates a field into a zarr store, then
denoises and segments it from the store, under an address-space limit (RLIMIT_AS) set to the
interpreter's size after start-up plus HEADROOM, below the store's size; prints a JSON
record of what it did."""

import json
import resource
import sys
import time
from pathlib import Path

import dask
import dask.array as da
import numpy as np

import kalmanfield as kf
import kalmanfield.dask as kfd

HEADROOM = 192 * 2**20
ROWS, WIDTH, FRAME_ROWS = 16384, 4096, 128  # 256 MiB of float32
MODEL = kf.ARFieldModel([0.9, 0.8], [2, 1])


def address_space() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmSize:"):
            return int(line.split()[1]) * 1024
    raise RuntimeError("no VmSize")


def main(folder: str) -> None:
    store = Path(folder)
    with dask.config.set(scheduler="threads", num_workers=2):
        # the thread pools (dask's, zarr's I/O, the Rust kernels') exist before the limit
        warm = kfd.sample(MODEL, (64, 64), chunks=(32, 64), seed=0)
        warm.to_zarr(str(store / "warm.zarr"), overwrite=True)
        warm = da.from_zarr(str(store / "warm.zarr")).reshape(2, 32, 64)
        kfd.denoise(warm, model=MODEL, noise_var=0.25, mean=0.0).compute()
        kfd.segment(warm, 2.5).compute()
        limit = address_space() + HEADROOM
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        stack_bytes = ROWS * WIDTH * 4
        try:
            np.empty(stack_bytes, np.uint8)
            fits = True
        except MemoryError:
            fits = False
        start = time.perf_counter()
        chunks = (4 * FRAME_ROWS, WIDTH)  # 8 MiB: a denoise task peaks at ~6× its chunk
        field = kfd.sample(MODEL, (ROWS, WIDTH), chunks=chunks, seed=7, dtype=np.float32)
        # uncompressed: random floats do not compress, and the codec would cost more than the
        # kernels
        field.to_zarr(str(store / "field.zarr"), overwrite=True, compressors=None)
        frames = da.from_zarr(str(store / "field.zarr")).reshape(-1, FRAME_ROWS, WIDTH)
        clean = kfd.denoise(frames, model=MODEL, noise_var=0.25, mean=0.0).astype(np.float32)
        stored = clean.to_zarr(
            str(store / "denoised.zarr"), overwrite=True, compressors=None, compute=False
        )
        _, spots = dask.compute(stored, kfd.segment(frames, 2.5))  # one read of the store
        head = da.from_zarr(str(store / "field.zarr"))[: 2 * FRAME_ROWS].compute()
        denoised_head = da.from_zarr(str(store / "denoised.zarr"))[:2].compute()
    expected = MODEL.sample((2 * FRAME_ROWS, WIDTH), seed=7, dtype=np.float32)
    in_memory = kf.denoise(
        expected.reshape(2, FRAME_ROWS, WIDTH), model=MODEL, noise_var=0.25, mean=0.0
    )
    record = {
        "limit": limit,
        "stack_bytes": stack_bytes,
        "stack_fits": fits,
        "seconds": time.perf_counter() - start,
        "sample_equal": bool(np.array_equal(head, expected)),
        "denoise_equal": bool(np.array_equal(denoised_head, in_memory.astype(np.float32))),
        "spots": len(spots),
        "frames_with_spots": int(spots["frame"].nunique()),
        "max_rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
    }
    print(json.dumps(record))


if __name__ == "__main__":
    main(sys.argv[1])
