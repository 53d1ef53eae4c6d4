# Type stubs of the penumbra package (PEP 484/561), written by hand from the bindings
# (bindings/python/penumbra_module.cpp); tests/test_stubs.py checks that they name every class,
# member, function and keyword the extension has. Vectors (Vec3) come back as lists of floats and
# are accepted as any sequence; images are float32 NumPy arrays (H, W, C).
import os
from typing import Callable, ClassVar, Iterator, Mapping, Optional, Sequence, Union, overload

import numpy as np
import numpy.typing as npt

__version__: str
__all__: list[str]

_Path = Union[str, os.PathLike[str]]
_Vec3 = Sequence[float]
_FloatImage = npt.NDArray[np.float32]
_ArrayLike = npt.ArrayLike

# ---- errors -----------------------------------------------------------------------------------
class Error(RuntimeError): ...
class BadInput(Error, ValueError): ...
class NoPlatform(Error): ...
class KernelBuild(Error): ...
class OutOfMemory(Error, MemoryError): ...
class DeviceError(Error): ...
class InternalError(Error): ...
class Cancelled(Error): ...

# ---- context ----------------------------------------------------------------------------------
class DeviceInfo:
    @property
    def index(self) -> int: ...
    @property
    def platform(self) -> str: ...
    @property
    def name(self) -> str: ...
    @property
    def version(self) -> str: ...
    @property
    def global_mem_bytes(self) -> int: ...
    @property
    def max_work_group_size(self) -> int: ...
    @property
    def fp64(self) -> bool: ...
    @property
    def int64_atomics(self) -> bool: ...

def list_devices() -> list[DeviceInfo]: ...

class Context:
    @overload
    def __init__(self, device: str = "") -> None: ...
    @overload
    def __init__(self, device: int) -> None: ...
    @property
    def info(self) -> DeviceInfo: ...
    def stage_times_ms(self) -> dict[str, float]: ...
    def reset_timings(self) -> None: ...
    def finish(self) -> None: ...

# ---- images -----------------------------------------------------------------------------------
def read_image(path: _Path) -> _FloatImage: ...
def write_image(path: _Path, image: _ArrayLike, exposure: Optional[float] = None,
                metadata: Optional[Mapping[str, Union[str, float]]] = None) -> None: ...
def tonemap(image: _ArrayLike, exposure: Optional[float] = None) -> npt.NDArray[np.uint8]: ...
def auto_exposure(image: _ArrayLike) -> float: ...

# ---- environment ------------------------------------------------------------------------------
class Environment:
    source: str
    equirect: _FloatImage
    rotation_y_deg: float
    def __init__(self) -> None: ...
    @property
    def sanitized_pixels(self) -> int: ...
    @property
    def non_finite_values(self) -> int: ...
    @property
    def negative_values(self) -> int: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    def lookup(self, direction: _Vec3) -> list[float]: ...
    def power(self) -> list[float]: ...
    def irradiance(self, normal: _Vec3) -> list[float]: ...
    def with_rotation_applied(self) -> Environment: ...

def load_environment(path: _Path) -> Environment: ...
def builtin_environment(width: int = 512) -> Environment: ...
def environment_from(path_or_builtin: _Path) -> Environment: ...
def cube_map_energy(ctx: Context, env: Environment, face_size: int,
                    supersample: int = 4) -> _FloatImage: ...

# ---- scene ------------------------------------------------------------------------------------
class Mesh:
    name: str
    positions: npt.NDArray[np.float32]
    normals: npt.NDArray[np.float32]
    triangles: npt.NDArray[np.int32]
    albedo: list[float]
    def __init__(self) -> None: ...

class Bounds:
    lo: list[float]
    hi: list[float]
    def center(self) -> list[float]: ...
    def radius(self) -> float: ...

class Camera:
    eye: list[float]
    target: list[float]
    up: list[float]
    fovy_deg: float
    def __init__(self, *, eye: _Vec3 = ..., target: _Vec3 = ..., up: _Vec3 = ...,
                 fovy_deg: float = ...) -> None: ...

