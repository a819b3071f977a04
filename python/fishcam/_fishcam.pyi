"""
fishcam's C++ library (use the fishcam package, not this module)
"""
from __future__ import annotations
import numpy
import numpy.typing
import typing
__all__: list[str] = ['AffineChange', 'AngleBin', 'Calibration', 'Camera', 'Comparison', 'ConfusionMatrix', 'Conversion', 'DisplacementStats', 'Error', 'FieldOfView', 'FitReport', 'ModelComparison', 'RigCalibration', 'ValidDomain', 'ViewpointChange', 'ViewpointWarp', 'affine_forward', 'affine_presets', 'affine_warp', 'affine_warp_depth', 'calibrate', 'calibrate_rig', 'check_depth_prior', 'check_preset', 'compare', 'convert', 'dataset_fidelity', 'dataset_model_fidelity', 'depth_priors', 'depth_priors_and_map', 'depth_values_names', 'derive_seed', 'get_num_threads', 'presets', 'random_affine', 'random_affine_in', 'random_change', 'random_change_in', 'read_corners', 'render', 'reprojection_error_map', 'sampling_names', 'set_num_threads', 'woodscape_classes']
class Error(ValueError):
    pass
class ValidDomain:
    """
    Where a camera's model is valid: theta in [0, theta_max] (closed) or [0, theta_max).
    """
    def __repr__(self) -> str:
        ...
    @property
    def closed(self) -> bool:
        """
        Whether theta_max itself is valid.
        """
    @property
    def limited_by(self) -> str:
        """
        What sets theta_max: 'model', 'fold' (rho stops increasing) or 'user' (a theta limit).
        """
    @property
    def rho_max_px(self) -> float | None:
        """
        rho(theta_max) in pixel-scale units, or None where the model diverges there.
        """
    @property
    def theta_max_deg(self) -> float:
        """
        The largest valid angle of incidence (degrees).
        """
class FieldOfView:
    """
    The image's angular coverage through the principal point (degrees).
    """
    def __repr__(self) -> str:
        ...
    @property
    def diagonal(self) -> float:
        """
        Degrees across its diagonal.
        """
    @property
    def horizontal(self) -> float:
        """
        Degrees across the image's width.
        """
    @property
    def vertical(self) -> float:
        """
        Degrees across its height.
        """
