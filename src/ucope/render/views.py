"""Sampling camera views around an object and rendering them.

World frame = the object frame (y up, the object resting on a floor at its lowest point). A view is a
joint state plus a camera placed at ``(yaw, elevation, distance)`` around the object's box centre,
looking at it with a random look-at offset and a small roll.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from ..geometry.transforms import (
    apply_transform,
    invert_transform,
    look_at_rotation,
    make_transform,
    rotation_about_axis,
    transform_directions,
)
from ..objects.articulation import ArticulatedObject
from ..objects.shapes import box, combine, cylinder
from .camera import DEFAULT_CAMERA, PinholeCamera
from .noise import DepthNoise, apply_depth_noise, depth_to_mm
from .raycast import BACKGROUND_LABEL, CLUTTER_LABEL, raycast_depth

__all__ = ["ViewConfig", "RenderedView", "sample_view", "render_view"]


@dataclass(frozen=True)
class ViewConfig:
    """How views are sampled and rendered.

    Attributes:
        camera: intrinsics and image size.
        distance_range_m, elevation_range_deg: camera placement; ``None`` = the category's defaults.
        yaw_range_deg: camera azimuth around the object's y axis (full circle by default).
        lookat_jitter: std of the look-at offset, as a fraction of the object's box diagonal.
        roll_deg: std of the camera roll about its viewing axis.
        noise: depth sensor model (``DepthNoise(enabled=False)`` for clean depth).
        floor: render a floor plane under the object.
        num_distractors: maximum number of distractor objects (boxes, cylinders) on the floor.
    """

    camera: PinholeCamera = DEFAULT_CAMERA
    distance_range_m: tuple[float, float] | None = None
    elevation_range_deg: tuple[float, float] | None = None
    yaw_range_deg: tuple[float, float] = (0.0, 360.0)
    lookat_jitter: float = 0.05
    roll_deg: float = 3.0
    noise: DepthNoise = field(default_factory=DepthNoise)
    floor: bool = True
    num_distractors: int = 2

    def to_dict(self) -> dict:
        d = asdict(self)
        d["camera"] = self.camera.to_dict()
        d["noise"] = self.noise.to_dict()
        return d

    @classmethod
    def from_dict(cls, d: dict) -> ViewConfig:
        d = dict(d)
        d["camera"] = PinholeCamera.from_dict(d["camera"])
        d["noise"] = DepthNoise(**d["noise"])
        for k in ("distance_range_m", "elevation_range_deg", "yaw_range_deg"):
            if d.get(k) is not None:
                d[k] = tuple(d[k])
        return cls(**d)


@dataclass
class RenderedView:
    """One rendered view of an object.

    Attributes:
        depth_mm: ``(H, W)`` uint16 sensor depth in millimetres (0 = no return).
        mask: ``(H, W)`` uint8: part index ``0..K-1``, :data:`CLUTTER_LABEL` (distractors) or
            :data:`BACKGROUND_LABEL` (floor / nothing).
        cam_from_object: ``(4, 4)``.
        cam_from_part: ``(K, 4, 4)`` every part's pose.
        joint_state: ``(K-1,)`` radians / metres.
        joint_pivot, joint_axis: ``(K-1, 3)`` in the camera frame.
    """

    depth_mm: np.ndarray
    mask: np.ndarray
    cam_from_object: np.ndarray
    cam_from_part: np.ndarray
    joint_state: np.ndarray
    joint_pivot: np.ndarray
    joint_axis: np.ndarray


def sample_view(obj: ArticulatedObject, cfg: ViewConfig, rng: np.random.Generator, spec=None) -> tuple[np.ndarray, np.ndarray]:
    """Draw a joint state and a camera pose: returns ``(joint_state (K-1,), cam_from_object (4, 4))``.

    ``spec`` (a :class:`~ucope.objects.categories.CategorySpec`) supplies default ranges.
    """
    lim = obj.limits
    state = rng.uniform(lim[:, 0], lim[:, 1]) if len(lim) else np.zeros(0)
    dist_rng = cfg.distance_range_m or (spec.distance_range_m if spec is not None else (0.5, 1.5))
    elev_rng = cfg.elevation_range_deg or (spec.elevation_range_deg if spec is not None else (10.0, 60.0))
    yaw = np.radians(rng.uniform(*cfg.yaw_range_deg))
    elev = np.radians(rng.uniform(*elev_rng))
    dist = rng.uniform(*dist_rng)
    lo, hi = obj.bounds(state)
    centre = 0.5 * (lo + hi)
    diag = float(np.linalg.norm(hi - lo))
    target = centre + rng.normal(0.0, cfg.lookat_jitter * diag, 3)
    eye = centre + dist * np.array([np.cos(elev) * np.sin(yaw), np.sin(elev), np.cos(elev) * np.cos(yaw)])
    R = look_at_rotation(eye, target, up=(0.0, 1.0, 0.0))
    R = R @ rotation_about_axis(np.array([0.0, 0.0, 1.0]), np.radians(rng.normal(0.0, cfg.roll_deg)))
    return state, invert_transform(make_transform(R, eye))


def _distractors(rng: np.random.Generator, n: int, floor_y: float, centre: np.ndarray, radius: float):
    meshes = []
    for _ in range(n):
        ang = rng.uniform(0, 2 * np.pi)
        r = radius * rng.uniform(1.2, 2.5)
        size = radius * rng.uniform(0.3, 0.9, 3)
        pos = np.array([centre[0] + r * np.sin(ang), floor_y + size[1] / 2, centre[2] + r * np.cos(ang)])
        if rng.random() < 0.5:
            meshes.append(box(size, pos, rotation_about_axis([0.0, 1.0, 0.0], rng.uniform(0, np.pi))))
        else:
            meshes.append(cylinder(size[0] / 2, size[1], pos, sections=16))
    return meshes


def render_view(
    obj: ArticulatedObject,
    cfg: ViewConfig,
    rng: np.random.Generator,
    spec=None,
    state: np.ndarray | None = None,
    cam_from_object: np.ndarray | None = None,
) -> RenderedView:
    """Sample (unless given) and render one view of ``obj``; all randomness comes from ``rng``."""
    s_state, s_pose = sample_view(obj, cfg, rng, spec)
    state = s_state if state is None else obj.check_state(state)
    cam_from_object = s_pose if cam_from_object is None else np.asarray(cam_from_object, np.float64)

    verts, faces, labels = obj.posed_geometry(state)
    lo, hi = verts.min(0), verts.max(0)
    floor_y = lo[1]
    n_dis = int(rng.integers(0, cfg.num_distractors + 1)) if cfg.num_distractors > 0 else 0
    if n_dis:
        centre = 0.5 * (lo + hi)
        radius = 0.5 * float(np.linalg.norm((hi - lo)[[0, 2]]))
        dm = combine(_distractors(rng, n_dis, floor_y, centre, radius))
        verts = np.concatenate([verts, dm.vertices])
        faces = np.concatenate([faces, np.asarray(dm.faces) + len(verts) - len(dm.vertices)])
        labels = np.concatenate([labels, np.full(len(dm.faces), CLUTTER_LABEL)])
    floor = None
    if cfg.floor:
        floor = (
            apply_transform(cam_from_object, np.array([[0.0, floor_y - 1e-4, 0.0]]))[0],
            transform_directions(cam_from_object, np.array([[0.0, 1.0, 0.0]]))[0],
        )
    depth, mask = raycast_depth(apply_transform(cam_from_object, verts), faces, labels, cfg.camera, floor_cam=floor)
    depth = apply_depth_noise(depth, cfg.noise, rng)
    depth_mm = depth_to_mm(depth)

    cam_from_part = cam_from_object @ obj.object_from_part(state)
    piv, ax = obj.joints_in_object(state)
    return RenderedView(
        depth_mm=depth_mm,
        mask=mask,
        cam_from_object=cam_from_object,
        cam_from_part=cam_from_part,
        joint_state=np.asarray(state, np.float64),
        joint_pivot=apply_transform(cam_from_object, piv) if len(piv) else np.zeros((0, 3)),
        joint_axis=transform_directions(cam_from_object, ax) if len(ax) else np.zeros((0, 3)),
    )


__all__ += ["BACKGROUND_LABEL", "CLUTTER_LABEL"]