class Scene:
    meshes: list[Mesh]
    def __init__(self) -> None: ...
    def bounds(self) -> Bounds: ...
    def triangle_count(self) -> int: ...

def builtin_scene(time: float = 0.0) -> Scene: ...
def load_scene(path: _Path, add_ground: bool = True, timeout_seconds: float = 0.0,
               memory_limit_bytes: int = 0) -> Scene: ...
def scene_from(path_or_builtin: _Path, add_ground: bool = True, timeout_seconds: float = 0.0,
               memory_limit_bytes: int = 0) -> Scene: ...
def validate_scene(scene: Scene) -> None: ...
def frame_camera(scene: Scene, aspect: float) -> Camera: ...
def parse_camera(text: str) -> Camera: ...

# ---- lights -----------------------------------------------------------------------------------
class LightShape:
    CAP: ClassVar[LightShape]
    POLYGON: ClassVar[LightShape]
    def __init__(self, value: int) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def value(self) -> int: ...

class LightOutline:
    VERTICES: ClassVar[LightOutline]
    RECT: ClassVar[LightOutline]
    ELLIPSE: ClassVar[LightOutline]
    def __init__(self, value: int) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def value(self) -> int: ...

class LightTexture:
    width: int
    height: int
    radiance: list[float]
    def __init__(self, *, width: int = ..., height: int = ...,
                 radiance: Sequence[float] = ...) -> None: ...
    def empty(self) -> bool: ...

class LightSample:
    @property
    def dir(self) -> list[float]: ...
    @property
    def weight(self) -> float: ...

class AreaLight:
    Outline: ClassVar[type[LightOutline]]
    shape: LightShape
    vertices: list[list[float]]
    direction: list[float]
    cos_alpha: float
    radiance: list[float]
    power: list[float]
    regions: list[list[int]]
    outline: LightOutline
    axis_u: list[float]
    tan_half: list[float]
    def __init__(self, *, shape: LightShape = ..., vertices: Sequence[_Vec3] = ...,
                 direction: _Vec3 = ..., cos_alpha: float = ..., radiance: _Vec3 = ...,
                 power: _Vec3 = ..., regions: Sequence[Sequence[int]] = ...,
                 outline: LightOutline = ..., axis_u: _Vec3 = ...,
                 tan_half: Sequence[float] = ...) -> None: ...
    @property
    def texture(self) -> LightTexture: ...
    def half_angle(self) -> float: ...
    def solid_angle(self) -> float: ...
    def irradiance(self, normal: _Vec3) -> list[float]: ...
    def axis_v(self) -> list[float]: ...
    def frame_coords(self, d: _Vec3) -> list[float]: ...
    def radiance_at(self, d: _Vec3) -> list[float]: ...
    def sample_weight(self, d: _Vec3) -> float: ...

class LightSet:
    lights: list[AreaLight]
    face_size: int
    method: str
    has_ambient: bool
    ambient_sh: npt.NDArray[np.float32]
    ambient_map: npt.NDArray[np.float32]
    def __init__(self) -> None: ...
    @property
    def directions(self) -> npt.NDArray[np.float32]: ...
    @property
    def powers(self) -> npt.NDArray[np.float32]: ...
    @property
    def radiances(self) -> npt.NDArray[np.float32]: ...
    @property
    def cos_alpha(self) -> npt.NDArray[np.float32]: ...
    def power(self) -> list[float]: ...
    def lights_power(self) -> list[float]: ...
    def ambient_power(self) -> list[float]: ...
    def irradiance(self, normal: _Vec3) -> list[float]: ...
    def ambient_irradiance(self, normal: _Vec3) -> list[float]: ...
    def to_json(self) -> str: ...
    def __len__(self) -> int: ...
    @overload
    def __getitem__(self, index: int) -> AreaLight: ...
    @overload
    def __getitem__(self, slice: slice) -> list[AreaLight]: ...
    def __setitem__(self, index: int, light: AreaLight) -> None: ...
    def __iter__(self) -> Iterator[AreaLight]: ...

