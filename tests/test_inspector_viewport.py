"""The viewport's layout and drawing for large pictures: the grid fills the canvas, nodata
is cropped and dimmed, outlines keep their width on screen when the picture is shrunk.

References are computed here independently: a pinhole projection of the framed camera
(not the layout's own formula), bounding boxes from ``np.argwhere``, outline widths from
a chessboard distance transform, and the browser's shrinking imitated by an area resize.
"""

from __future__ import annotations

import contextlib
import itertools
from types import SimpleNamespace

import cv2
import numpy as np
import pytest
import scipy.ndimage

from inspector import layout, render

# ----------------------------------------------------------------------------- framing


def arrangement_sizes(count: int, size: tuple[float, float], canvas: tuple[float, float]) -> dict[tuple[int, int], float]:
    """Canvas pixels per picture width of every grid without an empty row, by adding up
    the widths and heights of its cells, gaps and title bands."""
    sizes = {}
    for columns in range(1, count + 1):
        rows = -(-count // columns)
        width = sum([size[0]] * columns) + layout.GAP * (columns - 1)
        height = sum([size[1] + layout.TITLE] * rows) + layout.GAP * (rows - 1)
        sizes[(columns, rows)] = size[0] * min(canvas[0] / width, canvas[1] / height) / layout.MARGIN
    return sizes


@pytest.mark.parametrize(
    ("count", "size", "canvas", "expected"),
    [
        (2, (1.0, 1.0), (762, 1000), (1, 2)),  # a tall canvas: one above the other
        (2, (1.0, 1.0), (1600, 700), (2, 1)),  # a wide one: side by side
        (3, (1.0, 1.0), (762, 1000), (2, 2)),  # with the disparity map: a 2 x 2 grid
        (3, (1.0, 0.4), (762, 1000), (1, 3)),  # wide strips stack
        (2, (0.5, 1.0), (700, 700), (2, 1)),  # tall pictures stand side by side
    ],
)
def test_grid_shape_draws_the_pictures_largest(count, size, canvas, expected):
    sizes = arrangement_sizes(count, size, canvas)
    assert layout.grid_shape(count, size, canvas) == expected
    assert sizes[expected] == pytest.approx(max(sizes.values()))


def test_grid_centres_leave_gaps_and_title_bands_and_centre_the_grid():
    size = (1.0, 0.6)
    centres = layout.grid_centres(3, 2, size)
    assert centres[1][0] - centres[0][0] == pytest.approx(size[0] + layout.GAP)
    assert centres[2][1] - centres[0][1] == pytest.approx(size[1] + layout.TITLE + layout.GAP)
    assert centres[2][0] == pytest.approx(centres[0][0])
    top = centres[0][1] - size[1] / 2 - layout.TITLE
    bottom = centres[2][1] + size[1] / 2
    left, right = centres[0][0] - size[0] / 2, centres[1][0] + size[0] / 2
    assert top == pytest.approx(-bottom) and left == pytest.approx(-right)


class FakeCamera:
    """The attributes of a client camera that the viewport sets and reads."""

    def __init__(self, canvas: tuple[int, int]) -> None:
        self.image_width, self.image_height = canvas
        self.aspect = canvas[0] / canvas[1]
        self.position = self.look_at = self.up_direction = None
        self.fov = None
        self.callbacks = []

    def on_update(self, callback):
        self.callbacks.append(callback)


def project(camera: FakeCamera, point: np.ndarray) -> np.ndarray:
    """Canvas pixel of a scene point: a pinhole camera at ``position`` looking at
    ``look_at`` with ``up_direction`` (OpenCV axes: x right, y down on the canvas)."""
    position = np.asarray(camera.position, float)
    forward = np.asarray(camera.look_at, float) - position
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, np.asarray(camera.up_direction, float))
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    local = np.array([right, down, forward]) @ (point - position)
    focal = camera.image_height / 2 / np.tan(camera.fov / 2)
    return np.array([camera.image_width / 2, camera.image_height / 2]) + focal * local[:2] / local[2]


