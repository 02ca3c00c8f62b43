"""The scene model: what an SES script means, as frozen dataclasses (no bpy).

Everything here is in the SES world (right-handed, Y up) and the OpenCV camera frame;
angles are degrees unless a name says ``_rad``. Produced by ``ses.parse``; consumed by
the Blender builder, the CLI summary and the render manifest. ``to_json`` gives a plain
dict (the golden-test and manifest form).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import ClassVar, Literal, Optional

import numpy as np

from ..contract.camera import K_matrix
from ..contract.rig import right_from_left
from ..contract.motion import ego_table
from ..contract.timing import DEFAULT_FPS

Vec3 = tuple[float, float, float]
Mat4 = tuple[tuple[float, float, float, float], ...]  # 4 rows of 4, row-major


def mat4(T: np.ndarray) -> Mat4:
    return tuple(map(tuple, np.asarray(T, dtype=float).tolist()))


# --- materials and textures -------------------------------------------------------------

@dataclass(frozen=True, kw_only=True)
class TextureRef:
    """``texture`` of an object or material.

    kind 'builtin': one of textures.BUILTIN_TEXTURES (``number`` and canonical ``name``);
    kind 'image': an image file (``path`` absolute, resolved relative to the script;
    ``source`` as written in the script).
    """
    kind: Literal["builtin", "image"]
    name: str
    number: Optional[int] = None
    path: Optional[str] = None
    source: Optional[str] = None
    scale: float = 1.0  # texture-space scale (extension: bigger = finer pattern)


@dataclass(frozen=True, kw_only=True)
class LibraryParams:
    """A material built from the named library (``blender_sesgen.scene.materials``).

    ``name``: the library entry; ``scale``: divides its pattern size (bigger = finer);
    ``wear``, ``variation`` (0..1), ``bump`` (relief multiplier, >= 0) and ``seed`` (of the
    per-object variation) as documented in docs/ses-language.md (Material library).
    """
    name: str
    scale: float = 1.0
    wear: float = 0.2
    bump: float = 1.0
    variation: float = 0.3
    seed: int = 0


@dataclass(frozen=True, kw_only=True)
class ImageMaps:
    """A user's PBR image set: absolute paths (None = not given) mapped box-wise on the
    object's own coordinates in metres, one repeat every ``size_m``; ``sources`` as written;
    ``bump`` scales the normal map's strength."""
    albedo: Optional[str] = None
    normal: Optional[str] = None
    roughness: Optional[str] = None
    sources: tuple[Optional[str], Optional[str], Optional[str]] = (None, None, None)
    size_m: float = 1.0
    bump: float = 1.0


@dataclass(frozen=True, kw_only=True)
class Material:
    """``MATERIAL name N ...``: a physically based (Principled BSDF) material.

    ``library``: built from a library entry (its colour/roughness/metallic are then the
    entry's defaults unless the script overrides them); ``maps``: the user's image set.
    """
    name: str
    colour: Vec3 = (0.8, 0.8, 0.8)
    texture: Optional[TextureRef] = None
    roughness: float = 0.5
    metallic: float = 0.0
    specular: float = 0.5
    emission: Vec3 = (0.0, 0.0, 0.0)
    emission_strength: float = 0.0
    library: Optional[LibraryParams] = None
    maps: Optional[ImageMaps] = None
    glow: bool = False             # a diffusing library material emits the daylight it passes


# --- objects ----------------------------------------------------------------------------

@dataclass(frozen=True, kw_only=True)
class SceneObject:
    """Common tags of every object. ``id`` is the segmentation label (1..32767)."""
    shape: ClassVar[str] = "object"
    id: int
    name: str                      # from ``name`` or generated: "<shape>_<id>"
    colour: Vec3 = (1.0, 1.0, 1.0)  # multiplies the texture
    texture: Optional[TextureRef] = None
    material: Optional[str] = None  # name of a Material (defined, or a library entry)
    semantic_class: str = "static"  # contract.semantics name: ``class``, else the library material's, else static
    line: int = 0                  # source line (for messages); not part of the scene's meaning