class Camera:
    """
    A calibrated camera: a radial model rho(theta) (with tangential terms for some models), principal point, pixel scale, image size and an optional pose. Pixel centres at integer coordinates; camera frame x right, y down, z forward. Immutable; equal cameras compare equal and hash alike.
    """
    @staticmethod
    def from_json(text: str) -> Camera:
        """
        The camera of fishcam JSON text (what to_json gives).
        """
    @staticmethod
    def read(path: str, camera: typing.Any | None = None, image_size: tuple[int, int] | None = None, format: str | None = None, distortion_model: str | None = None) -> Camera:
        """
        Reads a camera file in any format fishcam knows (docs/formats.md). camera: which camera of a multi-camera file (index or name); image_size: (width, height) for files without one; format: force a reader; distortion_model: 'fisheye' or 'plumb_bob' for OpenCV files that do not say.
        """
    def __eq__(self, other: typing.Any) -> bool:
        """
        Equal when every number of the two cameras is (parameters_key).
        """
    def __getstate__(self) -> typing.Any:
        ...
    def __hash__(self) -> int:
        """
        The hash of parameters_key(): equal cameras hash alike.
        """
    def __reduce__(self) -> tuple[typing.Any, ...]:
        """
        Pickling at every protocol: (copyreg.__newobj__, (type,), __getstate__())
        """
    def __repr__(self) -> str:
        ...
    def __setstate__(self, arg0: typing.Any) -> None:
        ...
    def augmented(self, change: ViewpointChange) -> Camera:
        """
        The camera of an image augmented by `change`: same intrinsics, the pose moved by the change (a camera without a pose gets one relative to its own frame)
        """
    def cropped(self, left: int, top: int, width: int, height: int) -> Camera:
        """
        The same lens for the image cropped to the width x height window whose top-left pixel is (left, top) (negative, or past the edges: a padded crop): c' = c - (left, top).
        """
    def info_json(self) -> str:
        """
        What `fishcam info --json` prints (str); the same values typed: model, parameters, principal_point, pixel_scale, domain, field_of_view_deg, pose.
        """
    def limited_to_observed(self, margin_deg: float = 0.0) -> Camera:
        """
        The camera with its valid domain capped at the observed angles plus margin_deg, per azimuth (`--theta-limit data+DEG`): with margin_deg = 0 it unprojects exactly the pixels whose rays observed() accepts.
        """
    def mirrored(self, horizontal: bool = True, vertical: bool = False) -> Camera:
        """
        The same lens for the image flipped left-right (horizontal: u -> width - 1 - u) and/or upside down (vertical): the pixel grid mirrored (c'x = width - 1 - cx, a'x = -a_x), so the camera projects every point where the flipped image shows it. Only fishcam JSON holds a mirrored camera.
        """
    def observed(self, rays: typing.Any) -> numpy.ndarray[typing.Any, numpy.dtype[numpy.bool_]]:
        """
        Whether camera-frame rays (N, 3) lie within the angles its calibration observed (per 15-degree azimuth sector, each sector's angle holding up to the middle of its neighbours): (N,) bool.
        """
    def parameters_key(self, with_pose: bool = True) -> bytes:
        """
        bytes equal exactly when two cameras are (with_pose=False: the intrinsics and size only, what a warp depends on); cheap, for caches and hashing
        """
    def project(self, points: typing.Any) -> tuple[numpy.ndarray[typing.Any, numpy.dtype[numpy.float64]], numpy.ndarray[typing.Any, numpy.dtype[numpy.bool_]]]:
        """
        Projects points (N, 3) of the camera frame: (pixels (N, 2) float64, ok (N,) bool); NaN where the point is outside the valid field of view.
        """
    def projection_uncertainty(self, pixels: typing.Any, distance: float | None = None) -> numpy.ndarray[typing.Any, numpy.dtype[numpy.float64]]:
        """
        Projection uncertainty (mrcal's definition, worst-direction 1-sigma, px) at pixels (N, 2): how far the projection of a point fixed relative to the calibration boards, seen there, moves through calibrations perturbed by the corner noise. distance: along the ray in board units (metres); None: at infinity. NaN where a pixel has no ray. Needs a camera written by calibration (fishcam JSON).
        """
    def resized(self, width: int, height: int) -> Camera:
        """
        The same lens for the image resized to width x height: c' = (c + 0.5) s - 0.5, a' = a s.
        """
    def theta_from_rho(self, rho: numpy.typing.ArrayLike) -> numpy.ndarray[typing.Any, numpy.dtype[numpy.float64]]:
        """
        theta (radians) of radii rho (pixels, any shape, float64; same shape out) under the radial model; NaN outside the valid domain. For a camera with tangential terms (radial is False) that is its radial part only: unproject pixels instead.
        """
    def to_json(self) -> str:
        """
        The camera as fishcam JSON text
        """
    def unproject(self, pixels: typing.Any) -> tuple[numpy.ndarray[typing.Any, numpy.dtype[numpy.float64]], numpy.ndarray[typing.Any, numpy.dtype[numpy.bool_]]]:
        """
        Unit rays (N, 3) float64 of pixels (N, 2), and ok (N,) bool; NaN where a pixel has no ray.
        """
    def write(self, path: str, format: str | None = None, overwrite: bool = False) -> None:
        """
        Writes the camera in `format` (default: from the extension); refuses an existing file unless overwrite=True, and a format that cannot hold the model. Only fishcam JSON keeps a calibration record (a UserWarning says when it is left out).
        """
    @property
    def distortion(self) -> str:
        """
        The plane distortion's name: 'none', 'tangential' (the tangential property gives its terms) or 'mrcal_lens' (the mrcal_lens property gives it); docs/architecture.md lists the parts of a camera.
        """
    @property
    def domain(self) -> ValidDomain:
        """
        The model's valid domain (ValidDomain).
        """
    @property
    def field_of_view_deg(self) -> FieldOfView:
        """
        The image's angular coverage (FieldOfView, degrees).
        """
    @property
    def height(self) -> int:
        """
        Image height in pixels (int).
        """
    @property
    def model(self) -> str:
        """
        The model's name (docs/conventions.md lists them), e.g. 'polynomial', 'kannala-brandt'.
        """
    @property
    def mrcal_lens(self) -> tuple[str, list[float]] | None:
        """
        mrcal's lens model on the plane of the camera's model, evaluated by libmrcal (splined stereographic, CAHVOR on pinhole, CAHVORE, LONLAT and LATLON on stereographic): (lensmodel, its values after fx, fy, cx, cy), or None.
        """
    @property
    def observed_theta_max_deg(self) -> float | None:
        """
        The largest angle of incidence its calibration observed (degrees), or None for a camera without a calibration record.
        """
    @property
    def parameters(self) -> list[float]:
        """
        The model's parameters (list of float), in the order docs/conventions.md gives.
        """
    @property
    def pixel_scale(self) -> numpy.ndarray[tuple[typing.Literal[2], typing.Literal[1]], numpy.dtype[numpy.float64]]:
        """
        (a_x, a_y): pixel = c + a * rho(theta) * direction; float64 array (2,).
        """
    @property
    def pose(self) -> tuple[numpy.ndarray[tuple[typing.Literal[3], typing.Literal[3]], numpy.dtype[numpy.float64]], numpy.ndarray[tuple[typing.Literal[3], typing.Literal[1]], numpy.dtype[numpy.float64]]] | None:
        """
        The pose camera to reference, p_ref = R p_cam + t: a tuple of R (3, 3) and t (3,), or None
        """
    @property
    def principal_point(self) -> numpy.ndarray[tuple[typing.Literal[2], typing.Literal[1]], numpy.dtype[numpy.float64]]:
        """
        (cx, cy) in pixels, float64 array (2,).
        """
    @property
    def radial(self) -> bool:
        """
        Whether the camera is radially symmetric (no plane distortion, no skew): only then do rho and theta_from_rho describe its whole projection.
        """
    @property
    def skew(self) -> tuple[float, float]:
        """
        The pixel grid's skew (xy, yx): pixel = c + a * ([[1, xy], [yx, 1]] q) with q the model's image offset (docs/conventions.md); (0, 0) for the usual grid.
        """
    @property
    def tangential(self) -> dict[str, float]:
        """
        The tangential and thin-prism terms {'p1', 'p2', 's1', 's2', 's3', 's4'} (dict of float) on the model's undistorted plane (docs/conventions.md); all 0 unless distortion is 'tangential'.
        """
    @property
    def theta_limit_by_azimuth_deg(self) -> list[float] | None:
        """
        The per-azimuth cap on the angle of incidence (degrees; 24 sectors of 15 degrees, sector k covering azimuths atan2(y, x) in [-180 + 15 k, -165 + 15 k)), or None: limited_to_observed sets it.
        """
    @property
    def width(self) -> int:
        """
        Image width in pixels (int).
        """
