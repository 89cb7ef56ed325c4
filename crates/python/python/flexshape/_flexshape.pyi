"""Type hints of the extension module (see the package's docstring and each item's own)."""

from os import PathLike
from typing import Any, Callable, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, "PathLike[str]"]
_Image = npt.NDArray[np.uint8]  # (height, width, 3), RGB
_Points = npt.NDArray[np.float64]  # (N, 3), world mm

__version__: str

class FlexshapeError(Exception):
    """Bad input (a file, a field, a frame) or a failed computation; the message says what."""

class Record:
    """One frame's shape and how far to trust it (a `flexshape track` JSON Lines record).
    Picklable; equal when their JSON records are."""

    def __init__(self, json: str) -> None:
        """A record from its JSON (a line of `flexshape track`'s output, or `Record.json()`)."""
    @property
    def frame(self) -> int: ...
    @property
    def status(self) -> str:
        """`ok` only when the shape explains every image; otherwise why not."""
    @property
    def ok(self) -> bool: ...
    @property
    def reason(self) -> Optional[str]: ...
    @property
    def centerline(self) -> _Points:
        """(N, 3) world mm, proximal end to tip."""
    @property
    def tip(self) -> Optional[npt.NDArray[np.float64]]:
        """(3,) world mm."""
    @property
    def tip_direction(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def arc_length(self) -> float:
        """mm."""
    @property
    def curvature(self) -> npt.NDArray[np.float64]:
        """(N,) 1/mm at each centerline sample."""
    @property
    def bands(self) -> _Points:
        """(B, 3) marker band centres, world mm, proximal to distal."""
    def json(self) -> str: ...
    def to_dict(self) -> dict[str, Any]: ...

class Rig:
    """Cameras (intrinsics, distortion, poses in one world frame), volume and settings."""

    @staticmethod
    def open(path: _Path) -> "Rig":
        """A rig TOML file, or a folder of OpenCV camera files."""
    @property
    def cameras(self) -> list[str]: ...
    @property
    def image_sizes(self) -> list[tuple[int, int]]:
        """(width, height) px per camera."""
    def project(self, camera: int, points: _Points) -> npt.NDArray[np.float64]:
        """(N, 2) pixels of world points (N, 3) mm in camera `camera`; NaN behind it."""
    def camera(self, key: Union[str, int]) -> "Camera":
        """A camera by name or index (negative from the end)."""
    def __getitem__(self, key: Union[str, int]) -> "Camera": ...
    def __len__(self) -> int: ...
    def summary(self) -> str: ...

class Camera:
    """One camera as OpenCV has it: x_cam = R·X_world + t (mm); pixels from K and D."""

    @property
    def name(self) -> str: ...
    @property
    def image_size(self) -> tuple[int, int]:
        """(width, height) px."""
    @property
    def K(self) -> npt.NDArray[np.float64]:
        """(3, 3) camera matrix, px."""
    @property
    def D(self) -> npt.NDArray[np.float64]:
        """Distortion coefficients in OpenCV's order (k1, k2, p1, p2, k3[, …])."""
    @property
    def R(self) -> npt.NDArray[np.float64]:
        """(3, 3) rotation world → camera."""
    @property
    def t(self) -> npt.NDArray[np.float64]:
        """(3,) translation world → camera, mm."""
    @property
    def rvec(self) -> npt.NDArray[np.float64]:
        """(3,) Rodrigues vector of R, rad (cv2.Rodrigues)."""
    @property
    def centre(self) -> npt.NDArray[np.float64]:
        """(3,) the camera's centre in the world frame, mm."""
    def project(self, points: _Points) -> npt.NDArray[np.float64]:
        """(N, 2) pixels of world points (N, 3) mm; NaN behind the camera."""

class Tracker:
    """Follows the tube from frame to frame in images from your own cameras."""

    def __init__(
        self,
        rig: Rig,
        backgrounds: Sequence[_Image],
        follow: bool = True,
        channels: str = "rgb",
    ) -> None: ...
    @staticmethod
    def from_recording(path: _Path, follow: bool = True) -> "Tracker": ...
    def process(
        self,
        images: Sequence[_Image],
        frame: Optional[int] = None,
        captured_s: Optional[float] = None,
        camera_captured_s: Optional[Sequence[float]] = None,
        channels: str = "rgb",
    ) -> Record:
        """One frame; `captured_s` (s, your own base) and each camera's `camera_captured_s`
        (same base, rig order) for cameras not triggered together; `channels="bgr"` for
        OpenCV's images."""
    def reset(self) -> None: ...
    @property
    def follows(self) -> bool: ...

def track(
    recording: _Path,
    threads: int = 2,
    on_record: Optional[Callable[[Record], Optional[bool]]] = None,
) -> list[Record]:
    """Tracks a recording folder; `on_record` returning False stops early."""

def iter_track(recording: _Path, threads: int = 2) -> "TrackIter":
    """Tracks a recording folder, yielding each record as soon as it is made; breaking out
    of the loop (or `close()`) stops the tracking."""

class TrackIter:
    def __iter__(self) -> "TrackIter": ...
    def __next__(self) -> Record: ...
    def close(self) -> None: ...

def read_records(path: _Path) -> list[Record]:
    """The records of a `flexshape track` JSON Lines file."""

class Pose:
    """A pose of the simulated catheter."""

class SimFrame:
    """A rendered frame: images and ground truth."""

    @property
    def images(self) -> list[_Image]: ...
    @property
    def truth_centerline(self) -> _Points: ...
    @property
    def truth_tip(self) -> npt.NDArray[np.float64]: ...
    def truth(self) -> dict[str, Any]: ...

class Simulator:
    """A simulated rig looking at a catheter whose shape is known exactly."""

    def __init__(
        self,
        seed: int = 1,
        cams: int = 3,
        width: int = 640,
        height: int = 480,
        shadows: bool = False,
    ) -> None: ...
    @property
    def rig(self) -> Rig: ...
    def backgrounds(self) -> list[_Image]: ...
    def sweep(self, frames: int) -> list[Pose]: ...
    def motion(self, frames: int, rate_hz: float = 120.0) -> list[Pose]: ...
    def render(self, frame: int, pose: Pose) -> SimFrame: ...

def simulate(
    out: _Path,
    frames: int = 10,
    seed: int = 1,
    cams: int = 3,
    rate_hz: Optional[float] = None,
    model: Optional[_Path] = None,
    overwrite: bool = False,
) -> int:
    """Writes a simulated recording into `out` (with `model`, the model's experiment)."""

def model_template() -> str:
    """A model file (TOML) of the paper's catheter to start from."""

class Calibration:
    """A calibrated rig and its reports."""

    @property
    def rig(self) -> Rig: ...
    def reports(self) -> list[dict[str, Any]]: ...
    @property
    def notes(self) -> list[str]: ...
    def write(self, out: _Path) -> None: ...
    def summary(self, out: _Path = ".") -> str: ...

def calibrate(
    images: Sequence[tuple[str, _Path]],
    board: str,
    square_mm: float,
    marker_mm: Optional[float] = None,
    dictionary: str = "DICT_4X4_50",
    fix_k3: bool = False,
) -> Calibration:
    """Calibrates every camera from target images, in the first camera's world frame."""

class ModelFit:
    """An identified manipulator model."""

    def report(self) -> dict[str, Any]: ...
    def model_frame(self) -> dict[str, Any]: ...

def fit_model(
    params: _Path,
    data: _Path,
    displacements: Optional[_Path] = None,
    tendons: bool = False,
    threads: int = 2,
) -> ModelFit:
    """Identifies the model's stiffnesses from sensed shapes and tendon displacements."""