@dataclass(frozen=True, kw_only=True)
class Placed(SceneObject):
    """An object with ``position x y z [rx ry rz]``: centre and XYZ Euler rotation (deg)."""
    position: Vec3
    rotation_deg: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True, kw_only=True)
class Quad(SceneObject):
    shape: ClassVar[str] = "quad"
    vertices: tuple[Vec3, Vec3, Vec3, Vec3]  # in order around the boundary, SES world


@dataclass(frozen=True, kw_only=True)
class Cuboid(Placed):
    shape: ClassVar[str] = "cuboid"
    size: Vec3  # full edge lengths along the object's local x, y, z
    bevel: float = 0.0  # radius of the rounded edges (real geometry; 0 = sharp)


@dataclass(frozen=True, kw_only=True)
class Sphere(Placed):
    shape: ClassVar[str] = "sphere"
    radius: float


@dataclass(frozen=True, kw_only=True)
class Cylinder(Placed):
    shape: ClassVar[str] = "cylinder"
    radius: float
    height: float  # along the object's local Y axis, centred on position


@dataclass(frozen=True, kw_only=True)
class Mesh(Placed):
    """``MESH id N file path ...``: an imported OBJ/PLY/STL/glTF mesh.

    The file's coordinates are taken as SES-world units and axes (Y up), scaled by
    ``scale`` then rotated and moved to ``position``.
    """
    shape: ClassVar[str] = "mesh"
    path: str          # absolute, resolved relative to the script
    source: str        # as written in the script
    scale: Vec3 = (1.0, 1.0, 1.0)


@dataclass(frozen=True, kw_only=True)
class Asset(Placed):
    """``ASSET kind id N position ... [size sx sy sz] [seed n] [bend deg ...] [offset o]``: a
    procedural asset (blender_sesgen.scene.assets), its mesh a pure function of (kind, size, seed,
    bend, offset). ``size`` is always explicit here (the kind's seeded default when the
    script gives none); ``bend`` and ``offset`` only matter for strips."""
    shape: ClassVar[str] = "asset"
    kind: str
    size: Vec3
    seed: int
    bend: tuple[float, ...] = (0.0,)
    offset: float = 0.0
    ground_material: Optional[str] = None   # a building's ground-floor walls' material (else its walls')


@dataclass(frozen=True, kw_only=True)
class BlendImport:
    """``BLEND file PATH id N ...``: the mesh objects of a .blend file (a whole environment).

    Objects keep their place in the file's Blender (Z-up) world, moved as a whole by
    ``position``/``rotation_deg`` and scaled by ``scale`` (SES axes). Each gets an id: its
    custom property ``sesgen_id`` when it has one, else ``first_id``, ``first_id`` + 1, ...
    in the order of their names (skipping ids in use), and a class: its ``sesgen_class``
    property, else ``semantic_class``. ``collection``: only that collection's objects.
    ``lights``: keep the file's lamps. The ids are assigned when the file is loaded (the
    manifest lists them); no script stored in the file ever runs. The files it refers to
    (images, linked libraries) must lie in its folder unless ``allow_external``.
    """
    path: str
    source: str
    first_id: int
    collection: Optional[str] = None
    position: Vec3 = (0.0, 0.0, 0.0)
    rotation_deg: Vec3 = (0.0, 0.0, 0.0)
    scale: Vec3 = (1.0, 1.0, 1.0)
    semantic_class: str = "static"
    lights: bool = True
    allow_external: bool = False   # the file's images and libraries may lie outside its folder
    line: int = 0


# --- environment ------------------------------------------------------------------------

