"""Reading and writing rasters and stereo pair folders.

- :mod:`radcons.io.raster`: single-band images (PNG, TIFF/GeoTIFF), their checks and headers;
- :mod:`radcons.io.pair`: pair folders and their ``pair.toml`` manifest;
- :mod:`radcons.io.atomic`: writes that never leave a half file or folder;
- :mod:`radcons.io.paths`: input paths checked before they are read.
"""

from radcons.io.atomic import atomic_write_bytes, recover_folder, staged_folder
from radcons.io.pair import (
    FILE_KEYS,
    MANIFEST,
    Manifest,
    Pair,
    load_pair,
    load_pair_files,
    read_manifest,
    save_pair,
)
from radcons.io.paths import check_input_file
from radcons.io.raster import (
    ImageHeader,
    Raster,
    check_image,
    is_image_file,
    read_header,
    read_raster,
    valid_mask,
    write_raster,
)

__all__ = [
    "Raster", "Pair", "ImageHeader", "read_raster", "read_header", "write_raster", "check_image",
    "valid_mask", "is_image_file", "load_pair", "load_pair_files", "save_pair", "atomic_write_bytes",
    "staged_folder", "recover_folder", "MANIFEST", "FILE_KEYS", "Manifest", "read_manifest", "check_input_file",
]
