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