class AngleBin:
    """
    A fit's error over the rays of one 10-degree band of theta.
    """
    @property
    def max_px(self) -> float:
        """
        Largest pixel error.
        """
    @property
    def rms_px(self) -> float:
        """
        Root mean square pixel error (2-D norm).
        """
    @property
    def samples(self) -> int:
        """
        Rays in the band (int).
        """
    @property
    def theta_from_deg(self) -> float:
        """
        The band's lower edge (degrees).
        """
    @property
    def theta_to_deg(self) -> float:
        """
        The band's upper edge (degrees).
        """
class FitReport:
    """
    How far the fitted camera reprojects the source camera's rays (pixels, 2-D norm): what `fishcam convert --json` prints.
    """
    def __repr__(self) -> str:
        ...
    @property
    def by_angle(self) -> list[AngleBin]:
        """
        The error per 10-degree band (list of AngleBin).
        """
    @property
    def max_below_90_px(self) -> float:
        """
        Largest error over the rays below 90 deg.
        """
    @property
    def max_px(self) -> float:
        """
        Largest pixel error.
        """
    @property
    def p99_px(self) -> float:
        """
        99th percentile of the pixel error.
        """
    @property
    def rms_below_90_px(self) -> float:
        """
        RMS error over the rays below 90 deg.
        """
    @property
    def rms_px(self) -> float:
        """
        Root mean square pixel error.
        """
    @property
    def samples(self) -> int:
        """
        Rays compared (int).
        """
    @property
    def samples_below_90(self) -> int:
        """
        Rays with theta < 90 deg (what OpenCV's fisheye functions can use).
        """
    @property
    def unprojectable(self) -> int:
        """
        Rays the fitted camera cannot project (int).
        """
class Conversion:
    """
    fishcam.convert's result: the fitted camera and its FitReport; unpacks as (camera, report).
    """
    def __iter__(self) -> typing.Iterator[typing.Any]:
        """
        camera, report = fishcam.convert(...)
        """
    def to_json(self) -> str:
        """
        What `fishcam convert --json` prints (str).
        """
    @property
    def camera(self) -> Camera:
        """
        The fitted camera.
        """
    @property
    def center_and_aspect_fitted(self) -> bool:
        """
        Whether the principal point and a_y were fitted (always for a source with tangential terms).
        """
    @property
    def non_radial_px(self) -> tuple[float, float] | None:
        """
        For a source that is not radially symmetric: (rms, max) pixels no radial model gets below about the fitted principal point (the best free-form rho(theta)'s error); None for a radial source.
        """
    @property
    def report(self) -> FitReport:
        """
        Its FitReport against the source camera.
        """
    @property
    def widest_theta_deg(self) -> float:
        """
        The widest ray of the evaluation grid (degrees).
        """
