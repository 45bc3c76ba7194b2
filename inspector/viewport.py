"""The inspector's viewport: the two images (and the review's disparity map), blink, swipe,
and the 3D scene.

The scene uses image coordinates: x to the right, y down, the camera on the -z side
looking at +z with "up" = -y (viser draws images in OpenCV's camera convention). Each
picture is a group holding the picture (JPEG) and, just in front of the reference and the
target, a transparent overlay (PNG). The longest side of a picture is one scene unit.

The pictures are laid out in a grid chosen for the canvas (:func:`inspector.layout.grid_shape`):
side by side in a wide canvas, one above the other in a tall one, the disparity map of the
Disparity tab's review as one more cell in the same image frame. One camera looks at all
of them, so pan and zoom stay linked; it is framed to fill the canvas when a client
connects, and again whenever the canvas changes shape or the layout changes (a review
adds the disparity map, the docked panels are folded). The layout follows the canvas that
changed last (the scene is shared by every client).
"""

from __future__ import annotations

import threading
from typing import Any, Callable, Iterable

import numpy as np

from inspector import render
from inspector.layout import (
    MARGIN,
    TITLE,
    ImagePlacement,
    fit_scale,
    grid_centres,
    grid_extent,
    grid_shape,
    picture_size,
)
from inspector.validity_layers import check_layers, paint_causes

__all__ = ["Viewport", "COMPARE_MODES"]

#: How the two images are compared in the viewport.
COMPARE_MODES: tuple[str, ...] = ("side by side", "blink", "swipe", "3D scene")
_FOV = np.deg2rad(35.0)
#: Canvas size (CSS px) assumed until a client reports its own.
_DEFAULT_CANVAS = (1040.0, 800.0)


def _canvas_of(camera: Any) -> tuple[float, float] | None:
    """A client's canvas ``(width, height)``, CSS px, once it has reported one."""
    width, height = getattr(camera, "image_width", None), getattr(camera, "image_height", None)
    return (float(width), float(height)) if width and height else None


