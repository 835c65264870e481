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

def read_cloud(path: _Path) -> dict[str, Any]:
    """Reads a point cloud: points (N×3 float64), normals, colors (N×3 uint8), confidence, view_id,
    and units: the data's unit ("m" for a PLY that says so or the Stanford scans, "mm" for E57 and
    glTF, None where the file says none: millimetres). Give it back to a writer's ``units``."""

def write_cloud(
    path: _Path,
    points: _F64,
    normals: Optional[_F64] = None,
    colors: Optional[npt.NDArray[np.uint8]] = None,
    confidence: Optional[npt.NDArray[np.float32]] = None,
    *,
    units: Optional[str] = None,
) -> None:
    """Writes a point cloud; the format follows the extension. ``units``: the data's unit (None:
    millimetres); PLY says it, E57 and glTF are written converted from it. What the format cannot
    hold (confidence in OBJ, glTF, E57) is a UserWarning."""

def read_mesh(path: _Path) -> dict[str, Any]:
    """Reads a mesh: vertices (V×3), faces (index lists), triangles (F×3), normals, colors, units
    (as ``read_cloud``'s)."""

def write_mesh(
    path: _Path,
    vertices: _F64,
    faces: np.ndarray,
    colors: Optional[npt.NDArray[np.uint8]] = None,
    *,
    units: Optional[str] = None,
) -> None:
    """Writes a mesh; the format follows the extension. ``units``: the data's unit (None:
    millimetres); PLY says it, E57, glTF and STL are written converted from it. What the format
    cannot hold (quads in STL and glTF, colours in STL) is a UserWarning."""

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
    platter_z: Optional[float] = None,
    top_z: Optional[float] = None,
    base: str = "flat",
    trim: Optional[float] = None,
    force: bool = False,
    samples_per_cell: Optional[float] = None,
) -> tuple[_F64, npt.NDArray[np.int64], dict[str, Any]]:
    """Watertight reconstruction (thesis ch. 5: FFT eqs. 5.16-5.17, AdFFT 5.3), finished as `process` does
    (base cut at `platter_z`, cut at `top_z`, trim, support check): (V, F, report)."""

def remesh(
    vertices: _F64,
    faces: np.ndarray,
    *,
    spacing: Optional[float] = None,
    features: Optional[float] = None,
    weight: Optional[float] = None,
    force: bool = False,
) -> tuple[_F64, list[list[int]], dict[str, Any]]:
    """Quad remeshing from a harmonic field (thesis ch. 6): (V, faces, report). A remesh that cannot be
    right (edges of three faces or holes the input lacks, surface over 4 quads from it) raises StageError
    unless `force`, which returns it with a UserWarning."""

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

def align(
    moving: _F64,
    fixed: _F64,
    *,
    voxel: Optional[float] = None,
    seed: Optional[int] = None,
    force: bool = False,
) -> tuple[_F64, dict[str, Any]]:
    """Global registration, no pose to start from (issue 40): (4×4 transform, report).

    Raises StageError when the match is ambiguous or unsupported, unless force=True."""

def process(
    scan: _Path,
    out: Optional[_Path] = None,
    *,
    force: bool = False,
    until: Optional[str] = None,
    views: Optional[list[int]] = None,
) -> dict[str, Any]:
    """Processes a scan folder as `scanrig process` does (to stage `until`, of `views` only); returns its report."""

_Grid = dict[str, Any]
_Image = npt.NDArray[np.uint8]

def read_image(path: _Path) -> _Image:
    """Reads a PNG or JPEG: H×W uint8 (grey) or H×W×3 (colour)."""

def write_image(path: _Path, image: _Image) -> None:
    """Writes an H×W or H×W×3 uint8 image: PNG, or JPEG for .jpg/.jpeg."""

def read_range_grid(path: _Path) -> _Grid:
    """Reads a range grid: points (H×W×3, NaN holes), normals, confidence (H×W float32), sensor,
    units (as ``read_cloud``'s)."""