@dataclass(frozen=True, kw_only=True)
class Light:
    """``LIGHT sun|point|spot|area|portal ...``.

    sun: ``direction`` (the way the light travels, SES world), ``strength`` in W/m^2.
    point: ``position``, ``strength`` in W, ``size`` = radius.
    spot: ``position``, ``direction``, ``strength`` in W, ``size`` = radius, cone
    ``spot_angle_deg`` (full angle) with a soft edge ``spot_blend`` (0..1).
    area: ``position``, ``direction`` (the way it emits), ``size`` = edge (``size_y``: a
    rectangle's second edge, along the light's own y), ``strength`` in W.
    portal: an area (``position``, ``direction`` into the room, ``size``/``size_y``) that
    emits nothing itself but tells the renderer where the sky comes in (a window).
    """
    kind: Literal["sun", "point", "spot", "area", "portal"]
    colour: Vec3 = (1.0, 1.0, 1.0)
    strength: float = 3.0
    position: Optional[Vec3] = None
    direction: Optional[Vec3] = None
    size: float = 0.0
    size_y: Optional[float] = None
    spot_angle_deg: float = 45.0
    spot_blend: float = 0.15


@dataclass(frozen=True, kw_only=True)
class World:
    """``WORLD colour r g b [strength s]``, ``WORLD sky [strength s] [elevation e] [azimuth a]
    [aerosol a]`` or ``WORLD hdri NAME|FILE [strength s] [rotation deg]``.

    sky: ``aerosol`` is the sky model's aerosol density (Blender's ``aerosol_density``: 0 none,
    1 a city's clear day, more is hazier: a dimmer sun, a brighter, whiter sky, softer shadows).

    hdri: ``hdri`` is a built-in name (``blender_sesgen.scene.lighting.BUILTIN_HDRIS``) or
    None with ``hdri_path`` an absolute file path (``hdri_source`` as written);
    ``rotation_deg`` turns the image about the vertical (SES +Y) axis.
    """
    kind: Literal["colour", "sky", "hdri"]
    colour: Vec3 = (0.05, 0.05, 0.05)
    strength: float = 1.0
    sun_elevation_deg: float = 45.0
    sun_azimuth_deg: float = 0.0
    aerosol: float = 1.0
    hdri: Optional[str] = None
    hdri_path: Optional[str] = None
    hdri_source: Optional[str] = None
    rotation_deg: float = 0.0


@dataclass(frozen=True, kw_only=True)
class Fog:
    """Distance fog on the RGB output only (ground truth never fogged)."""
    start: float
    end: float
    colour: Vec3 = (0.7, 0.7, 0.7)


@dataclass(frozen=True, kw_only=True)
class Noise:
    """Additive Gaussian noise (8-bit grey levels) for exported RGB; EXR stays clean."""
    sigma: float
    seed: int = 0


@dataclass(frozen=True, kw_only=True)
class Look:
    """``LOOK [view agx|filmic|standard] [look NAME] [exposure auto|EV]``: how the
    display-referred image is made. ``look``: AgX's contrast looks (lighting_data.AGX_LOOKS);
    ``auto_exposure`` None = the default rule (automatic for a script without emitting
    LIGHTs, else ``exposure_ev`` 0); the EXR stays scene-linear either way."""
    view: Literal["agx", "filmic", "standard"] = "agx"
    look: str = "base"
    auto_exposure: Optional[bool] = None
    exposure_ev: float = 0.0


@dataclass(frozen=True, kw_only=True)
class RenderSettings:
    """``RENDER [quality Q] [samples N] [denoise on|off] [seed n]``; CLI flags override.
    ``None``: not given (the quality preset decides, see ``presets.effective``)."""
    quality: Optional[str] = None
    samples: Optional[int] = None
    denoise: Optional[bool] = None
    seed: int = 0


# --- the camera and IMU as sensors (all optional; absent = off) ---------------------------

@dataclass(frozen=True, kw_only=True)
class Timing:
    """``TIMING rate HZ [start S] [exposure S] [readout S] [blur on|off] [still on|off]``.

    Frame k is stamped at the middle of its exposure, ``start_s + k / rate_hz``. ``exposure_s``
    0 = instantaneous (no motion blur); ``readout_s`` 0 = global shutter, else rows are read
    top to bottom over that time (rolling shutter)."""
    rate_hz: float = DEFAULT_FPS
    start_s: float = 0.0
    exposure_s: float = 0.0
    readout_s: float = 0.0
    blur: bool = True          # motion blur over the exposure (when exposure_s > 0)
    still: bool = True         # a still camera's frames hold the path tracer's noise (render/sensor/still.py)

    @property
    def motion_blur(self) -> bool:
        return self.blur and self.exposure_s > 0.0

    @property
    def rolling_shutter(self) -> bool:
        return self.readout_s > 0.0


