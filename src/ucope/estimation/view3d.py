"""A 3D viewer of estimates in the browser (the ``view`` extra: ``pip install "ucope[view]"``, viser).

Each :class:`~ucope.estimation.draw_scene.Scene` (one frame or one cloud) shows its clouds coloured by
predicted part, every part's box (translucent faces in the part colour and thick edges a shade darker,
so that a box stands out of its own points; faded for a part scoring below
:data:`~ucope.estimation.draw_scene.LOW_SCORE`; the ground truth's grey), its frame's axis triad (x red,
y green, z blue), its joint axes (black, labelled with type and state) and a label with the object's
name (several objects), the part's name and score; several scenes are laid side by side along x. The
side panel lists the parts with their scores (and errors when known); the standalone HTML carries the
same list as a legend over the view. The view opens looking along the camera's line of sight at the
first scene, from where its objects fill most of the view.

* :func:`show`: a live viewer at ``http://HOST:PORT`` (``ucope predict ... --view``), until Ctrl-C
  (:func:`check_address` checks the address first);
* :func:`write_html`: the same scene as one self-contained HTML file that opens in any browser
  without Python or a network (``--view-html FILE``);
* :func:`build_scene`: add the scenes to a viser server of your own.

Coordinates are the camera frame (OpenCV: x right, y down, z forward), metres; the viewer's up is -y
and it opens looking along the camera's line of sight towards the first scene, from closer by.

viser (not rerun) fits a CPU-first library used over SSH: a small dependency, a browser page (no native
window), and a standalone HTML export that opens in any browser.
"""

from __future__ import annotations

import contextlib
import io
import os
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..fileio import atomic_write_text
from ..geometry.boxes import BOX_EDGES, box_corners
from .draw_scene import AXIS_COLOURS, LOW_SCORE, DrawnObject, Scene, legend_lines, part_colours, warning_lines

__all__ = ["viser_module", "build_scene", "show", "write_html", "legend_html", "check_address"]

VIEW_FOV_DEG = 50.0
"""Vertical field of view of the opening camera."""

VIEW_FILL = 0.8
"""Share of the opening view's height that the first scene's objects span."""


def viser_module():
    """The ``viser`` module, or :class:`InputError` naming the extra to install."""
    try:
        import viser
    except ImportError:
        raise InputError('the 3D viewer needs viser: pip install "ucope[view]"') from None
    return viser


def _rgb(hex_colour: str) -> tuple[int, int, int]:
    h = hex_colour.lstrip("#")
    return int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16)


def _shade(rgb, k: float) -> tuple[int, int, int]:
    """``rgb`` darkened (``k < 1``) or blended towards white (``k > 1``: ``k - 1`` of the way)."""
    c = np.asarray(rgb, np.float64)
    c = c * k if k <= 1 else c + (255.0 - c) * min(k - 1.0, 1.0)
    return tuple(int(v) for v in np.clip(np.round(c), 0, 255))


