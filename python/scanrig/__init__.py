"""scanrig from Python: the scanner toolkit's stages as functions on NumPy arrays.

Every function is the library's own stage (no algorithm lives in the binding), with the command
line's defaults and messages; long calls release the GIL and stop waiting on Ctrl-C. Errors are
:class:`ScanrigError` (:class:`FileError` for files, :class:`StageError` for a stage that refused its
input); wrong array shapes and dtypes are ``ValueError``/``TypeError`` naming the argument.

Thesis chapters: triangulation eq. 2.3, denoising ch. 4 (eqs. 4.3, 4.6), fusion ch. 3 (eqs.
3.2-3.10), reconstruction ch. 5 (eqs. 5.16-5.17; AdFFT 5.3), remeshing ch. 6, registration ch. 2.2.
"""

from . import _scanrig  # noqa: F401
from ._scanrig import (  # noqa: F401
    FileError,
    ScanrigError,
    StageError,
    __version__,
    align,
    calibrate_camera,
    calibrate_rig,
    decode,
    denoise,
    fuse,
    icp,
    laser_line,
    process,
    read_cloud,
    read_image,
    read_mesh,
    read_range_grid,
    reconstruct,
    register,
    remesh,
    simulate_scan,
    simulate_view,
    triangulate,
    write_cloud,
    write_image,
    write_mesh,
    write_range_grid,
)

__all__ = [
    "FileError",
    "ScanrigError",
    "StageError",
    "align",
    "calibrate_camera",
    "calibrate_rig",
    "decode",
    "denoise",
    "fuse",
    "icp",
    "laser_line",
    "process",
    "read_cloud",
    "read_image",
    "read_mesh",
    "read_range_grid",
    "reconstruct",
    "register",
    "remesh",
    "simulate_scan",
    "simulate_view",
    "triangulate",
    "write_cloud",
    "write_image",
    "write_mesh",
    "write_range_grid",
]