def make_polygon_light(vertices: Sequence[_Vec3], radiance: _Vec3) -> AreaLight: ...
def make_rect_light(direction: _Vec3, up: _Vec3, half_angles: Sequence[float],
                    radiance: _Vec3) -> AreaLight: ...
def make_ellipse_light(direction: _Vec3, up: _Vec3, half_angles: Sequence[float],
                       radiance: _Vec3) -> AreaLight: ...
def set_light_texture(light: AreaLight, texture: LightTexture) -> None: ...
def texture_lights_from_map(env: Environment, lights: LightSet, size: int = 8,
                            supersample: int = 4) -> None: ...
def light_samples(light: AreaLight, n: int, rotation: float = 0.0) -> list[LightSample]: ...
def light_sample_directions(light: AreaLight, n: int,
                            rotation: float = 0.0) -> list[list[float]]: ...
def validate_light_set(light_set: LightSet) -> None: ...
def rotate_light_set(light_set: LightSet, degrees: float) -> LightSet: ...
def load_light_set(path: _Path) -> LightSet: ...
def light_set_from_json(text: str, source: str = "light set") -> LightSet: ...

# ---- extraction -------------------------------------------------------------------------------
class ExtractionMethod:
    MEDIAN_CUT: ClassVar[ExtractionMethod]
    GREEDY: ClassVar[ExtractionMethod]
    CENTER_SURROUND: ClassVar[ExtractionMethod]
    def __init__(self, value: int) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def value(self) -> int: ...

class MedianCutOptions:
    lights: int
    face_size: int
    supersample: int
    min_half_angle_deg: float
    max_half_angle_deg: float
    merge_across_faces: bool
    merge_compactness: float
    peak_ratio: float
    peak_max_half_angle_deg: float
    shape: LightShape
    def __init__(self, *, lights: int = ..., face_size: int = ..., supersample: int = ...,
                 min_half_angle_deg: float = ..., max_half_angle_deg: float = ...,
                 merge_across_faces: bool = ..., merge_compactness: float = ...,
                 peak_ratio: float = ..., peak_max_half_angle_deg: float = ...,
                 shape: LightShape = ...) -> None: ...

class GreedyOptions:
    threshold: float
    square: bool
    face_size: int
    max_lights: int
    supersample: int
    def __init__(self, *, threshold: float = ..., square: bool = ..., face_size: int = ...,
                 max_lights: int = ..., supersample: int = ...) -> None: ...

class CenterSurroundOptions:
    width: int
    sizes: int
    min_deg: float
    max_deg: float
    inner_ratio: float
    surround_weight: float
    candidate_fraction: float
    stop_fraction: float
    max_lights: int
    def __init__(self, *, width: int = ..., sizes: int = ..., min_deg: float = ...,
                 max_deg: float = ..., inner_ratio: float = ..., surround_weight: float = ...,
                 candidate_fraction: float = ..., stop_fraction: float = ...,
                 max_lights: int = ...) -> None: ...

class AmbientModel:
    IRRADIANCE_MAP: ClassVar[AmbientModel]
    SH9: ClassVar[AmbientModel]
    def __init__(self, value: int) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def value(self) -> int: ...

class AmbientOptions:
    model: AmbientModel
    map_width: int
    map_height: int
    def __init__(self, *, model: AmbientModel = ..., map_width: int = ...,
                 map_height: int = ...) -> None: ...

class ExtractOptions:
    method: Union[ExtractionMethod, str]
    median_cut: MedianCutOptions
    greedy: GreedyOptions
    center_surround: CenterSurroundOptions
    ambient: bool
    ambient_options: AmbientOptions
    light_texture: int
    target_error: float
    def __init__(self, *, method: Union[ExtractionMethod, str] = ...,
                 median_cut: MedianCutOptions = ..., greedy: GreedyOptions = ...,
                 center_surround: CenterSurroundOptions = ..., ambient: bool = ...,
                 ambient_options: AmbientOptions = ..., light_texture: int = ...,
                 target_error: float = ...) -> None: ...

def light_set_probe_error(env: Environment, lights: LightSet) -> float: ...