class ViewpointChange:
    """
    A viewpoint change (the paper's eq. 7): a point P of the camera frame is at R P + t in the moved camera's frame; R = Rz Ry Rx of rotation_deg (x applied first), t in unit-sphere units.
    """
    def __getstate__(self) -> tuple[typing.Any, ...]:
        ...
    def __init__(self, rotation_deg: numpy.typing.ArrayLike = ..., translation: numpy.typing.ArrayLike = ...) -> None:
        """
        rotation_deg: (3,) degrees about x, y, z; translation: (3,).
        """
    def __reduce__(self) -> tuple[typing.Any, ...]:
        """
        Pickling at every protocol: (copyreg.__newobj__, (type,), __getstate__())
        """
    def __repr__(self) -> str:
        ...
    def __setstate__(self, arg0: tuple[typing.Any, ...]) -> None:
        ...
    @property
    def rotation(self) -> numpy.ndarray[tuple[typing.Literal[3], typing.Literal[3]], numpy.dtype[numpy.float64]]:
        """
        R of eq. 7: float64 array (3, 3).
        """
    @property
    def rotation_deg(self) -> numpy.ndarray[tuple[typing.Literal[3], typing.Literal[1]], numpy.dtype[numpy.float64]]:
        """
        Degrees about x, y, z: float64 array (3,).
        """
    @property
    def translation(self) -> numpy.ndarray[tuple[typing.Literal[3], typing.Literal[1]], numpy.dtype[numpy.float64]]:
        """
        t of eq. 7: float64 array (3,).
        """
class ViewpointWarp:
    """
    The viewpoint augmentation of one calibration (source camera -> target camera, the same by default): caches the target's rays and the grid plan, so keep one per calibration.
    """
    def __call__(self, *, image: numpy.ndarray[typing.Any, numpy.dtype[typing.Any]] | None = None, labels: numpy.ndarray[typing.Any, numpy.dtype[typing.Any]] | None = None, change: ViewpointChange, depth: str = 'source-sphere', fill: float = 0.0, label_fill: int = 0, return_valid: bool = False, sampling: str = 'grid', depth_map: numpy.ndarray[typing.Any, numpy.dtype[typing.Any]] | None = None, depth_values: str = 'range') -> dict[str, typing.Any]:
        """
        warp(...): one augmented sample (what `fishcam augment` writes): image HxW or HxWxC (uint8, uint16, float32; bilinear) and labels HxW (uint8, uint16; nearest); a dict of new arrays: image, labels, valid when asked.
        """
    def __getstate__(self) -> tuple[typing.Any, ...]:
        ...
    def __init__(self, camera: Camera, target: Camera | None = None) -> None:
        """
        camera: the images' camera; target: the output camera (default: the same).
        """
    def __reduce__(self) -> tuple[typing.Any, ...]:
        """
        Pickling at every protocol: (copyreg.__newobj__, (type,), __getstate__())
        """
    def __setstate__(self, arg0: tuple[typing.Any, ...]) -> None:
        ...
    def forward(self, points: typing.Any, change: ViewpointChange, depth: str = 'source-sphere', depth_map: numpy.ndarray[typing.Any, numpy.dtype[typing.Any]] | None = None, depth_values: str = 'range') -> tuple[numpy.ndarray[typing.Any, numpy.dtype[numpy.float64]], numpy.ndarray[typing.Any, numpy.dtype[numpy.bool_]]]:
        """
        Where source pixels (N, 2) appear after the change: (pixels (N, 2) float64, NaN where none; visible (N,) bool: inside the output and not hidden)
        """
    def maps(self, change: ViewpointChange, depth: str = 'source-sphere', kind: str = 'geometric', exact: bool = False, grid: bool = False) -> tuple[numpy.ndarray[typing.Any, numpy.dtype[numpy.float32]], numpy.ndarray[typing.Any, numpy.dtype[numpy.float32]], numpy.ndarray[typing.Any, numpy.dtype[numpy.bool_]]]:
        """
        The maps of a change: (map_x, map_y (H, W) float32, valid (H, W) bool). kind='geometric': source coordinates, NaN where none; 'sampling': what resampling uses. exact=True: the double-precision reference; grid=True: the grid path's (within 1/32 px), geometric.
        """
    def sampling_grid(self, change: ViewpointChange, depth: str = 'source-sphere') -> tuple[numpy.ndarray[typing.Any, numpy.dtype[numpy.float32]], numpy.ndarray[typing.Any, numpy.dtype[numpy.bool_]]]:
        """
        The grid path's maps as torch.nn.functional.grid_sample takes them (align_corners=True): (grid (H, W, 2) float32 in [-1, 1], valid (H, W) bool)
        """
    def warp(self, *, image: numpy.ndarray[typing.Any, numpy.dtype[typing.Any]] | None = None, labels: numpy.ndarray[typing.Any, numpy.dtype[typing.Any]] | None = None, change: ViewpointChange, depth: str = 'source-sphere', fill: float = 0.0, label_fill: int = 0, return_valid: bool = False, sampling: str = 'grid', depth_map: numpy.ndarray[typing.Any, numpy.dtype[typing.Any]] | None = None, depth_values: str = 'range') -> dict[str, typing.Any]:
        """
        One augmented sample (what `fishcam augment` writes): image HxW or HxWxC (uint8, uint16, float32; bilinear) and labels HxW (uint8, uint16; nearest); a dict of new arrays: image, labels, valid when asked. depth: a prior, or "map" with depth_map (the source's HxW float32 range or z, depth_values; exact, no source where the source never saw the scene).
        """
    def warp_depth(self, depth_map: numpy.ndarray[typing.Any, numpy.dtype[typing.Any]], change: ViewpointChange, depth: str = 'source-sphere', values: str = 'range', fill: float = ...) -> numpy.ndarray[typing.Any, numpy.dtype[typing.Any]]:
        """
        A depth map (HxW float32, range or z) seen from the moved camera: nearest-neighbour sampled, values re-expressed in the moved camera (exact for rotations; with depth="map", the map is the prior: exact); fill where there is no source
        """
    @property
    def float_kernel(self) -> bool:
        """
        Whether maps come from the float kernel (within 1e-3 px), else the exact path.
        """
    @property
    def grid_error_px(self) -> float:
        """
        The grid's measured worst interpolation error against the per-pixel map (px).
        """
    @property
    def grid_spacing(self) -> int:
        """
        The grid path's node spacing in pixels (0: no grid, per-pixel maps).
        """
    @property
    def source(self) -> Camera:
        """
        The images' camera.
        """
    @property
    def target(self) -> Camera:
        """
        The output camera.
        """
