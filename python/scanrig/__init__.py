"""scanrig from Python: the scanner toolkit's stages as functions on NumPy arrays.

Every function is the library's own stage (no algorithm lives in the binding), with the command
line's defaults and messages; long calls release the GIL and stop waiting on Ctrl-C. Errors are
:class:`ScanrigError` (:class:`FileError` for files, :class:`StageError` for a stage that refused its
input); wrong array shapes and dtypes are ``ValueError``/``TypeError`` naming the argument.

Thesis chapters: fusion ch. 3 (eqs. 3.2-3.10), reconstruction ch. 5 (eqs. 5.16-5.17; AdFFT 5.3),
remeshing ch. 6, registration ch. 2.2.
"""

from . import _scanrig  # noqa: F401
from ._scanrig import (  # noqa: F401
    FileError,
    ScanrigError,
    StageError,
    __version__,
    fuse,
    icp,
    process,
    read_cloud,
    read_mesh,
    reconstruct,
    remesh,
    write_cloud,
    write_mesh,
)

__all__ = [
    "FileError",
    "ScanrigError",
    "StageError",
    "fuse",
    "icp",
    "process",
    "read_cloud",
    "read_mesh",
    "reconstruct",
    "remesh",
    "write_cloud",
    "write_mesh",
]