def _wxyz(R: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(np.asarray(R, np.float64)).as_quat()
    return np.array([w, x, y, z])


def _extent(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    pts = [box_corners(o.result.cam_from_part, o.result.size_m).reshape(-1, 3) for o in scene.objects]
    pts += [np.asarray(o.points, np.float64).reshape(-1, 3) for o in scene.objects if o.points is not None]
    p = np.concatenate(pts)
    p = p[np.isfinite(p).all(axis=1)]
    return p.min(axis=0), p.max(axis=0)


def build_scene(server, scenes: Sequence[Scene], max_points: int = 20000) -> list[str]:
    """Add ``scenes`` to a viser server (see the module docstring); returns the names of the nodes added.

    Raises :class:`InputError` for no scenes or a scene without objects."""
    if not scenes:
        raise InputError("nothing to show")
    names: list[str] = []
    sc = server.scene
    sc.set_up_direction("-y")
    offset = 0.0
    lo0, hi0 = _extent(scenes[0])
    notes = []
    for i, scene in enumerate(scenes):
        if not scene.objects:
            raise InputError(f"scene {scene.title!r} has no objects to show")
        lo, hi = _extent(scene)
        shift = np.array([offset - lo[0] if i else 0.0, 0.0, 0.0])
        offset = (hi + shift)[0] + 0.25 * float(np.max(hi - lo))
        root = f"/scene_{i}"
        sc.add_frame(root, show_axes=False, position=shift)
        names.append(root)
        if scene.title:
            sc.add_label(f"{root}/title", scene.title, position=np.array([lo[0], lo[1], lo[2]]), anchor="bottom-left")
            names.append(f"{root}/title")
        diag = float(np.linalg.norm(hi - lo))
        for j, (obj, cols) in enumerate(zip(scene.objects, part_colours(scene.objects), strict=False)):
            part_text, joint_text = legend_lines(obj)
            names += _add_object(sc, f"{root}/object_{j}", obj, cols, diag, max_points, joint_text)
            notes += [f"- **{scene.title or f'scene {i}'}**: " + t for t in part_text + joint_text]
        notes += [f"- **{scene.title or f'scene {i}'}**: {w}" for w in warning_lines(scene)]
    server.gui.add_markdown(
        "**ucope estimates** (camera frame, metres; boxes in part colours, ground truth grey; "
        "axes x red, y green, z blue; joint axes black)\n\n" + "\n".join(notes)
    )
    eye, centre = _opening_view(lo0, hi0)
    server.initial_camera.fov = float(np.radians(VIEW_FOV_DEG))
    server.initial_camera.position = tuple(float(v) for v in eye)
    server.initial_camera.look_at = tuple(float(v) for v in centre)
    server.initial_camera.up = (0.0, -1.0, 0.0)
    return names


def _add_object(sc, base: str, obj: DrawnObject, cols: Sequence[str], diag: float, max_points: int, joint_text) -> list[str]:
    """Add one object under ``base``: its cloud, boxes, triads, labels, joint axes (``joint_text``: their
    legend lines) and ground-truth boxes; ``diag``: the scene's diagonal (metres). Returns the node names."""
    names: list[str] = []
    r = obj.result
    if obj.points is not None:
        names.append(_add_points(sc, f"{base}/points", obj, cols, diag, max_points))
    names += _add_parts(sc, base, obj, cols)
    for q, jt in enumerate(r.joints):
        piv = np.asarray(jt.pivot_m if jt.pivot_m is not None else r.parts[jt.child].cam_from_part[:3, 3], np.float64)
        u = np.asarray(jt.axis, np.float64) / (np.linalg.norm(jt.axis) + 1e-12)
        ends = np.stack([piv - 0.3 * diag * u, piv + 0.3 * diag * u])
        sc.add_line_segments(
            f"{base}/joint_{q}", ends[None].astype(np.float32), (20, 20, 20), thickness=4.0, thickness_units="screen"
        )
        sc.add_label(
            f"{base}/joint_label_{q}", joint_text[q].split("  |")[0].split(": ")[-1], position=ends[1], anchor="top-left"
        )
        names += [f"{base}/joint_{q}", f"{base}/joint_label_{q}"]
    if obj.sample is not None:
        g = box_corners(np.asarray(obj.sample["cam_from_part"], np.float64), np.asarray(obj.sample["size_m"], np.float64))
        gseg = g[:, BOX_EDGES].reshape(-1, 2, 3)
        sc.add_line_segments(
            f"{base}/gt_boxes", gseg.astype(np.float32), (128, 128, 128), thickness=1.5, thickness_units="screen"
        )
        names.append(f"{base}/gt_boxes")
    return names


def _add_points(sc, name: str, obj: DrawnObject, cols: Sequence[str], diag: float, max_points: int) -> str:
    """Add an object's finite points on a part (at most ``max_points``, evenly spread) in part colours."""
    pts = np.asarray(obj.points, np.float64).reshape(-1, 3)
    labels = np.asarray(obj.result.part_labels)
    if len(labels) != len(pts):
        labels = np.zeros(len(pts), np.int64)
    ok = (labels >= 0) & np.isfinite(pts).all(axis=1)
    pts, labels = pts[ok], labels[ok]
    if len(pts) > max_points:
        sel = np.linspace(0, len(pts) - 1, max_points).astype(np.int64)
        pts, labels = pts[sel], labels[sel]
    palette = np.array([_rgb(c) for c in cols], np.uint8)
    sc.add_point_cloud(
        name,
        pts.astype(np.float32),
        palette[np.clip(labels, 0, len(cols) - 1)],
        point_size=max(0.001, 0.004 * diag),
        point_shape="circle",
        precision="float32",
    )
    return name


def _add_parts(sc, base: str, obj: DrawnObject, cols: Sequence[str]) -> list[str]:
    """Add every part's box (edges a shade darker than its points, faded towards white for a low score;
    translucent faces), its frame's triad and its label; returns the node names."""
    r = obj.result
    corners = box_corners(r.cam_from_part, r.size_m)  # (K, 8, 3)
    low = [not obj.truth and float(p.score) < LOW_SCORE for p in r.parts]
    edge = np.array([_shade(_rgb(c), 1.6 if lo else 0.6) for c, lo in zip(cols, low, strict=True)], np.uint8)
    seg = corners[:, BOX_EDGES].reshape(-1, 2, 3)
    seg_col = np.repeat(edge, len(BOX_EDGES), axis=0)
    sc.add_line_segments(
        f"{base}/boxes",
        seg.astype(np.float32),
        np.repeat(seg_col[:, None], 2, axis=1),
        thickness=5.0,
        thickness_units="screen",
    )
    names = [f"{base}/boxes"]
    for k, p in enumerate(r.parts):
        T = np.asarray(p.cam_from_part, np.float64)
        sc.add_box(
            f"{base}/box_{k}",
            color=_rgb(cols[k]),
            dimensions=tuple(float(v) for v in np.maximum(np.asarray(p.size_m, np.float64), 1e-4)),
            opacity=0.08 if low[k] else 0.18,
            side="double",
            cast_shadow=False,
            receive_shadow=False,
            wxyz=_wxyz(T[:3, :3]),
            position=T[:3, 3],
        )
        L = 0.3 * float(np.max(p.size_m))
        sc.add_frame(f"{base}/part_{k}", axes_length=L, axes_radius=0.04 * L, wxyz=_wxyz(T[:3, :3]), position=T[:3, 3])
        top = corners[k][np.argmin(corners[k][:, 1])]  # the corner highest in the picture (-y is up)
        text = p.label if obj.truth else f"{p.label} {p.score:.2f}" + (" (low)" if low[k] else "")
        if obj.name:
            text = f"{obj.name}: {text}"
        sc.add_label(f"{base}/label_{k}", text, position=top, anchor="bottom-center")
        names += [f"{base}/box_{k}", f"{base}/part_{k}", f"{base}/label_{k}"]
    return names


def _opening_view(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(eye, centre)``: look at the box ``[lo, hi]`` (camera frame) along the camera's line of sight to
    its centre, from the distance at which its diagonal spans :data:`VIEW_FILL` of a
    :data:`VIEW_FOV_DEG` view's height."""
    centre = 0.5 * (np.asarray(lo, np.float64) + np.asarray(hi, np.float64))
    diag = max(float(np.linalg.norm(np.asarray(hi) - np.asarray(lo))), 1e-3)
    dist = 0.5 * diag / np.tan(0.5 * np.radians(VIEW_FOV_DEG)) / VIEW_FILL
    ray = centre / np.linalg.norm(centre) if np.linalg.norm(centre) > 1e-6 else np.array([0.0, 0.0, 1.0])
    return centre - dist * ray, centre


def legend_html(scenes: Sequence[Scene]) -> str:
    """An HTML ``<div>`` legend of the scenes (part colours with names and scores, joints, warnings, the
    triad colours), fixed over the top-left corner of the page; :func:`write_html` adds it to the file."""
    import html

    rows = []
    for i, scene in enumerate(scenes):
        title = html.escape(scene.title or f"scene {i}")
        rows.append(f'<div style="font-weight:600;margin-top:4px">{title}</div>')
        for obj, cols in zip(scene.objects, part_colours(scene.objects), strict=False):
            part_text, joint_text = legend_lines(obj)
            for c, t in zip(cols, part_text, strict=False):
                rows.append(
                    f'<div><span style="display:inline-block;width:12px;height:12px;background:{c};'
                    f'margin-right:6px;vertical-align:middle;border:1px solid #333"></span>{html.escape(t)}</div>'
                )
            rows += [f'<div><span style="margin-right:6px">&#8594;</span>{html.escape(t)}</div>' for t in joint_text]
        rows += [f'<div style="color:#b00020">{html.escape(w)}</div>' for w in warning_lines(scene)]
    triad = " ".join(f'<span style="color:{c};font-weight:700">{a}</span>' for c, a in zip(AXIS_COLOURS, "xyz", strict=False))
    rows.append(f"<div>part frame axes: {triad}; joint axes black; ground truth grey; faded: score &lt; {LOW_SCORE}</div>")
    return (
        '<div id="ucope-legend" style="position:fixed;left:12px;bottom:12px;z-index:1000;max-width:42%;max-height:45%;'
        "overflow:auto;background:rgba(255,255,255,0.88);border:1px solid #999;border-radius:6px;padding:6px 10px;"
        'font:12px/1.35 system-ui,sans-serif;color:#111">' + "".join(rows) + "</div>"
    )


def check_address(host: str, port: int, names: tuple[str, str] = ("host", "port")) -> list[str]:
    """Check that a viewer can listen on ``host:port``, before any server thread starts (a server thread
    that fails cannot report it, and viser retries an address it cannot bind forever).

    ``names`` name the two in the messages (the CLI passes ``("--view-host", "--view-port")``).

    Returns warnings: the address reaches beyond this machine (the viewer has no authentication), or the
    port is taken (viser then serves on the next free one, and says which).

    Raises :class:`InputError`: a port that is not an integer in 0-65535; a host that does not resolve,
    or that is no address of this machine."""
    import ipaddress
    import socket

    if isinstance(port, bool) or not isinstance(port, int | np.integer) or not 0 <= int(port) <= 65535:
        raise InputError(f"{names[1]} must be an integer from 0 to 65535 (0: any free port), got {port!r}")
    if not isinstance(host, str):
        raise InputError(f"{names[0]} must be a host name or an IP address, got {host!r}")
    try:
        infos = socket.getaddrinfo(host or None, 0, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except (OSError, UnicodeError) as e:
        raise InputError(f"{names[0]} {host!r} does not resolve to an address ({e})") from None
    addrs = list(dict.fromkeys((family, sockaddr) for family, _, _, _, sockaddr in infos))
    bindable, taken = [], None
    for family, sockaddr in addrs:
        for p in (0, int(port)) if port else (0,):
            with socket.socket(family, socket.SOCK_STREAM) as sock:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server will
                try:
                    sock.bind((sockaddr[0], p, *sockaddr[2:]))
                except OSError as e:
                    if p != 0:
                        taken = taken or e.strerror or str(e)
                    continue
            if p == 0:
                bindable.append(sockaddr[0])
    if not bindable:
        raise InputError(
            f"{names[0]} {host!r} ({', '.join(a[1][0] for a in addrs)}) is no address of this machine: the viewer cannot listen "
            "on it (127.0.0.1: this machine only; 0.0.0.0: every network interface)"
        )
    notes = []
    if taken:
        notes.append(f"port {port} cannot be used on {host} ({taken}): the viewer serves on the next free port")
    if not all(ipaddress.ip_address(a.split("%")[0]).is_loopback for a in bindable):
        notes.append(
            f"the viewer at {host}:{port} is open to every machine that can reach this one, without authentication "
            "(use 127.0.0.1 and an SSH tunnel to keep it private)"
        )
    return notes


def _server(host: str, port: int, quiet: bool):
    viser = viser_module()
    if quiet:
        with contextlib.redirect_stdout(io.StringIO()):
            return viser.ViserServer(host=host, port=port, verbose=False)
    return viser.ViserServer(host=host, port=port)


def show(scenes: Sequence[Scene], host: str = "127.0.0.1", port: int = 8080, block: bool = True):
    """Serve the scenes at ``http://host:port`` (viser) and, with ``block``, wait until Ctrl-C.

    Returns the viser server (call ``.stop()`` on it when ``block=False``). ``port=0`` takes a free one
    (``server.get_port()``). The address is checked first (:func:`check_address`: a bad port or host
    raises :class:`InputError`; its warnings are printed to stderr)."""
    for note in check_address(host, port):
        print(f"warning: {note}", file=sys.stderr, flush=True)
    server = _server(host, port, quiet=False)
    try:
        build_scene(server, scenes)
    except BaseException:
        server.stop()
        raise
    if block:
        print(f"3D viewer at http://{host}:{server.get_port()} (Ctrl-C to stop)", flush=True)
        try:
            server.sleep_forever()
        except KeyboardInterrupt:
            pass
        finally:
            server.stop()
    return server


def write_html(scenes: Sequence[Scene], path: str | os.PathLike, dark_mode: bool = False) -> Path:
    """Write the scenes as one self-contained HTML file (the viewer and the scene inside, about 1 MB
    plus the clouds, with :func:`legend_html` over the view), atomically; it opens offline in any
    browser with WebGL."""
    server = _server("127.0.0.1", 0, quiet=True)
    try:
        build_scene(server, scenes)
        with contextlib.redirect_stdout(io.StringIO()):
            html = server.get_scene_serializer().as_html(dark_mode=dark_mode)
    finally:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            server.stop()
    legend = legend_html(scenes)
    at = html.rfind("</body>")
    html = html[:at] + legend + html[at:] if at >= 0 else html + legend
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, html)
    return path