class Viewport:
    """Owns the scene nodes of the pictures, overlays and point cloud.

    Parameters
    ----------
    server : viser.ViserServer

    Attributes
    ----------
    shown : dict
        ``"reference"`` / ``"target"`` -> the grey picture sent last.
    cloud : (ndarray, ndarray) or None
        The points and colours of the 3D point cloud sent last.
    on_layout : callable or None
        Called (no argument) after the pictures were laid out anew for a canvas of
        another size: what is drawn for the pictures' scale on the canvas (the overlays)
        must be drawn again.
    """

    def __init__(self, server: Any) -> None:
        self.server = server
        self._aspects: dict[int, float] = {}
        self.scene = server.scene
        self.scene.set_up_direction("-y")
        # Pictures and points are unlit: the default lights' shadow passes and the
        # environment map's prefiltering would only cost the page frames.
        self.scene.configure_environment_map(hdri=None)
        self.scene.configure_default_lights(enabled=False, cast_shadow=False)
        self.mode = "side by side"
        self.placements: dict[str, ImagePlacement] = {}
        self._frame: render.DisplayFrame | None = None
        self._canvas = _DEFAULT_CANVAS
        self._extent = (1.0, 1.0)
        self._nodes: dict[str, Any] = {}
        self._builds = 0
        self._cloud: Any = None
        self.cloud: tuple[np.ndarray, np.ndarray] | None = None
        self.on_layout: Callable[[], None] | None = None
        self._lock = threading.RLock()
        self._blink_stop = threading.Event()
        self._blink_thread: threading.Thread | None = None
        self.blink_period = 0.7
        self.blink_showing = "reference"
        self.shown: dict[str, np.ndarray] = {}
        self._sent_layers: dict[str, np.ndarray] = {}
        self.swipe_position = 0.5
        self._display_shape: tuple[int, int] | None = None
        self.has_disparity = False
        self.validity_layers: tuple[str, ...] = ()
        self._disparity_drawn: tuple[np.ndarray, np.ndarray | None] | None = None

    # ------------------------------------------------------------------ layout

    def _slots(self, disparity: bool) -> list[tuple[str, ...]]:
        """The pictures of each grid cell, in order: blink and swipe show both images in one."""
        if self.mode == "3D scene":
            return [("reference", "target")]
        images = [("reference",), ("target",)] if self.mode == "side by side" else [("reference", "target")]
        return images + [("disparity",)] if disparity else images

    def _layout(self, shape: tuple[int, int], origin: tuple[int, int], disparity: bool) -> dict[str, ImagePlacement]:
        """Placements of the pictures of a part of ``shape`` pixels for the current canvas;
        sets :attr:`_extent`, the scene size the camera frames."""
        size, slots = picture_size(shape), self._slots(disparity)
        columns, self._extent = self._grid(len(slots), size)
        centres = grid_centres(len(slots), columns, size)
        return {name: ImagePlacement(centre, size, shape, origin) for slot, centre in zip(slots, centres) for name in slot}

    def picture_scale(self, shape: tuple[int, int], picture_side: int, disparity: bool) -> float:
        """Picture pixels per canvas pixel once pictures of a ``shape`` part (longest side
        ``picture_side`` px) are laid out, with or without the disparity map, and framed."""
        with self._lock:
            _, extent = self._grid(len(self._slots(disparity)), picture_size(shape))
            return picture_side / fit_scale(extent, self._canvas)

    def _grid(self, count: int, size: tuple[float, float]) -> tuple[int, tuple[float, float]]:
        """Columns and scene extent of the grid of ``count`` pictures of ``size`` for the canvas."""
        columns, rows = grid_shape(count, size, self._canvas)
        return columns, grid_extent(columns, rows, size)

    def _build(self, display_shape: tuple[int, int], frame: render.DisplayFrame, disparity: bool) -> None:
        """(Re)create the picture groups for a new picture size, frame or compare mode.

        Each build uses new node names: viser keeps the old position of a node that is
        removed and added again under the same name.
        """
        for node in sorted(self._nodes, key=lambda key: -key.count("/")):
            self._nodes[node].remove()  # children first: browsers keep orphans otherwise
        self._nodes = {}
        self._builds += 1
        self.placements = self._layout(frame.shape, frame.origin, disparity)
        blank = np.zeros(display_shape, np.uint8)
        clear = np.zeros((*display_shape, 4), np.uint8)
        for name, place in self.placements.items():
            root = f"/{name}_{self._builds}"
            self._nodes[name] = self.scene.add_frame(root, show_axes=False, position=(*place.centre, 0.0))
            self._nodes[f"{name}/image"] = self.scene.add_image(
                f"{root}/image", blank, place.size[0], place.size[1], format="jpeg", jpeg_quality=92,
                cast_shadow=False, receive_shadow=False,
            )
            if name != "disparity":
                self._nodes[f"{name}/overlay"] = self.scene.add_image(
                    f"{root}/overlay", clear, place.size[0], place.size[1], format="png",
                    cast_shadow=False, receive_shadow=False, position=(0.0, 0.0, -0.002),
                )
            self._nodes[f"{name}/title"] = self.scene.add_label(
                f"{root}/title", name, position=(-place.size[0] / 2, -place.size[1] / 2 - 0.3 * TITLE, 0.0),
                anchor="bottom-left", font_screen_scale=0.9,
            )
        self._frame = frame
        self._display_shape = display_shape
        self.has_disparity = disparity
        self._sent_layers = {}
        self.initial_camera()

    def _pose(self, aspect: float) -> tuple[tuple[float, float, float], tuple[float, float, float]] | None:
        """Camera ``(position, up)`` that fits the current layout in a canvas of ``aspect``."""
        if self._frame is None:
            return None
        extent_x, extent_y = self._extent
        tan_y = np.tan(_FOV / 2)
        distance = MARGIN * max(extent_y / 2 / tan_y, extent_x / 2 / (tan_y * aspect))
        if self.mode == "3D scene":
            return (0.0, 1.1 * distance, -0.75 * distance), (0.0, 0.0, -1.0)
        return (0.0, 0.0, -distance), (0.0, -1.0, 0.0)

    def frame_camera(self, client: Any | None = None) -> None:
        """Point one client's camera (or every client's) at the pictures or the 3D scene."""
        clients = [client] if client is not None else list(self.server.get_clients().values())
        for handle in clients:
            camera = handle.camera
            aspect = camera.aspect if camera.aspect and np.isfinite(camera.aspect) else self._canvas[0] / self._canvas[1]
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
        shrink it just after connecting, a panel may be folded, the window resized); lay
        the pictures out anew when its canvas changes size (:meth:`set_canvas`). Only a
        change of a client's own canvas counts: clients of two sizes do not take turns."""
        seen: list[tuple[float, float] | None] = [None]

        def changed(camera: Any) -> None:
            canvas = _canvas_of(camera)
            if canvas is not None and canvas != seen[0]:
                seen[0] = canvas
                self.set_canvas(canvas)
            aspect = camera.aspect
            if aspect and abs(aspect - self._aspects.get(client.client_id, aspect)) > 1e-3:
                self.frame_camera(client)

        changed(client.camera)
        self.frame_camera(client)
        client.camera.on_update(changed)

    def set_canvas(self, canvas: tuple[float, float]) -> None:
        """Lay the pictures out for a canvas of ``(width, height)`` CSS px.

        The picture groups move (nothing is resent) when the grid changes, and every
        client's camera is framed again; :attr:`on_layout` is called either way, since
        the pictures' scale on the canvas changed.
        """
        with self._lock:
            if canvas == self._canvas:
                return
            self._canvas = canvas
            if self._frame is None:
                return
            before = self.placements
            self.placements = self._layout(self._frame.shape, self._frame.origin, self.has_disparity)
            moved = self.placements != before
            if moved:
                with self.server.atomic():
                    for name, place in self.placements.items():
                        self._nodes[name].position = (*place.centre, 0.0)
                self.initial_camera()
        if moved:
            self.frame_camera()
        if self.on_layout is not None:
            self.on_layout()

    def initial_camera(self) -> None:
        """Set the camera that new clients start with (before their canvas size is known)."""
        pose = self._pose(self._canvas[0] / self._canvas[1])
        if pose is None:
            return
        camera = self.server.initial_camera
        camera.fov = float(_FOV)
        camera.position = pose[0]
        camera.look_at = (0.0, 0.0, 0.0)
        camera.up = pose[1]

    # ------------------------------------------------------------------ showing

    def show(
        self,
        reference: np.ndarray,
        target: np.ndarray,
        overlays: tuple[np.ndarray, np.ndarray],
        titles: tuple[str, str],
        frame: render.DisplayFrame,
        swipe: float = 0.5,
        disparity: tuple[np.ndarray, str] | None = None,
        causes: np.ndarray | None = None,
    ) -> None:
        """Show two images, their overlays and a disparity map in the current compare mode.

        Parameters
        ----------
        reference, target : ndarray of uint8, shape (h, w)
            Grey display images (cropped and shrunk from the work pair), sent as JPEG.
        overlays : (ndarray, ndarray)
            RGBA layers of the same size, sent as PNG (a picture or layer equal to
            the one on the page is not sent again).
        titles : (str, str)
            Captions drawn above the images.
        frame : render.DisplayFrame
            The part of the work pair shown and its shrinking (clicks map to its pixels).
        swipe : float
            Split position (0..1) in swipe mode.
        disparity : (ndarray, str), optional
            RGB picture of a disparity map in the same frame and size, and its caption:
            one more picture of the grid (not in the 3D scene).
        causes : ndarray, optional
            Cause code of each pixel of the disparity picture
            (:mod:`radcons.evaluate.validity`): those of :attr:`validity_layers` are
            painted in their colours (:func:`inspector.validity_layers.paint_causes`).
        """
        with self._lock:
            display_shape = reference.shape[:2]
            with_disparity = disparity is not None and self.mode != "3D scene"
            if (self._frame, self._display_shape, self.has_disparity) != (frame, display_shape, with_disparity):
                self._build(display_shape, frame, with_disparity)
                self.frame_camera()
            self.shown = {"reference": reference, "target": target}
            self.swipe_position = swipe
            pictures = {"reference": reference, "target": target}
            if self.mode == "swipe":
                pictures["reference"] = render.swipe_composite(reference, target, swipe)
            named = list(zip(("reference", "target"), titles))
            if with_disparity:
                self._disparity_drawn = (disparity[0], causes)
                pictures["disparity"] = paint_causes(disparity[0], causes, self.validity_layers)
                named.append(("disparity", disparity[1]))
            with self.server.atomic():
                for name, title in named:
                    if not _same(self._nodes[f"{name}/image"].image, pictures[name]):
                        self._nodes[f"{name}/image"].image = pictures[name]
                    self._nodes[f"{name}/title"].text = title
                self._send_layers(overlays, swipe)
                self._apply_visibility()

    def show_validity_layers(self, layers: Iterable[str]) -> None:
        """Paint the invalid pixels of the causes named in ``layers`` on the disparity
        picture (:data:`inspector.validity_layers.LAYER_COLOURS`): only that picture is
        sent again."""
        with self._lock:
            chosen = check_layers(layers)
            self.validity_layers = chosen
            if self.has_disparity and self._disparity_drawn is not None and "disparity/image" in self._nodes:
                self._nodes["disparity/image"].image = paint_causes(*self._disparity_drawn, chosen)

    def sent_picture(self, name: str) -> np.ndarray | None:
        """The picture last sent for ``"reference"``, ``"target"`` or ``"disparity"``
        (None when it is not laid out)."""
        with self._lock:
            node = self._nodes.get(f"{name}/image")
            return None if node is None else node.image

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
            if not _same(self._sent_layers.get(name), layer) or self.mode == "swipe":
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
            self._frame = None
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
            "disparity": not in_3d,
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

        ``image`` is ``"reference"``, ``"target"`` or ``"disparity"`` (in the reference's
        pixels). Returns canvas coordinates in CSS px (origin top-left), or None when the
        picture is not laid out or the point is behind the camera. The inverse of :meth:`pick`.
        """
        import viser.transforms as tf

        with self._lock:
            place = self.placements.get(image)
        if place is None:
            return None
        world = np.array([
            place.centre[0] - place.size[0] / 2 + (x - place.origin[0]) / place.shape[1] * place.size[0],
            place.centre[1] - place.size[1] / 2 + (y - place.origin[1]) / place.shape[0] * place.size[1],
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
        """Return ``(image, x, y)``: the visible image and work-pair pixel a click ray hits
        (a click in the disparity map, which lies in the reference's frame, names the reference)."""
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
            order.append("disparity")
            for name in order:
                place = self.placements.get(name)
                if place is None:
                    continue
                pixel = place.pixel(point)
                if pixel is not None:
                    if self.mode == "swipe" and name != "disparity":
                        split = place.origin[0] + self.swipe_position * place.shape[1]
                        return ("reference" if pixel[0] < split else "target", *pixel)
                    return ("reference" if name == "disparity" else name, *pixel)
        return None


def _same(sent: np.ndarray | None, picture: np.ndarray) -> bool:
    """Whether ``picture`` equals the array already on the page."""
    return sent is not None and (sent is picture or (sent.shape == picture.shape and np.array_equal(sent, picture)))