class AffineChange:
    def __getstate__(self) -> tuple[typing.Any, ...]:
        ...
    def __init__(self, rotation_deg: float = 0.0, translation: numpy.typing.ArrayLike = ..., scale: float = 1.0) -> None:
        ...
    def __reduce__(self) -> tuple[typing.Any, ...]:
        """
        Pickling at every protocol: (copyreg.__newobj__, (type,), __getstate__())
        """
    def __repr__(self) -> str:
        ...
    def __setstate__(self, arg0: tuple[typing.Any, ...]) -> None:
        ...
    @property
    def rotation_deg(self) -> float:
        ...
    @property
    def scale(self) -> float:
        ...
    @property
    def translation(self) -> numpy.ndarray[tuple[typing.Literal[2], typing.Literal[1]], numpy.dtype[numpy.float64]]:
        ...
class DisplacementStats:
    """
    How far the alternative model's augmentation puts pixels from the reference's (px).
    """
    def __repr__(self) -> str:
        ...
    @property
    def max_px(self) -> float:
        """
        Largest displacement.
        """
    @property
    def mean_px(self) -> float:
        """
        Mean displacement.
        """
    @property
    def p95_px(self) -> float:
        """
        95th percentile (numpy's linear interpolation).
        """
    @property
    def pixels(self) -> int:
        """
        (output pixel, change) pairs compared (int).
        """
class ModelComparison:
    """
    One alternative model against the reference camera.
    """
    @property
    def by_angle(self) -> list[DisplacementStats]:
        """
        Per band of Comparison.angle_bands_deg (list of DisplacementStats).
        """
    @property
    def camera(self) -> Camera:
        """
        The alternative camera.
        """
    @property
    def displacement(self) -> DisplacementStats:
        """
        Over every compared pixel (DisplacementStats).
        """
    @property
    def fit_rms_px(self) -> float | None:
        """
        The fit's RMS error over the camera's image when fitted, else None.
        """
    @property
    def how(self) -> str:
        """
        Where it came from: 'least-squares fit', "the paper's eqs. 13-14", 'read from FILE', ...
        """
    @property
    def identity_max_px(self) -> float:
        """
        Largest displacement of the identity change (the models' own disagreement).
        """
    @property
    def labels_differ_pct(self) -> list[float]:
        """
        Percent of labels that differ, per label image (aligned with Comparison.label_names).
        """
    @property
    def mean_displacement(self) -> numpy.ndarray[typing.Any, numpy.dtype[numpy.float32]]:
        """
        Mean displacement per output pixel over the changes, (H, W) float32, NaN where none.
        """
    @property
    def name(self) -> str:
        """
        The model as named: a model name or a file.
        """
    @property
    def validity_differs_pct(self) -> float:
        """
        Percent of output pixels with a source under one model only.
        """
