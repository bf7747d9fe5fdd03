"""Reading and writing images, stacks of frames, zarr stores and fitted models.

The file formats come from well-kept libraries, installed with the ``io`` extra
(``pip install "kalmanfield[io]"``): imageio (PNG, JPEG, GIF, and video through its ffmpeg
plugin), tifffile (TIFF stacks) and zarr (chunked stores larger than memory). ``.npy`` files
and the JSON of a model need none of them. The command line (:doc:`/guide/cli`) reads and
writes through these functions.
"""

from .images import iter_frames, read_image, read_stack, write_image, write_stack
from .model_json import read_model, write_model
from .zarr_store import open_zarr, write_zarr

__all__ = [
    "iter_frames",
    "open_zarr",
    "read_image",
    "read_model",
    "read_stack",
    "write_image",
    "write_model",
    "write_stack",
    "write_zarr",
]
