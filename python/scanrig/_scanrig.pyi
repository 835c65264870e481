"""Type stubs of the compiled module (see scanrig/__init__.py)."""

from os import PathLike
from typing import Any, Optional, Union

import numpy as np
import numpy.typing as npt

__version__: str

class ScanrigError(Exception): ...
class FileError(ScanrigError): ...
class StageError(ScanrigError): ...

_Path = Union[str, PathLike[str]]
_F64 = npt.NDArray[np.float64]

def read_cloud(path: _Path) -> dict[str, Optional[np.ndarray]]:
    """Reads a point cloud: points (N×3 float64), normals, colors (N×3 uint8), confidence, view_id."""

def write_cloud(
    path: _Path,
    points: _F64,
    normals: Optional[_F64] = None,
    colors: Optional[npt.NDArray[np.uint8]] = None,
    confidence: Optional[npt.NDArray[np.float32]] = None,
) -> None:
    """Writes a point cloud; the format follows the extension."""

def read_mesh(path: _Path) -> dict[str, Any]:
    """Reads a mesh: vertices (V×3), faces (index lists), triangles (F×3), normals, colors."""

def write_mesh(path: _Path, vertices: _F64, faces: np.ndarray, colors: Optional[npt.NDArray[np.uint8]] = None) -> None:
    """Writes a mesh; the format follows the extension."""

def fuse(
    points: _F64,
    normals: Optional[_F64] = None,
    colors: Optional[npt.NDArray[np.uint8]] = None,
    confidence: Optional[npt.NDArray[np.float32]] = None,
    *,
    k: Optional[int] = None,
    kernel_spacing: Optional[float] = None,
) -> tuple[dict[str, Optional[np.ndarray]], npt.NDArray[np.bool_], dict[str, Any]]:
    """Mean-shift fusion (thesis ch. 3, eqs. 3.2-3.10): (cloud, kept mask, report)."""

def reconstruct(
    points: _F64,
    normals: _F64,
    *,
    method: str = "fft",
    depth: Optional[int] = None,
    error: Optional[float] = None,
    smoothing_cells: Optional[float] = None,
    memory_budget_gb: Optional[float] = None,
) -> tuple[_F64, npt.NDArray[np.int64], dict[str, Any]]:
    """Watertight reconstruction (thesis ch. 5: FFT eqs. 5.16-5.17, AdFFT 5.3): (V, F, report)."""

def remesh(
    vertices: _F64,
    faces: np.ndarray,
    *,
    spacing: Optional[float] = None,
    features: Optional[float] = None,
    weight: Optional[float] = None,
) -> tuple[_F64, list[list[int]], dict[str, Any]]:
    """Quad remeshing from a harmonic field (thesis ch. 6): (V, faces, report)."""

def icp(
    moving: _F64,
    moving_normals: _F64,
    target: _F64,
    target_normals: _F64,
    *,
    initial: Optional[_F64] = None,
    max_iterations: Optional[int] = None,
    start_distance: Optional[float] = None,
) -> tuple[_F64, dict[str, Any]]:
    """Point-to-plane ICP (thesis ch. 2.2): (4×4 transform, report)."""

def process(scan: _Path, out: Optional[_Path] = None, *, force: bool = False) -> dict[str, Any]:
    """Processes a scan folder as `scanrig process` does; returns its report."""