@pytest.fixture()
def viewport():
    import viser

    from inspector.recording import free_port
    from inspector.viewport import Viewport

    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    view = Viewport(server)
    try:
        yield view
    finally:
        view.stop()
        server.stop()


def show(viewport, shape: tuple[int, int], disparity: bool) -> render.DisplayFrame:
    picture = np.full(shape, 100, np.uint8)
    layer = np.zeros((*shape, 4), np.uint8)
    frame = render.DisplayFrame((0, shape[0], 0, shape[1]), 1)
    extra = (np.zeros((*shape, 3), np.uint8), "disparity") if disparity else None
    viewport.show(picture, picture, (layer, layer), ("reference", "target"), frame, disparity=extra)
    return frame


def client_of(canvas: tuple[int, int]) -> SimpleNamespace:
    return SimpleNamespace(client_id=7, camera=FakeCamera(canvas), atomic=contextlib.nullcontext)


def picture_boxes(viewport, camera: FakeCamera) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Canvas ``(top-left, bottom-right)`` of each laid-out picture, projected."""
    boxes = {}
    for name, place in viewport.placements.items():
        corners = [np.array([place.centre[0] + sx * place.size[0] / 2, place.centre[1] + sy * place.size[1] / 2, 0.0]) for sx, sy in ((-1, -1), (1, 1))]
        boxes[name] = tuple(project(camera, corner) for corner in corners)
    return boxes


@pytest.mark.parametrize(("canvas", "disparity"), [((762, 1000), False), ((762, 1000), True), ((1500, 600), True)])
def test_framed_pictures_fill_the_canvas_and_are_as_large_as_any_grid_allows(viewport, canvas, disparity):
    shape = (600, 500)
    viewport.set_canvas(tuple(map(float, canvas)))
    show(viewport, shape, disparity)
    client = client_of(canvas)
    viewport.frame_camera(client)
    assert viewport.framed(client)
    boxes = picture_boxes(viewport, client.camera)
    assert set(boxes) == {"reference", "target"} | ({"disparity"} if disparity else set())
    low = np.min([box[0] for box in boxes.values()], axis=0)
    high = np.max([box[1] for box in boxes.values()], axis=0)
    assert (low >= -0.5).all() and (high <= np.array(canvas) + 0.5).all(), "a picture leaves the canvas"
    spans = (high - low) / np.array(canvas)
    assert spans.max() > 0.9, f"the pictures use only {spans} of the canvas"
    width = boxes["reference"][1][0] - boxes["reference"][0][0]
    best = max(arrangement_sizes(len(boxes), (shape[1] / 600, 1.0), canvas).values())
    assert width == pytest.approx(best, rel=0.01)
    # the scale the overlays are drawn for is the one on the canvas
    assert viewport.picture_scale(shape, max(shape), disparity) == pytest.approx(shape[1] / width, rel=0.01)
    # pictures do not overlap
    for (_, a), (_, b) in itertools.combinations(boxes.items(), 2):
        assert a[1][0] <= b[0][0] + 0.5 or b[1][0] <= a[0][0] + 0.5 or a[1][1] <= b[0][1] + 0.5 or b[1][1] <= a[0][1] + 0.5


def test_a_canvas_of_another_shape_lays_the_pictures_out_again_and_reframes(viewport):
    relaid = []
    viewport.on_layout = lambda: relaid.append(True)
    viewport.set_canvas((1500.0, 600.0))
    show(viewport, (400, 400), disparity=False)
    client = client_of((1500, 600))
    viewport.follow_canvas(client)
    wide = picture_boxes(viewport, client.camera)
    assert wide["target"][0][0] > wide["reference"][1][0], "side by side in a wide canvas"
    # the panels are folded away: the canvas becomes tall; the camera reports it
    client.camera.image_width, client.camera.image_height, client.camera.aspect = 700, 1000, 0.7
    for callback in client.camera.callbacks:
        callback(client.camera)
    assert relaid and viewport.framed(client)
    tall = picture_boxes(viewport, client.camera)
    assert tall["target"][0][1] > tall["reference"][1][1], "one above the other in a tall canvas"
    side_by_side = 700 / (2 + layout.GAP) / layout.MARGIN  # picture width if they had stayed side by side
    assert tall["reference"][1][0] - tall["reference"][0][0] > 1.3 * side_by_side


def test_clicks_and_screen_points_map_through_the_crop(viewport):
    frame = render.DisplayFrame((100, 400, 50, 450), 2)
    picture = np.zeros((150, 200), np.uint8)
    layer = np.zeros((150, 200, 4), np.uint8)
    disparity = (np.zeros((150, 200, 3), np.uint8), "disparity")
    viewport.show(picture, picture, (layer, layer), ("r", "t"), frame, disparity=disparity)
    for name in ("reference", "target", "disparity"):
        place = viewport.placements[name]
        # a ray straight at the scene point of work pixel (250, 160)
        point = (place.centre[0] - place.size[0] / 2 + (250 - 50) / 400 * place.size[0],
                 place.centre[1] - place.size[1] / 2 + (160 - 100) / 300 * place.size[1])
        hit = viewport.pick((point[0], point[1], -3.0), (0.0, 0.0, 1.0))
        assert hit[0] == ("reference" if name == "disparity" else name)
        assert hit[1:] == pytest.approx((250, 160))


# ----------------------------------------------------------------------------- nodata


def test_valid_box_is_the_bounding_box_of_pixels_valid_in_either_image():
    rng = np.random.default_rng(3)
    for _ in range(20):
        images = [np.where(rng.random((40, 50)) < 0.02, 1.0, np.nan) for _ in range(2)]
        rows, cols = np.argwhere(np.isfinite(images[0]) | np.isfinite(images[1])).T
        assert render.valid_box(*images) == (rows.min(), rows.max() + 1, cols.min(), cols.max() + 1)
    assert render.valid_box(np.full((5, 6), np.nan)) == (0, 5, 0, 6)


def rotated_footprint(shape: tuple[int, int], angle: float, offset: tuple[int, int]) -> np.ndarray:
    """An image that is NaN outside a rotated square, as an epipolar resampling leaves it."""
    image = np.random.default_rng(0).random(shape).astype(np.float32) * 100 + 50
    mask = np.zeros(shape, np.uint8)
    centre = (shape[1] / 2 + offset[0], shape[0] / 2 + offset[1])
    corners = cv2.boxPoints((centre, (shape[1] * 0.55, shape[0] * 0.55), angle)).astype(np.int32)
    cv2.fillConvexPoly(mask, corners, 1)
    return np.where(mask > 0, image, np.nan)


def test_pictures_are_cropped_to_the_valid_pixels_and_show_nodata_in_a_dim_grey():
    from inspector.panels.view import ViewPanel

    reference = rotated_footprint((300, 400), 20, (-60, 20))
    target = rotated_footprint((300, 400), 20, (-50, 25))
    panel = ViewPanel(SimpleNamespace(), display_side=100)
    frame, pictures, invalid = panel._pictures((reference, target))
    rows, cols = np.argwhere(np.isfinite(reference) | np.isfinite(target)).T
    assert frame.box == (rows.min(), rows.max() + 1, cols.min(), cols.max() + 1)
    assert frame.box[3] - frame.box[2] < 300, "the empty margins were not cropped"
    assert max(pictures[0].shape) <= 100 and frame.factor == -(-max(frame.shape) // 100)
    for picture, image in zip(pictures, (reference, target)):
        row0, row1, col0, col1 = frame.box
        shrunk = cv2.resize(image[row0:row1, col0:col1], picture.shape[::-1], interpolation=cv2.INTER_AREA)
        nodata = ~np.isfinite(shrunk)
        assert nodata.any() and (picture[nodata] == render.NODATA_GREY).all()
        assert (picture[~nodata] != render.NODATA_GREY).mean() > 0.9  # image content keeps its greys
    np.testing.assert_array_equal(invalid, ~np.isfinite(frame.apply(reference)))


# ----------------------------------------------------------------------------- outlines


def square_labels(size: int = 240) -> np.ndarray:
    labels = np.zeros((size, size), np.int32)
    labels[60:180, 60:180] = 1
    return labels


@pytest.mark.parametrize("thickness", [1, 2, 5])
def test_outline_mask_is_a_border_of_the_given_width(thickness):
    labels = square_labels()
    inside = scipy.ndimage.distance_transform_cdt(labels > 0, metric="chessboard")
    expected = (labels > 0) & (inside <= thickness)
    np.testing.assert_array_equal(render.outline_mask(labels, thickness), expected)


@pytest.mark.parametrize("scale", [1.0, 2.5, 4.0])
def test_outlines_keep_their_width_on_screen_when_the_picture_is_shrunk(scale):
    labels = square_labels()
    layer = render.draw_overlay(labels.shape, labels=labels, colours={1: (255, 40, 40)}, names={}, scale=scale, line_px=2.0)
    width = int((layer[120, :, 3] > 0).argmax())  # first outlined column on the middle row
    band = int((layer[120, width:, 3] > 0).argmin())
    assert band == render.outline_thickness(scale, 2.0) == max(1, round(2 * scale))
    # the browser shrinks the picture by `scale`: the outline stays opaque on screen
    size = round(labels.shape[0] / scale)
    on_screen = cv2.resize(layer, (size, size), interpolation=cv2.INTER_AREA)
    assert on_screen[size // 2, : size // 2, 3].max() >= 250
    thin = render.draw_overlay(labels.shape, labels=labels, colours={1: (255, 40, 40)}, names={}, scale=1.0)
    faded = cv2.resize(thin, (size, size), interpolation=cv2.INTER_AREA)
    if scale > 2:
        assert faded[size // 2, : size // 2, 3].max() < 200, "a 1 px outline should fade when shrunk (control)"


def test_layers_are_drawn_in_the_cropped_frame_at_the_canvas_scale():
    from inspector.overlays import OUTLINE_PX, OVERLAYS, draw_layers
    from radcons.io import Pair, Raster
    from radcons.results import ObjectLabels

    labels = np.zeros((300, 400), np.int32)
    labels[120:200, 150:260] = 4
    image = np.zeros(labels.shape, np.float32)
    pair = Pair(Raster(image), Raster(image), name="box")
    objects = ObjectLabels(labels, labels, "user")
    on = {label: False for label in OVERLAYS} | {"Object outlines": True}
    box, factor, scale = (100, 300, 100, 300), 2, 3.0
    reference, _ = draw_layers(on, pair, objects, None, factor, (100, 100), None, box, scale)
    shown = labels[100:300:2, 100:300:2]
    width = round(OUTLINE_PX * scale)
    inside = scipy.ndimage.distance_transform_cdt(shown > 0, metric="chessboard")
    np.testing.assert_array_equal(reference[..., 3] > 0, (shown > 0) & (inside <= width))


def test_an_unrectified_pair_of_two_shapes_keeps_both_whole():
    from inspector.panels.view import ViewPanel

    reference = np.random.default_rng(1).random((81, 80)).astype(np.float32)
    target = np.random.default_rng(2).random((81, 75)).astype(np.float32)
    frame, pictures, _ = ViewPanel(SimpleNamespace(), display_side=100)._pictures((reference, target))
    assert frame.box == (0, 81, 0, 80)
    assert pictures[0].shape == (81, 80) and pictures[1].shape == (81, 75)