class Comparison:
    """
    What `fishcam compare` measures (docs/comparison.md).
    """
    def to_json(self) -> str:
        """
        What `fishcam compare --json` prints (str).
        """
    @property
    def angle_bands_deg(self) -> list[float]:
        """
        The edges of ModelComparison.by_angle's bands (degrees).
        """
    @property
    def changes(self) -> list[ViewpointChange]:
        """
        The viewpoint changes (list of ViewpointChange).
        """
    @property
    def depth(self) -> str:
        """
        The depth prior.
        """
    @property
    def label_names(self) -> list[str]:
        """
        The label images compared.
        """
    @property
    def models(self) -> list[ModelComparison]:
        """
        One ModelComparison per alternative model.
        """
    @property
    def preset(self) -> str:
        """
        The pose preset of the changes.
        """
    @property
    def samples(self) -> int:
        """
        Changes compared.
        """
    @property
    def seed(self) -> int:
        """
        The changes' seed.
        """
class ConfusionMatrix:
    def __init__(self, num_classes: int, ignore: int | None = None) -> None:
        ...
    def _iou(self) -> list[float | None]:
        ...
    def _miou(self) -> float | None:
        ...
    def merge(self, other: ConfusionMatrix) -> None:
        ...
    def update(self, prediction: typing.Any, ground_truth: typing.Any, valid: typing.Any = None) -> None:
        """
        Counts pixels: prediction and ground_truth integer arrays of one shape (uint8, uint16, int32, int64), valid an optional bool mask of that shape; a value that is not a class raises and counts nothing.
        """
    @property
    def counts(self) -> numpy.ndarray[typing.Any, numpy.dtype[numpy.int64]]:
        ...
    @property
    def ignore(self) -> int | None:
        ...
    @property
    def num_classes(self) -> int:
        ...
    @property
    def scored_pixels(self) -> int:
        ...
class Calibration:
    """
    A chessboard calibration (what `fishcam calibrate --json` reports), typed.
    """
    def __repr__(self) -> str:
        ...
    @property
    def board_warp(self) -> tuple[float, float] | None:
        """
        The boards' warp (x2, y2), board units: mrcal's calobject_warp, the deflections at the middle of the board's width and height; None where the boards were held flat (board_warp=False).
        """
    @property
    def board_warp_sigmas(self) -> tuple[float, float] | None:
        """
        Their 1-sigma (x2, y2); None where the boards were held flat.
        """
    @property
    def camera(self) -> Camera:
        """
        The calibrated camera, with its calibration record (observed angles, covariance).
        """
    @property
    def corners(self) -> int:
        """
        Corners used (outliers excluded).
        """
    @property
    def images(self) -> list[str]:
        """
        File names of the boards used, in file order.
        """
    @property
    def noise_px(self) -> float:
        """
        Residual standard deviation per coordinate (px), degrees of freedom accounted for.
        """
    @property
    def outliers(self) -> list[tuple[str, int, float]]:
        """
        Corners dropped as outliers: (image, corner index, error px).
        """
    @property
    def parameters(self) -> dict[str, typing.Any]:
        """
        Model parameters, the tangential terms solved (MODEL+tangential: p1, p2), cx, cy, a_y by name (dict of float).
        """
    @property
    def per_image_rms_px(self) -> list[float]:
        """
        RMS per image (px), as `images`.
        """
    @property
    def poses(self) -> list[tuple[numpy.ndarray[tuple[typing.Literal[3], typing.Literal[3]], numpy.dtype[numpy.float64]], numpy.ndarray[tuple[typing.Literal[3], typing.Literal[1]], numpy.dtype[numpy.float64]]]]:
        """
        Board poses, as `images`: (R, t) with p_camera = R p_board + t.
        """
    @property
    def rms_per_coordinate_px(self) -> float:
        """
        The same per coordinate (what mrcal and OpenCV print): rms_px / sqrt(2).
        """
    @property
    def rms_px(self) -> float:
        """
        RMS of the corners' 2-D reprojection error (px).
        """
    @property
    def sigmas(self) -> dict[str, typing.Any]:
        """
        1-sigma uncertainty by name (dict); None for a parameter the data do not determine.
        """
    @property
    def undetermined(self) -> list[str]:
        """
        The combinations of parameters the data do not determine (list of str).
        """
    @property
    def warnings(self) -> list[str]:
        """
        What the user should know (list of str).
        """