@dataclass(frozen=True, kw_only=True)
class Lens:
    """``LENS [brown k1 k2 p1 p2 [k3] | fisheye k1 k2 k3 k4] [fnumber N] [defocus px]
    [vignetting v] [chromatic px]``: distortion (geometric, rendered) and optics (applied to
    the sensor images only; ``fnumber`` 0 = no diffraction)."""
    model: Literal["pinhole", "brown", "kannala_brandt"] = "pinhole"
    coeffs: tuple[float, ...] = ()
    f_number: float = 0.0          # 0: no diffraction blur
    defocus_px: float = 0.0        # diameter of the defocus blur disc (pixels)
    vignetting: float = 0.0        # 1 = the natural cos^4 law; 0 = none
    chromatic_px: float = 0.0      # lateral chromatic aberration at the image corner (pixels)

    @property
    def distorted(self) -> bool:
        return self.model == "kannala_brandt" or (self.model == "brown" and any(self.coeffs))

    @property
    def optics(self) -> bool:
        return bool(self.f_number or self.defocus_px or self.vignetting or self.chromatic_px)


@dataclass(frozen=True, kw_only=True)
class Sensor:
    """``SENSOR ...``: the raw image sensor (images written beside the EXRs; EXR and ground
    truth stay clean). Electrons = full_well * L / saturation * (exposure / nominal exposure)."""
    full_well_e: float = 10000.0
    read_noise_e: float = 0.0
    dark_current_e_s: float = 0.0
    prnu: float = 0.0              # pixel response non-uniformity (fraction, std)
    dsnu_e: float = 0.0            # dark signal non-uniformity (electrons, std)
    row_noise_e: float = 0.0       # per-row temporal offset (electrons, std)
    cfa: Optional[Literal["rggb", "bggr", "grbg", "gbrg"]] = None   # None: a colour sensor without mosaic
    mono: bool = False             # a greyscale sensor: one channel, the Rec. 709 luminance
    bits: int = 8
    gain: float = 1.0              # analog gain at the nominal exposure
    black_level_dn: float = 0.0
    saturation: float = 1.0        # linear render value that fills the full well at the nominal exposure
    response: Literal["linear", "srgb", "gamma"] = "srgb"
    gamma: float = 2.2
    pixel_um: float = 3.0          # pixel pitch (diffraction MTF)
    fill_factor: float = 1.0       # pixel aperture (fraction of the pitch)
    olpf_px: float = 0.0           # optical low-pass filter spot separation (pixels)
    jpeg_quality: int = 0          # 0: no JPEG
    seed: int = 0
    profile: Optional[str] = None  # the camera profile the defaults came from (sensor/profiles.py)
    native_width_px: int = 0       # the values are per pixel of a sensor this wide (0: per render pixel)
    nir_share: float = 0.0         # share of a spectrally flat surface's signal from 700-1000 nm (0: IR-cut
                                   # filter); > 0 renders library materials in the sensor's band


@dataclass(frozen=True, kw_only=True)
class AutoExposure:
    """``AUTOEXPOSURE [target T] [speed S] [max_exposure S] [max_gain G] [min_exposure S]
    [start converged|nominal]``: exposure control with one frame of latency; ``speed`` in 1/s
    (the fraction of the log-exposure error corrected over dt is 1 - exp(-speed dt)); ``start``:
    frame 0 at the controller's steady state for what frame 0 sees (``converged``, a camera
    that ran before the sequence began) or at the nominal TIMING exposure and SENSOR gain."""
    target: float = 0.18           # mean normalised signal (0..1 of full scale) to aim for
    speed: float = 3.0
    max_exposure_s: float = 0.0    # 0: the frame period minus the readout
    max_gain: float = 8.0
    min_exposure_s: float = 1e-5
    start: str = "converged"       # "converged" | "nominal": frame 0's exposure