def write_range_grid(path: _Path, grid: _Grid) -> None:
    """Writes a range grid (a dict as read_range_grid gives) as a PLY with grid_col/grid_row, its
    "units" (if any) in a ``comment units``."""

def denoise(frames: Union[_Grid, list[_Grid]], *, current: int = 0, temporal: int = 0) -> tuple[_Grid, dict[str, Any]]:
    """Non-local denoising (thesis ch. 4: eq. 4.3 alone, eq. 4.6 over `temporal` frames either side)."""

def simulate_view(
    angle_deg: float = 0.0,
    *,
    config: str = "structured-light",
    method: Optional[str] = None,
    resolution: Optional[tuple[int, int]] = None,
    mesh: Optional[_Path] = None,
    size: Optional[float] = None,
    up: str = "y",
    seed: int = 1,
    view: int = 0,
    noiseless: bool = False,
) -> dict[str, Any]:
    """One simulated view in memory: frames, patterns, rig (TOML text), truth (points, object, projector)."""

def simulate_scan(
    out: _Path,
    *,
    config: str = "structured-light",
    method: Optional[str] = None,
    views: Optional[int] = None,
    resolution: Optional[tuple[int, int]] = None,
    mesh: Optional[_Path] = None,
    size: Optional[float] = None,
    up: str = "y",
    seed: int = 1,
    noiseless: bool = False,
    truth: bool = True,
) -> dict[str, Any]:
    """A simulated scan folder, as `scanrig sim` writes it (resumes a half-written one): the report."""

def decode(
    frames: list[_Image],
    *,
    projector: tuple[int, int],
    patterns: Optional[list[dict[str, Any]]] = None,
    shadow_threshold: Optional[float] = None,
    bit_threshold: Optional[int] = None,
    gray_fit_radius: Optional[int] = None,
) -> tuple[_F64, dict[str, Any]]:
    """Gray code and phase shift into a projector map (H×W×3: u, v, confidence; NaN undecoded)."""

def triangulate(map: _F64, rig: _Path) -> tuple[_Grid, dict[str, Any]]:
    """A projector map through the rig's camera and projector (eq. 2.3) into a range grid (mm)."""

def laser_line(
    frame: _Image,
    rig: _Path,
    *,
    laser: int = 0,
    off: Optional[_Image] = None,
    texture: Optional[_Image] = None,
    force: bool = False,
) -> tuple[dict[str, Optional[np.ndarray]], dict[str, Any]]:
    """One laser's line in one view (points in the camera frame, mm), as `process` makes a laser view."""

def register(
    grids: list[_Grid], angles_deg: list[float], rig: _Path, *, force: bool = False
) -> tuple[dict[str, Optional[np.ndarray]], list[dict[str, Any]], dict[str, Any]]:
    """Multi-view ICP from the turntable poses (thesis ch. 2.2): (cloud, poses, report)."""

def calibrate_camera(
    captures: _Path,
    *,
    board: tuple[int, int] | str = (9, 6),
    square: float = 15.0,
    out: Optional[_Path] = None,
    rig: Optional[_Path] = None,
    fix_aspect_ratio: bool = False,
    fix_principal_point: bool = False,
    zero_tangential: bool = False,
    fix_k3: bool = False,
    lens_model: str = "auto",
    force: bool = False,
) -> tuple[str, dict[str, Any]]:
    """The camera from chessboard captures: (rig TOML text, report)."""

def calibrate_rig(
    captures: _Path,
    *,
    board: tuple[int, int] | str = (9, 6),
    square: float = 15.0,
    out: Optional[_Path] = None,
    rig: Optional[_Path] = None,
    projector: Optional[tuple[int, int]] = None,
    corner_height: Optional[float] = None,
    fix_aspect_ratio: bool = False,
    fix_principal_point: bool = False,
    zero_tangential: bool = False,
    fix_k3: bool = False,
    lens_model: str = "auto",
    force: bool = False,
) -> tuple[str, dict[str, Any]]:
    """Camera, projector, laser planes and turntable axis, as the captures allow: (rig TOML text, report)."""