class RigCalibration:
    """
    A camera rig's joint calibration (what `fishcam calibrate --corners A --corners B ... --json` reports), typed.
    """
    def __repr__(self) -> str:
        ...
    @property
    def cameras(self) -> list[Calibration]:
        """
        Per camera its Calibration; camera.pose is camera -> camera 0.
        """
    @property
    def fixed_intrinsics(self) -> list[bool]:
        """
        Per camera, whether its intrinsics were held fixed (given as a Camera) or solved.
        """
    @property
    def instants(self) -> int:
        """
        Distinct instants with a board.
        """
    @property
    def rms_px(self) -> float:
        """
        RMS 2-D reprojection error over every camera (px).
        """
    @property
    def rotation_sigma_deg(self) -> list[float]:
        """
        Per camera, 1-sigma of its rotation relative to camera 0 (degrees; the largest angle-axis component).
        """
    @property
    def translation_sigma(self) -> list[float]:
        """
        Per camera, 1-sigma of its translation relative to camera 0 (board units; the largest component).
        """
    @property
    def warnings(self) -> list[str]:
        """
        What the user should know (list of str).
        """
def _initialised(arg0: typing.Any) -> bool:
    ...
def _input_address(arg0: typing.Any, arg1: str) -> int:
    ...
def affine_forward(points: typing.Any, change: AffineChange, width: int, height: int) -> tuple[numpy.ndarray[typing.Any, numpy.dtype[numpy.float64]], numpy.ndarray[typing.Any, numpy.dtype[numpy.bool_]]]:
    """
    Where points (N, 2) land under the affine change: (pixels (N, 2), visible (N,) bool: inside the image)
    """
def affine_presets() -> dict[str, typing.Any]:
    ...
def affine_warp(*, image: numpy.ndarray[typing.Any, numpy.dtype[typing.Any]] | None = None, labels: numpy.ndarray[typing.Any, numpy.dtype[typing.Any]] | None = None, change: AffineChange, fill: float = 0.0, label_fill: int = 0, return_valid: bool = False) -> dict[str, typing.Any]:
    ...
def affine_warp_depth(depth_map: numpy.ndarray[typing.Any, numpy.dtype[typing.Any]], change: AffineChange, fill: float = ...) -> numpy.ndarray[typing.Any, numpy.dtype[typing.Any]]:
    ...
def calibrate(observations: list[typing.Any], board: tuple[int, int] | str, spacing: float | None, image_size: tuple[int, int], model: str, threads: int = 1, board_warp: bool = True) -> Calibration:
    """
    Calibrates `model` (a model name; 'MODEL+tangential' also solves OpenCV's p1, p2 and 'MODEL+thin-prism' p1, p2, s1..s4, for pinhole, opencv and mei; mrcal's splined model by its mrcal name, 'LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=10_fov_x_deg=200', solved as mrcal-calibrate-cameras solves it) from chessboard corners (what read_corners gives: (filename, corners (N, 2)) pairs; board (W, H) inner corners with spacing in metres, or a target's text with spacing None: 'aprilgrid:COLSxROWS:SIZE:SPACING' (Kalibr's AprilGrid: tag side SIZE metres, the gap between tags SPACING times it) or 'charuco:COLSxROWS:SQUARE:MARKER[:DICTIONARY]', as `fishcam detect-corners --target` found them; image_size (width, height)): a Calibration. threads: for the independent solves; the result is the same for every count. board_warp: solve the boards' warp (mrcal's calobject_warp, as mrcal does; Calibration.board_warp), False: flat boards (OpenCV's model). Raises fishcam.Error on data that cannot determine a camera (a transposed board, one pose, a principal point off the image, ...).
    """
def calibrate_rig(cameras: list[typing.Any], board: tuple[int, int] | str, spacing: float | None, threads: int = 1, board_warp: bool = True) -> RigCalibration:
    """
    Calibrates a camera rig jointly: cameras is a list of (observations, (width, height), model), one per camera, observations as read_corners gives them; board and spacing as calibrate takes them (a chessboard or a target); images of one instant share their file name (the last path component). model: a model name (the camera's intrinsics solved) or a fishcam.Camera for those images (its intrinsics held fixed, as calibrate --fix-intrinsics FILE: only where it sits is solved). Every solved camera's intrinsics, each camera's pose relative to camera 0 and the boards' poses: a RigCalibration. board_warp: solve the boards' warp in the joint solve (mrcal's calobject_warp, as mrcal does; every camera's Calibration.board_warp), False: flat boards (OpenCV's stereoCalibrate). Raises fishcam.Error when a camera cannot be calibrated alone or shares no instant.
    """
def check_depth_prior(arg0: str) -> None:
    """
    Raises fishcam.Error naming the choices unless name is a depth prior.
    """
def check_preset(arg0: str) -> None:
    """
    Raises fishcam.Error naming the choices unless name is a pose preset.
    """
def compare(camera: Camera, models: list[typing.Any], method: str, preset: str, samples: int, seed: int, depth: str, labels: dict[str, typing.Any]) -> Comparison:
    ...