def extract_lights(ctx: Context, env: Environment,
                   method: Union[ExtractionMethod, str, None] = None,
                   lights: Optional[int] = None, ambient: Optional[bool] = None,
                   options: Optional[ExtractOptions] = None) -> LightSet: ...
def extract_median_cut(ctx: Context, env: Environment,
                       options: MedianCutOptions = ...) -> LightSet: ...
def extract_greedy(ctx: Context, env: Environment, options: GreedyOptions = ...) -> LightSet: ...
def extract_center_surround(ctx: Context, env: Environment,
                            options: CenterSurroundOptions = ...) -> LightSet: ...
def add_ambient_residual(ctx: Context, env: Environment, lights: LightSet,
                         options: AmbientOptions = ...) -> None: ...
def write_light_overlay(path: _Path, env: Environment, lights: LightSet) -> None: ...

# ---- rendering --------------------------------------------------------------------------------
class ShadowTechnique:
    NONE: ClassVar[ShadowTechnique]
    HARD: ClassVar[ShadowTechnique]
    PCSS: ClassVar[ShadowTechnique]
    CSSM: ClassVar[ShadowTechnique]
    MSSM4: ClassVar[ShadowTechnique]
    MSSM6: ClassVar[ShadowTechnique]
    BRUTE: ClassVar[ShadowTechnique]
    BITMASK: ClassVar[ShadowTechnique]
    BITMASK_HARD: ClassVar[ShadowTechnique]
    AREA_APPROX: ClassVar[ShadowTechnique]
    AUTO: ClassVar[ShadowTechnique]
    def __init__(self, value: int) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def value(self) -> int: ...

class Prefilter:
    SAT: ClassVar[Prefilter]
    MIP: ClassVar[Prefilter]
    def __init__(self, value: int) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def value(self) -> int: ...

def parse_shadow_technique(name: str) -> ShadowTechnique: ...
def technique_name(technique: ShadowTechnique) -> str: ...

class ShadowOptions:
    depth_bias: float
    light_size_scale: float
    max_filter_texels: float
    min_filter_texels: float
    contact_shadows: bool
    contact_from_maps: bool
    contact_texels: float
    horizon_visibility: bool
    ground_visibility: bool
    def __init__(self, *, depth_bias: float = ..., light_size_scale: float = ...,
                 max_filter_texels: float = ..., min_filter_texels: float = ...,
                 contact_shadows: bool = ..., contact_from_maps: bool = ...,
                 contact_texels: float = ...,
                 horizon_visibility: bool = ..., ground_visibility: bool = ...) -> None: ...

class MSSMOptions:
    moment_bias: float
    slope_bias: float
    blocker_epsilon: float
    upper_bound_blocker: bool
    delta1: float
    delta2: float
    upper_bound_tilt: float
    cosine_centroid: bool
    leak_reduction: float
    def __init__(self, *, moment_bias: float = ..., slope_bias: float = ...,
                 blocker_epsilon: float = ..., upper_bound_blocker: bool = ...,
                 delta1: float = ..., delta2: float = ...,
                 upper_bound_tilt: float = ..., cosine_centroid: bool = ...,
                 leak_reduction: float = ...) -> None: ...

class CSSMOptions:
    order: int
    sharpen_a: float
    sharpen_b: float
    ringing_offset: float
    damping: float
    depth_bias: float
    slope_bias: float
    max_basis_bytes: int
    def __init__(self, *, order: int = ..., sharpen_a: float = ..., sharpen_b: float = ...,
                 ringing_offset: float = ..., damping: float = ..., depth_bias: float = ...,
                 slope_bias: float = ..., max_basis_bytes: int = ...) -> None: ...

class PCSSOptions:
    blocker_taps: int
    filter_taps: int
    receiver_plane_bias: bool
    def __init__(self, *, blocker_taps: int = ..., filter_taps: int = ...,
                 receiver_plane_bias: bool = ...) -> None: ...

class BruteOptions:
    samples: int
    batch_bytes: int
    def __init__(self, *, samples: int = ..., batch_bytes: int = ...) -> None: ...

