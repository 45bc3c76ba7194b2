import numpy as np
import pytest

from radcons.errors import InputError, ParamsError
from radcons.validate import single_band_image


def test_a_float32_image_passes_unchanged():
    image = np.arange(64, dtype=np.float32).reshape(8, 8)
    assert single_band_image(image, "reference", 8, "is too small") is image


def test_integer_images_become_float32():
    out = single_band_image(np.full((4, 5), 7, np.uint16), "target", 2, "is too small")
    assert out.dtype == np.float32 and out.shape == (4, 5) and np.all(out == 7)


@pytest.mark.parametrize(
    ("image", "message"),
    [
        (np.zeros((4, 4, 3)), r"reference must be a single-band 2-D image, got shape \(4, 4, 3\)"),
        (np.zeros((4, 9)), r"reference of shape \(4, 9\) is too small for a test"),
        (np.zeros((8, 8), complex), "reference must hold real numbers, got dtype complex128"),
        (np.full((8, 8), np.nan), "every pixel of the reference is NaN"),
    ],
)
def test_bad_images_are_refused_with_their_reason(image, message):
    with pytest.raises(InputError, match=message):
        single_band_image(image, "reference", 5, "is too small for a test")


@pytest.mark.parametrize(
    "stage, name", [("uniformity", "sigma"), ("objects", "smooth_sigma"), ("refine", "blend_width"), ("sharpness", "sigma")]
)
def test_gaussian_widths_longer_than_the_image_are_refused(stage, name):
    from radcons.params import Params
    from radcons.validate import check_params_for_shape

    params = Params().with_stage(stage, **{name: 696694429.0})
    with pytest.raises(ParamsError, match=rf"\[{stage}\] {name} = .* smaller side \(64 px\)"):
        check_params_for_shape(params, (64, 80))
    check_params_for_shape(Params().with_stage(stage, **{name: 5.0}), (64, 80))


def test_a_background_disparity_beyond_the_image_width_is_refused():
    from radcons.params import Params
    from radcons.validate import check_params_for_shape

    with pytest.raises(ParamsError, match=r"background_disparity = 1e\+12 px is beyond the image's width \(80 px\)"):
        check_params_for_shape(Params().with_stage("smoothness", background_disparity=1e12), (64, 80))
    check_params_for_shape(Params().with_stage("smoothness", background_disparity=-80.0), (64, 80))


def test_the_size_minimum_of_the_readers_holds_for_every_stage():
    """An image the readers take (radcons.io.raster.MIN_SIDE a side) passes every stage's
    own size check, and a pair of that size runs through every stage."""
    from demo_data_gen import generate
    from radcons.io.raster import MIN_SIDE
    from radcons.params import STAGES, Params
    from radcons.pipeline import Pipeline
    from radcons.stages.rectify.epipolar import validated_image
    from radcons.stages.sharpness.run import sharpness_consistency
    from radcons.stages.uniformity.run import illumination_uniformity

    rng = np.random.default_rng(0)
    checks = (
        lambda image: validated_image(image, "reference"),
        lambda image: sharpness_consistency(image, image[::-1].copy()),
        illumination_uniformity,
    )
    for check in checks:
        check(rng.uniform(10, 200, (MIN_SIDE, MIN_SIDE)).astype(np.float32))
    for check in checks[:2]:  # the stages that set the minimum
        with pytest.raises(InputError, match="too small"):
            check(rng.uniform(10, 200, (MIN_SIDE - 1, MIN_SIDE)).astype(np.float32))
    pair = generate(size=64, seed=0, scenario="mixed")
    crop = pair.with_images(pair.reference.data[:MIN_SIDE, :MIN_SIDE], pair.target.data[:MIN_SIDE, :MIN_SIDE])
    crop.disparity = crop.reference_objects = crop.target_objects = crop.change_mask = None
    every_stage = Params.from_preset("paper").with_stage("sharpness", enabled=True, noise="cleaner")
    run = Pipeline(every_stage).run(crop)
    assert run.image_stages[-1] == STAGES[-1] and run.images()[0].shape == (MIN_SIDE, MIN_SIDE)
