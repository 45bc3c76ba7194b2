"""The inspector's viewport: the two images side by side, blink, swipe, and the 3D scene.

The scene uses image coordinates: x to the right, y down, the camera on the -z side
looking at +z with "up" = -y (viser draws images in OpenCV's camera convention). Each
image is a group holding the picture (JPEG) and, just in front of it, a transparent
overlay (PNG). The longest side of an image is one scene unit.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any

import numpy as np

from inspector import render

__all__ = ["ImagePlacement", "Viewport", "COMPARE_MODES"]

#: How the two images are compared in the viewport.
COMPARE_MODES: tuple[str, ...] = ("side by side", "blink", "swipe", "3D scene")
_GAP = 0.04
_FOV = np.deg2rad(35.0)


@dataclass(frozen=True)
class ImagePlacement:
    """Where one displayed image lies in the scene.

    Attributes
    ----------
    centre : (float, float)
        Scene x, y of the image centre.
    size : (float, float)
        Scene width and height.
    shape : (int, int)
        Pixel ``(height, width)`` of the *work pair* image it shows.
    """

    centre: tuple[float, float]
    size: tuple[float, float]
    shape: tuple[int, int]

    def pixel(self, point: np.ndarray) -> tuple[float, float] | None:
        """Work-pair pixel ``(x, y)`` under scene ``point``, or None when outside."""
        u = (point[0] - (self.centre[0] - self.size[0] / 2)) / self.size[0]
        v = (point[1] - (self.centre[1] - self.size[1] / 2)) / self.size[1]
        if not (0.0 <= u < 1.0 and 0.0 <= v < 1.0):
            return None
        return u * self.shape[1], v * self.shape[0]


class Viewport:
    """Owns the scene nodes of the images, overlays and point cloud.

    Parameters
    ----------
    server : viser.ViserServer

    Attributes
    ----------
    shown : dict
        ``"reference"`` / ``"target"`` -> the grey picture sent last.
    cloud : (ndarray, ndarray) or None
        The points and colours of the 3D point cloud sent last.
    """

    def __init__(self, server: Any) -> None:
        self.server = server
        self._aspects: dict[int, float] = {}
        self.scene = server.scene
        self.scene.set_up_direction("-y")
        self.mode = "side by side"
        self.placements: dict[str, ImagePlacement] = {}
        self._shape: tuple[int, int] | None = None
        self._nodes: dict[str, Any] = {}
        self._builds = 0
        self._cloud: Any = None
        self.cloud: tuple[np.ndarray, np.ndarray] | None = None
        self._lock = threading.RLock()
        self._blink_stop = threading.Event()
        self._blink_thread: threading.Thread | None = None
        self.blink_period = 0.7
        self.blink_showing = "reference"
        self.shown: dict[str, np.ndarray] = {}
        self._sent_layers: dict[str, np.ndarray] = {}
        self.swipe_position = 0.5
        self._display_shape: tuple[int, int] | None = None

    # ------------------------------------------------------------------ layout

    def _layout(self, shape: tuple[int, int]) -> dict[str, ImagePlacement]:
        height, width = shape
        side = max(height, width)
        w, h = width / side, height / side
        if self.mode in ("blink", "swipe"):
            return {name: ImagePlacement((0.0, 0.0), (w, h), shape) for name in ("reference", "target")}
        offset = w / 2 + _GAP / 2
        return {
            "reference": ImagePlacement((-offset, 0.0), (w, h), shape),
            "target": ImagePlacement((offset, 0.0), (w, h), shape),
        }

    def _build(self, display_shape: tuple[int, int], work_shape: tuple[int, int]) -> None:
        """(Re)create the image groups for a new image size or compare mode.

        Each build uses new node names: viser keeps the old position of a node that is
        removed and added again under the same name.
        """
        for node in sorted(self._nodes, key=lambda key: -key.count("/")):
            self._nodes[node].remove()  # children first: browsers keep orphans otherwise
        self._nodes = {}
        self._builds += 1
        self.placements = self._layout(work_shape)
        blank = np.zeros(display_shape, np.uint8)
        clear = np.zeros((*display_shape, 4), np.uint8)
        for name, place in self.placements.items():
            root = f"/{name}_{self._builds}"
            self._nodes[name] = self.scene.add_frame(root, show_axes=False, position=(*place.centre, 0.0))
            self._nodes[f"{name}/image"] = self.scene.add_image(
                f"{root}/image", blank, place.size[0], place.size[1], format="jpeg", jpeg_quality=92,
                cast_shadow=False, receive_shadow=False,
            )
            self._nodes[f"{name}/overlay"] = self.scene.add_image(
                f"{root}/overlay", clear, place.size[0], place.size[1], format="png",
                cast_shadow=False, receive_shadow=False, position=(0.0, 0.0, -0.002),
            )
            self._nodes[f"{name}/title"] = self.scene.add_label(
                f"{root}/title", name, position=(-place.size[0] / 2, -place.size[1] / 2 - 0.012, 0.0),
                anchor="bottom-left", font_screen_scale=0.9,
            )
        self._shape = work_shape
        self._display_shape = display_shape
        self._sent_layers = {}
        self.initial_camera(work_shape)

    def _pose(self, aspect: float) -> tuple[tuple[float, float, float], tuple[float, float, float]] | None:
        """Camera ``(position, up)`` that fits the current layout in a canvas of ``aspect``."""
        if self._shape is None:
            return None
        height, width = self._shape
        side = max(height, width)
        extent_x = (2 * width / side + _GAP) if self.mode == "side by side" else width / side
        extent_y = height / side
        tan_y = np.tan(_FOV / 2)
        distance = 1.06 * max(extent_y / 2 / tan_y, extent_x / 2 / (tan_y * aspect))
        if self.mode == "3D scene":
            return (0.0, 1.1 * distance, -0.75 * distance), (0.0, 0.0, -1.0)
        return (0.0, 0.0, -distance), (0.0, -1.0, 0.0)

    def frame_camera(self, client: Any | None = None) -> None:
        """Point one client's camera (or every client's) at the images or the 3D scene."""
        clients = [client] if client is not None else list(self.server.get_clients().values())
        for handle in clients:
            camera = handle.camera
            aspect = camera.aspect if camera.aspect and np.isfinite(camera.aspect) else 1.3
            pose = self._pose(aspect)
            if pose is None:
                return
            self._aspects[handle.client_id] = aspect
            with handle.atomic():
                camera.fov = float(_FOV)
                camera.up_direction = pose[1]
                camera.position = pose[0]
                camera.look_at = (0.0, 0.0, 0.0)

    def framed(self, client: Any) -> bool:
        """True when the client's camera shows the current layout fitted to its canvas."""
        camera = client.camera
        pose = self._pose(camera.aspect) if camera.aspect else None
        return pose is not None and bool(np.allclose(camera.position, pose[0], atol=1e-4)) and bool(
            np.allclose(camera.look_at, 0.0, atol=1e-4)
        )

    def follow_canvas(self, client: Any) -> None:
        """Frame a new client, and again whenever its canvas changes shape (docked panels
        shrink it just after connecting, and the window may be resized)."""
        self.frame_camera(client)

        def changed(camera: Any) -> None:
            aspect = camera.aspect
            if aspect and abs(aspect - self._aspects.get(client.client_id, aspect)) > 1e-3:
                self.frame_camera(client)

        client.camera.on_update(changed)

    def initial_camera(self, shape: tuple[int, int]) -> None:
        """Set the camera that new clients start with (before their canvas size is known)."""
        height, width = shape
        side = max(height, width)
        distance = 1.08 * max(height / side / 2, (2 * width / side + _GAP) / 2 / 1.3) / np.tan(_FOV / 2)
        camera = self.server.initial_camera
        camera.fov = float(_FOV)
        camera.position = (0.0, 0.0, -distance)
        camera.look_at = (0.0, 0.0, 0.0)
        camera.up = (0.0, -1.0, 0.0)

    # ------------------------------------------------------------------ showing

    def show(
        self,
        reference: np.ndarray,
        target: np.ndarray,
        overlays: tuple[np.ndarray, np.ndarray],
        titles: tuple[str, str],
        work_shape: tuple[int, int],
        swipe: float = 0.5,
    ) -> None:
        """Show two images and their overlays in the current compare mode.

        Parameters
        ----------
        reference, target : ndarray of uint8, shape (h, w)
            Grey display images (possibly downsampled from the work pair), sent as JPEG.
        overlays : (ndarray, ndarray)
            RGBA layers of the same size, sent as PNG unless they are the very arrays
            sent last time.
        titles : (str, str)
            Captions drawn above the images.
        work_shape : (int, int)
            Shape of the work-pair images shown (clicks map to their pixels).
        swipe : float
            Split position (0..1) in swipe mode.
        """
        with self._lock:
            display_shape = reference.shape[:2]
            if self._shape != work_shape or self._display_shape != display_shape:
                self._build(display_shape, work_shape)
                self.frame_camera()
            self.shown = {"reference": reference, "target": target}
            self.swipe_position = swipe
            pictures = {"reference": reference, "target": target}
            if self.mode == "swipe":
                pictures["reference"] = render.swipe_composite(reference, target, swipe)
            with self.server.atomic():
                for name, title in zip(("reference", "target"), titles):
                    self._nodes[f"{name}/image"].image = pictures[name]
                    self._nodes[f"{name}/title"].text = title
                self._send_layers(overlays, swipe)
                self._apply_visibility()

    @property
    def sent_layers(self) -> dict[str, np.ndarray]:
        """``"reference"`` / ``"target"`` -> the RGBA overlay layer sent last."""
        with self._lock:
            return dict(self._sent_layers)

    def show_overlays(self, overlays: tuple[np.ndarray, np.ndarray], swipe: float = 0.5) -> None:
        """Replace only the overlay layers."""
        with self._lock:
            if self._nodes:
                with self.server.atomic():
                    self._send_layers(overlays, swipe)

    def _send_layers(self, overlays: tuple[np.ndarray, np.ndarray], swipe: float) -> None:
        layers = {"reference": overlays[0], "target": overlays[1]}
        if self.mode == "swipe":
            layers["reference"] = render.swipe_composite(overlays[0], overlays[1], swipe, line=False)
        for name, layer in layers.items():
            if self._sent_layers.get(name) is not layer or self.mode == "swipe":
                self._nodes[f"{name}/overlay"].image = layer
                self._sent_layers[name] = layer

    def show_cloud(self, points: np.ndarray, colours: np.ndarray) -> None:
        """Replace the 3D point cloud (shown in the "3D scene" mode).

        ``points`` are ``(x, y, height)`` with x, y in image coordinates (longest side 1,
        y down) as :func:`render.point_cloud` makes them; height goes towards the camera
        (-z here).
        """
        if len(points) == 0:
            return
        spread = np.ptp(points[:, :2], axis=0)
        spacing = float(np.sqrt(max(spread[0] * spread[1], 1e-12) / len(points)))
        with self._lock:
            self.cloud = (points, colours)
            if self._cloud is not None:
                self._cloud.remove()
            self._cloud = self.scene.add_point_cloud(
                "/scene3d", points * np.array([1.0, 1.0, -1.0], np.float32), colours, point_size=1.4 * spacing,
                point_shape="square", point_shading="flat", precision="float32", visible=self.mode == "3D scene",
            )

    def set_mode(self, mode: str) -> None:
        """Switch the compare mode; images are re-laid out on the next :meth:`show`."""
        if mode not in COMPARE_MODES:
            raise ValueError(f"unknown compare mode {mode!r}")
        with self._lock:
            self.mode = mode
            self._shape = None
        self._blink_stop.set()
        if mode == "blink":
            self._blink_stop = threading.Event()
            self._blink_thread = threading.Thread(target=self._blink, args=(self._blink_stop,), name="inspector-blink", daemon=True)
            self._blink_thread.start()

    def _apply_visibility(self) -> None:
        in_3d = self.mode == "3D scene"
        blinking = self.mode == "blink"
        visible = {
            "reference": not in_3d and (not blinking or self.blink_showing == "reference"),
            "target": self.mode == "side by side" or (blinking and self.blink_showing == "target"),
        }
        for key, node in self._nodes.items():
            node.visible = visible[key.split("/")[0]]  # children do not follow their group
        if self._cloud is not None:
            self._cloud.visible = in_3d

    def _blink(self, stop: threading.Event) -> None:
        while not stop.wait(self.blink_period):
            with self._lock:
                self.blink_showing = "target" if self.blink_showing == "reference" else "reference"
                if self._nodes:
                    self._apply_visibility()

    def stop(self) -> None:
        """Stop the blink thread."""
        self._blink_stop.set()

    def screen_point(self, client: Any, image: str, x: float, y: float) -> tuple[float, float] | None:
        """Where work-pair pixel ``(x, y)`` of ``image`` appears on a client's canvas.

        Returns canvas coordinates in CSS px (origin top-left), or None when the image is
        not laid out or the point is behind the camera. The inverse of :meth:`pick`.
        """
        import viser.transforms as tf

        with self._lock:
            place = self.placements.get(image)
        if place is None:
            return None
        world = np.array([
            place.centre[0] - place.size[0] / 2 + x / place.shape[1] * place.size[0],
            place.centre[1] - place.size[1] / 2 + y / place.shape[0] * place.size[1],
            0.0,
        ])
        camera = client.camera
        rotation = tf.SO3(np.asarray(camera.wxyz)).as_matrix()
        local = rotation.T @ (world - np.asarray(camera.position))
        if local[2] <= 0:
            return None
        height, width = float(camera.image_height), float(camera.image_width)
        focal = height / 2 / np.tan(camera.fov / 2)
        return width / 2 + focal * local[0] / local[2], height / 2 + focal * local[1] / local[2]

    def pick(self, ray_origin: Any, ray_direction: Any) -> tuple[str, float, float] | None:
        """Return ``(image, x, y)``: the visible image and work-pair pixel a click ray hits."""
        origin = np.asarray(ray_origin, dtype=np.float64)
        direction = np.asarray(ray_direction, dtype=np.float64)
        if abs(direction[2]) < 1e-9 or self.mode == "3D scene":
            return None
        t = -origin[2] / direction[2]
        if t <= 0:
            return None
        point = origin + t * direction
        with self._lock:
            order = ["reference", "target"]
            if self.mode == "blink" and self.blink_showing == "target":
                order.reverse()
            for name in order:
                place = self.placements.get(name)
                if place is None:
                    continue
                pixel = place.pixel(point)
                if pixel is not None:
                    if self.mode == "swipe":
                        split = self.swipe_position
                        return ("reference" if pixel[0] < split * place.shape[1] else "target", *pixel)
                    return (name, *pixel)
        return None