class BitmaskOptions:
    light_samples: int
    list_size: int
    mask_bytes: int
    def __init__(self, *, light_samples: int = ..., list_size: int = ...,
                 mask_bytes: int = ...) -> None: ...

class AreaApproxOptions:
    edge_samples: int
    cap_vertices: int
    taps: int
    batch_bytes: int
    def __init__(self, *, edge_samples: int = ..., cap_vertices: int = ..., taps: int = ...,
                 batch_bytes: int = ...) -> None: ...

class AutoOptions:
    exact_lights: int
    hard_pixels: float
    pcss_texels: float
    pcss_min_elevation_deg: float
    filtered_lights: int
    exact_share: float
    exact_half_angle_deg: float
    def __init__(self, *, exact_lights: int = ..., hard_pixels: float = ...,
                 pcss_texels: float = ..., pcss_min_elevation_deg: float = ...,
                 filtered_lights: int = ..., exact_share: float = ...,
                 exact_half_angle_deg: float = ...) -> None: ...

class RenderOptions:
    width: int
    height: int
    shadow_map_size: int
    technique: Union[ShadowTechnique, str]
    prefilter: Union[Prefilter, str]
    front_back_faces: bool
    shadow: ShadowOptions
    mssm: MSSMOptions
    cssm: CSSMOptions
    pcss: PCSSOptions
    brute: BruteOptions
    bitmask: BitmaskOptions
    area_approx: AreaApproxOptions
    auto_choice: AutoOptions
    environment_background: bool
    bent_normals: bool
    bent_normals_scale: float
    def __init__(self, *, width: int = ..., height: int = ..., shadow_map_size: int = ...,
                 technique: Union[ShadowTechnique, str] = ...,
                 prefilter: Union[Prefilter, str] = ..., front_back_faces: bool = ...,
                 shadow: ShadowOptions = ..., mssm: MSSMOptions = ..., cssm: CSSMOptions = ...,
                 pcss: PCSSOptions = ..., brute: BruteOptions = ...,
                 bitmask: BitmaskOptions = ..., area_approx: AreaApproxOptions = ...,
                 auto_choice: AutoOptions = ..., environment_background: bool = ...,
                 bent_normals: bool = ..., bent_normals_scale: float = ...) -> None: ...

class Frame:
    @property
    def image(self) -> _FloatImage: ...
    @property
    def timings(self) -> dict[str, float]: ...
    @property
    def shadow_map_bytes(self) -> int: ...
    def _repr_png_(self) -> bytes: ...

class Renderer:
    def __init__(self, ctx: Context) -> None: ...
    def render(self, scene: Scene, camera: Camera, lights: LightSet, env: Environment,
               options: RenderOptions = ...) -> Frame: ...
    def last_visibility(self, width: int, height: int) -> npt.NDArray[np.float32]: ...

def render_report_json(ctx: Context, lights: LightSet, env: Environment,
                       options: RenderOptions, frame: Frame) -> str: ...

# ---- reference and comparison -----------------------------------------------------------------
class ReferenceOptions:
    width: int
    height: int
    spp: int
    seed: int
    threads: int
    environment_background: bool
    def __init__(self, *, width: int = ..., height: int = ..., spp: int = ..., seed: int = ...,
                 threads: int = ..., environment_background: bool = ...) -> None: ...

def reference_environment(scene: Scene, camera: Camera, env: Environment,
                          options: ReferenceOptions = ...,
                          progress: Optional[Callable[[float], object]] = None) -> _FloatImage: ...
def reference_lights(scene: Scene, camera: Camera, lights: LightSet, env: Environment,
                     options: ReferenceOptions = ...,
                     progress: Optional[Callable[[float], object]] = None) -> _FloatImage: ...

class ImageMetrics:
    @property
    def rmse(self) -> float: ...
    @property
    def relative_rmse(self) -> float: ...
    @property
    def psnr(self) -> float: ...
    @property
    def max_abs_error(self) -> float: ...
    @property
    def pixels(self) -> int: ...
    def to_json(self) -> str: ...

def compare_images(image: _ArrayLike, reference: _ArrayLike) -> ImageMetrics: ...