def convert(camera: Camera, to: str, method: str = 'lsq', max_angle: float | None = None, fit_center: bool = False, fit_aspect: bool = False) -> Conversion:
    """
    Fits model `to` to `camera` as `fishcam convert` does (method 'lsq' or 'paper'; max_angle in degrees): a Conversion (camera, report).
    """
def dataset_fidelity(dataset: str) -> list[dict[str, typing.Any]]:
    """
    How faithful the augmentation is to the truth on a dataset of `fishcam sample-dataset --scenes N [--depth]` (as `fishcam fidelity`): each test sample augmented by the change of each true viewpoint test set (test-*/changes.jsonl) under every depth prior, and its depth map when the dataset has test/depth/, against the re-render from the moved camera. One dict per test set and prior: test_set, prior, samples, valid_share (pixels with a source), label_agreement (away from class boundaries), psnr_db; means over the samples.
    """
def dataset_model_fidelity(dataset: str, models: list[str], depth: str = 'source-sphere') -> list[dict[str, typing.Any]]:
    """
    The paper's Table 5 by geometry (as `fishcam fidelity --models`): each true viewpoint test set of a dataset of `fishcam sample-dataset --scenes N` augmented through each of `models` -- 'own' (the camera itself) or a model fitted to each sample's camera, 'NAME' or 'NAME:paper' / 'NAME:lsq' (eqs. 13-14 or least squares) -- under the depth prior `depth`, against the re-render from the moved camera. One dict per test set and model: test_set, model, how, samples, valid_share, label_agreement, psnr_db (means over the samples), endpoint_px (mean distance of the model's map from the camera's own, px) and endpoint_by_angle_px (by the output pixel's angle of incidence: 0-30, 30-60, 60-90, 90+ degrees; NaN for a band without pixels).
    """
def depth_priors() -> list[str]:
    """
    The depth priors' names.
    """
def depth_priors_and_map() -> list[str]:
    """
    The depth priors' names and "map" (the source image's depth map in place of a prior).
    """
def depth_values_names() -> list[str]:
    """
    What depth maps' values can be.
    """
def derive_seed(seed: int, key: str, index: int) -> int:
    """
    A 64-bit seed per (key, index) from one user seed (SplitMix64 over FNV-1a of the key): the seeds of augment-dataset, compare and WoodScapeDataset(seed=).
    """
def get_num_threads() -> int:
    """
    The threads fishcam's compute uses (int).
    """
def presets() -> dict[str, typing.Any]:
    ...
def random_affine(preset: str, seed: int) -> AffineChange:
    ...
def random_affine_in(max_rotation_deg: float, max_translation: float, min_scale: float, max_scale: float, seed: int) -> AffineChange:
    ...
def random_change(preset: str, seed: int) -> ViewpointChange:
    ...
def random_change_in(max_rotation_deg: float, max_translation: float, seed: int) -> ViewpointChange:
    ...
def read_corners(path: str, board: tuple[int, int] | str) -> list[tuple[str, numpy.ndarray[typing.Any, numpy.dtype[numpy.float64]]]]:
    """
    A corners file (mrcal's vnlog: filename x y level) of a board of (W, H) inner corners, or of a target (its text, as calibrate takes it; an AprilGrid of C x R tags has 2C x 2R corners): a list of (filename, corners (N, 2) float64), N = 0 for an image without a board; a partial board (rows whose level is '-') has all W*H rows in board order, NaN for the corners not observed.
    """
def render(camera: Camera, scene_seed: int | None = None, change: ViewpointChange | None = None, supersampling: int = 2) -> dict[str, typing.Any]:
    """
    Ray-casts a street scene through `camera` at its pose (moved by `change` when given): the bundled street, or the random street of `scene_seed`. Returns {'image': (H, W, 3) uint8 RGB (supersampling^2 rays per pixel), 'mask': (H, W) uint8 WoodScape class ids, 'depth': (H, W) float32 range along each pixel's ray in metres (inf: sky, NaN: outside the camera's domain)}; mask and depth from one ray through each pixel centre.
    """
def reprojection_error_map(source: Camera, fitted: Camera) -> numpy.ndarray[typing.Any, numpy.dtype[numpy.float32]]:
    """
    The pixel error of `fitted` at every pixel of `source`'s image (float32 (H, W), NaN where the source has no ray or `fitted` none): what `fishcam convert --error-map` writes.
    """
def sampling_names() -> list[str]:
    """
    The sampling modes' names.
    """
def set_num_threads(arg0: int) -> None:
    ...
def woodscape_classes() -> list[tuple[str, tuple[int, int, int]]]:
    """
    The WoodScape classes the renderer labels, by id: [(name, (r, g, b) display colour), ...].
    """
__version__: str = '0.1.0'