@dataclass(frozen=True, kw_only=True)
class Imu:
    """``IMU ...``: accelerometer + gyroscope on the rig (see blender_sesgen.render.sensor.imu)."""
    rate_hz: float = 200.0
    gyro_noise: float = 1.6968e-04      # rad/s/sqrt(Hz)        (EuRoC ADIS16448)
    gyro_walk: float = 1.9393e-05       # rad/s^2/sqrt(Hz)
    accel_noise: float = 2.0e-3         # m/s^2/sqrt(Hz)
    accel_walk: float = 3.0e-3          # m/s^3/sqrt(Hz)
    position: Vec3 = (0.0, 0.0, 0.0)    # IMU origin in the left camera frame (OpenCV axes)
    rotation_deg: Vec3 = (0.0, 0.0, 0.0)  # XYZ Euler angles of R_cam_imu
    time_offset_s: float = 0.0          # IMU stamp = camera time + offset (Kalibr's timeshift_cam_imu)
    gravity: float = 9.81
    seed: int = 0

    def T_cam_imu(self) -> np.ndarray:
        from ..contract.frames import object_pose
        return object_pose(self.position, self.rotation_deg)


# --- rig and motion ---------------------------------------------------------------------

@dataclass(frozen=True, kw_only=True)
class Rig:
    """``CAMERA``: pinhole intrinsics (pixels, OpenCV convention) and stereo baseline."""
    width: int = 640
    height: int = 480
    focal_px: float = 389.0
    cx: float = 319.5
    cy: float = 239.5
    baseline: float = 0.12  # 0 = monocular
    near: float = 0.05
    far: float = 1000.0

    @property
    def stereo(self) -> bool:
        return self.baseline > 0.0

    @property
    def views(self) -> tuple[str, ...]:
        return ("left", "right") if self.stereo else ("left",)

    def K(self) -> np.ndarray:
        return K_matrix(self.focal_px, self.cx, self.cy)


@dataclass(frozen=True, kw_only=True)
class Motion:
    """How the rig moves, as written: ``kind`` 'static' (no motion lines), 'ego', 'pose'
    or 'trajectory'. ``ego``: one (U, V, W, alpha, beta, gamma) per EGO line;
    ``keyframes``: one (x, y, z, rx, ry, rz) per POSE line; ``trajectory_*``: the
    TRAJECTORY file (absolute path, format), replayed relative to START."""
    kind: Literal["static", "ego", "pose", "trajectory"] = "static"
    ego: tuple[tuple[float, float, float, float, float, float], ...] = ()
    keyframes: tuple[tuple[float, float, float, float, float, float], ...] = ()
    trajectory_path: Optional[str] = None
    trajectory_format: Optional[Literal["tum", "kitti"]] = None


@dataclass(frozen=True, kw_only=True)
class Timeline:
    """The per-frame poses of the left (reference) camera: ``T_world_left[k]`` is the 4x4
    pose (SES world, OpenCV camera) at frame k; frame count = len(T_world_left)."""
    T_world_left: tuple[Mat4, ...]

    @property
    def frames(self) -> int:
        return len(self.T_world_left)

    def left(self) -> np.ndarray:
        """(N, 4, 4) left-camera poses."""
        return np.array(self.T_world_left, dtype=float)

    def right(self, baseline: float) -> np.ndarray:
        """(N, 4, 4) right-camera poses: T_world_left @ trans(B, 0, 0)."""
        return right_from_left(self.left(), baseline)

    def ego_table(self) -> np.ndarray:
        """(N-1, 6) per-step (U, V, W, alpha, beta, gamma), deg, recovered from the poses."""
        return ego_table(self.left())


@dataclass(frozen=True, kw_only=True)
class ObjectMotion:
    """How one object moves (its ``MOVE`` statements, as written) and the per-frame poses
    they give (blender_sesgen.scene.dynamics). ``kind``:

    - 'keys': ``keys`` = one (frame, x, y, z, rx, ry, rz) per keyframe, frames increasing
      (frame 0 is the object's own position);
    - 'twist': ``twists`` = one (first, last, U, V, W, alpha, beta, gamma) per segment;
    - 'trajectory': ``trajectory_path`` (absolute), ``trajectory_format``, ``trajectory_first``.

    ``T_world_obj[k]`` is the object frame's pose in the SES world at frame k (one per frame
    of the sequence).
    """
    id: int
    kind: Literal["keys", "twist", "trajectory"]
    keys: tuple[tuple[float, ...], ...] = ()
    twists: tuple[tuple[float, ...], ...] = ()
    trajectory_path: Optional[str] = None
    trajectory_format: Optional[Literal["tum", "kitti"]] = None
    trajectory_first: int = 0
    T_world_obj: tuple[Mat4, ...] = ()

    def poses(self) -> np.ndarray:
        """(N, 4, 4) T_world_obj per frame."""
        return np.array(self.T_world_obj, dtype=float)


# --- the scene --------------------------------------------------------------------------

@dataclass(frozen=True, kw_only=True)
class Scene:
    source: str                           # the script's path as given ("<string>" if none)
    objects: tuple[SceneObject, ...]
    imports: tuple[BlendImport, ...] = ()  # BLEND statements
    rig: Rig = field(default_factory=Rig)
    start_position: Vec3 = (0.0, 0.0, 0.0)
    start_rotation_deg: Vec3 = (0.0, 0.0, 0.0)
    motion: Motion = field(default_factory=Motion)
    timeline: Timeline = field(default_factory=lambda: Timeline(T_world_left=()))
    materials: tuple[Material, ...] = ()
    lights: tuple[Light, ...] = ()        # empty: the renderer adds the default lighting
    world: Optional[World] = None         # None: the renderer's default world
    fog: Optional[Fog] = None
    noise: Optional[Noise] = None
    look: Look = field(default_factory=Look)
    render: RenderSettings = field(default_factory=RenderSettings)
    object_motions: tuple[ObjectMotion, ...] = ()  # one per moving object (MOVE), by id
    timing: Optional[Timing] = None       # None: 25 Hz, instantaneous global shutter
    lens: Optional[Lens] = None
    sensor: Optional[Sensor] = None
    autoexposure: Optional[AutoExposure] = None
    imu: Optional[Imu] = None

    @property
    def frames(self) -> int:
        return self.timeline.frames

    def motion_of(self, obj_id: int) -> Optional[ObjectMotion]:
        """The ObjectMotion of object ``obj_id``, or None if it does not move."""
        for m in self.object_motions:
            if m.id == obj_id:
                return m
        return None

    @property
    def moving_ids(self) -> tuple[int, ...]:
        return tuple(m.id for m in self.object_motions)

    def material(self, name: str) -> Material:
        for m in self.materials:
            if m.name == name:
                return m
        raise KeyError(name)

    def to_json(self) -> dict:
        """A plain, JSON-serialisable dict (objects carry their ``shape``; no ``line``)."""
        return _jsonable(self)


SENSOR_FIELDS = ("timing", "lens", "sensor", "autoexposure", "imu")


def _jsonable(value):
    if dataclasses.is_dataclass(value):
        out = {}
        if isinstance(value, SceneObject):
            out["shape"] = value.shape
        for f in dataclasses.fields(value):
            if f.name == "line" or (f.name == "imports" and not value.imports):
                continue
            if isinstance(value, Scene) and f.name in SENSOR_FIELDS and getattr(value, f.name) is None:
                continue  # sensor statements absent: the JSON of a SESGen script is unchanged
            out[f.name] = _jsonable(getattr(value, f.name))
        return out
    if isinstance(value, (tuple, list)):
        return [_jsonable(v) for v in value]
    if isinstance(value, float) and value == 0.0:
        return 0.0  # no "-0.0" in golden files
    return value
