"""Tiled GeoTIFFs assembled from blocks compressed elsewhere: a scene run's output.

A scene is too large for the process that writes its output to compress it: on one
machine that process takes a core from the workers, and on a cluster it would be the
one serial step. So each Dask worker turns its tile into the file's blocks, deflated,
at full resolution and at every overview level whose blocks lie within the tile
(:func:`encode_tile`); the writer (:class:`TiledGeoTiffWriter`) only keeps them in a
scratch file beside the output and lays them out at the end. tifffile writes blocks
given as bytes as they are.

The layout (:class:`Pyramid`) is the one :func:`radcons.io.gdal.write_gdal` gives a
large image: square blocks (256 px where the tile side allows it), deflate, overviews
at 2, 4, 8, ... down to 256 px. Each overview level is the 2 x 2 mean of the level
above it (:func:`reduce_by_two`: valid pixels only, rounded for integer dtypes, nodata
where a group has none), as GDAL's ``average`` overviews. The first level whose blocks
span several tiles is assembled whole by the writer from the tiles' reductions (1/64
of the image with 1024 px tiles), and the levels after it are computed from it.

The georeferencing tags (GeoKeys, pixel scale and tie point or transformation, nodata,
RPCs) are those GDAL writes for the same CRS, transform, nodata and RPCs
(:func:`geotiff_tags`: copied from a one-pixel GeoTIFF GDAL writes in memory).
"""

from __future__ import annotations

import io
import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from radcons.io.raster import valid_mask

__all__ = ["Pyramid", "EncodedTile", "reduce_by_two", "encode_blocks", "encode_tile", "geotiff_tags", "TiledGeoTiffWriter"]

#: Overview levels stop when the next would be smaller than this many px.
OVERVIEW_SIDE = 256
#: Deflate level of the blocks (GDAL's default ZLEVEL), by libdeflate (imagecodecs), which
#: compresses a 1024 px uint16 tile 5 times faster than zlib at the same level.
DEFLATE_LEVEL = 6
#: Uncompressed bytes (all levels) above which the file is a BigTIFF, as GDAL's
#: ``BIGTIFF=IF_SAFER`` (with room for the directories).
BIGTIFF_FROM = 4_000_000_000
#: TIFF tags of georeferencing copied from GDAL's file: ModelPixelScale, ModelTiepoint,
#: ModelTransformation, GeoKeyDirectory, GeoDoubleParams, GeoAsciiParams,
#: GDAL_METADATA, GDAL_NODATA, RPCCoefficient.
GEO_TAGS = frozenset({33550, 33922, 34264, 34735, 34736, 34737, 42112, 42113, 50844})


def _ceil_div(a: int, b: int) -> int:
    return -(-a // b)


@dataclass(frozen=True)
class Pyramid:
    """The levels and blocks of one output image, and which levels the workers encode.

    Attributes
    ----------
    shape : (int, int)
        Rows and columns at full resolution.
    block : int
        Side of a file block, px.
    levels : int
        Levels in the file: full resolution and its overviews.
    local : int
        Levels ``0 .. local - 1`` are encoded by the workers, block by block; level
        ``local`` (when ``local < levels``) is assembled by the writer from the tiles'
        reductions.
    """

    shape: tuple[int, int]
    block: int
    levels: int
    local: int

    @classmethod
    def plan(cls, shape: tuple[int, int], tile: int) -> "Pyramid":
        """The layout of a ``shape`` image written from tiles of ``tile`` px (a multiple of 64).

        Raises
        ------
        ValueError
            ``tile`` is not a multiple of 64.
        """
        if tile % 64:
            raise ValueError(f"the tile side must be a multiple of 64 px, got {tile}")
        block = math.gcd(tile, 256)
        side = max(shape)
        levels = 1 + sum(1 for k in range(1, 32) if side / 2**k >= OVERVIEW_SIDE)
        local = 1
        while local < levels and tile % (block << local) == 0:
            local += 1
        return cls(tuple(shape), block, levels, local)

    def level_shape(self, level: int) -> tuple[int, int]:
        """Rows and columns of ``level`` (each level halves the one above, rounding up)."""
        return _ceil_div(self.shape[0], 2**level), _ceil_div(self.shape[1], 2**level)

    def block_grid(self, level: int) -> tuple[int, int]:
        """Rows and columns of blocks of ``level``."""
        rows, columns = self.level_shape(level)
        return _ceil_div(rows, self.block), _ceil_div(columns, self.block)

    def uncompressed_bytes(self, dtype: np.dtype) -> int:
        """Bytes of every level's blocks, uncompressed."""
        return sum(math.prod(self.block_grid(k)) for k in range(self.levels)) * self.block**2 * np.dtype(dtype).itemsize


@dataclass(frozen=True)
class EncodedTile:
    """One tile of an output image, as the writer stores it.

    Attributes
    ----------
    origin : (int, int)
        Row and column of the tile's first pixel, at full resolution.
    shape : (int, int)
        Rows and columns of the tile at full resolution.
    blocks : list of list of bytes
        Per level ``0 .. local - 1``: the deflated blocks of the tile, row by row.
    reduced : ndarray or None
        The tile at level ``local`` (None when the file has no such level).
    """

    origin: tuple[int, int]
    shape: tuple[int, int]
    blocks: list[list[bytes]]
    reduced: np.ndarray | None

    def block_grid(self, level: int, block: int) -> tuple[int, int]:
        """Rows and columns of blocks the tile holds at ``level``."""
        rows, columns = (_ceil_div(_ceil_div(side, 2**level), block) for side in self.shape)
        return rows, columns


def reduce_by_two(image: np.ndarray, nodata: float | None) -> np.ndarray:
    """The next overview level: 2 x 2 means of the valid pixels (a last odd row or column alone).

    Integer images are rounded to the nearest value; a group without a valid pixel takes
    ``nodata`` (0 without one; NaN for floats without one).
    """
    rows, columns = image.shape
    valid = valid_mask(image, nodata)
    # float32 holds sums of four 8- or 16-bit values exactly
    work = np.float32 if image.dtype.itemsize <= 2 else np.float64
    if rows % 2 == 0 and columns % 2 == 0 and valid.all():  # most tiles: every group whole
        mean = image.astype(work).reshape(rows // 2, 2, columns // 2, 2).sum(axis=(1, 3)) / work(4)
        return mean.astype(image.dtype) if image.dtype.kind == "f" else np.rint(mean).astype(image.dtype)
    padded = ((0, rows % 2), (0, columns % 2))
    values = np.pad(np.where(valid, image, 0).astype(work), padded)
    counts = np.pad(valid.astype(work), padded)
    total = values.reshape(-1, 2, values.shape[1] // 2, 2).sum(axis=(1, 3))
    count = counts.reshape(-1, 2, counts.shape[1] // 2, 2).sum(axis=(1, 3))
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = total / count
    empty = count == 0
    if image.dtype.kind == "f":
        out = mean.astype(image.dtype)
        out[empty] = np.nan if nodata is None else nodata
        return out
    out = np.rint(np.where(empty, 0.0, mean)).astype(image.dtype)
    out[empty] = 0 if nodata is None else nodata
    return out


def encode_blocks(image: np.ndarray, block: int) -> list[bytes]:
    """The deflated blocks of ``image``, row by row, the last ones zero-padded to ``block`` px."""
    from imagecodecs import deflate_encode

    blocks = []
    for r in range(0, image.shape[0], block):
        for c in range(0, image.shape[1], block):
            part = image[r : r + block, c : c + block]
            if part.shape != (block, block):
                part = np.pad(part, ((0, block - part.shape[0]), (0, block - part.shape[1])))
            blocks.append(deflate_encode(np.ascontiguousarray(part).tobytes(), level=DEFLATE_LEVEL))
    return blocks


def encode_tile(image: np.ndarray, origin: tuple[int, int], pyramid: Pyramid, nodata: float | None) -> EncodedTile:
    """One tile of an output image encoded for :class:`TiledGeoTiffWriter` (a worker's part).

    ``origin`` must be a multiple of the tiles' side, which the pyramid was planned for.
    """
    shape = image.shape
    levels = []
    for _ in range(pyramid.local):
        levels.append(encode_blocks(image, pyramid.block))
        image = reduce_by_two(image, nodata) if len(levels) < pyramid.levels else image
    return EncodedTile(origin, shape, levels, image if pyramid.local < pyramid.levels else None)


def geotiff_tags(gdal: dict[str, Any], nodata: float | None, dtype: np.dtype) -> list[tuple[int, int, int, Any, bool]]:
    """The georeferencing TIFF tags GDAL writes for ``gdal`` (CRS, transform, RPCs) and ``nodata``.

    Returns tifffile's ``extratags``.
    """
    import rasterio
    import rasterio.errors
    import tifffile
    from rasterio.io import MemoryFile

    from radcons.io.gdal import georeferencing_profile

    profile = {"driver": "GTiff", "height": 1, "width": 1, "count": 1, "dtype": np.dtype(dtype).name,
               **georeferencing_profile(gdal, nodata)}
    with warnings.catch_warnings(), MemoryFile() as memory:
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with memory.open(**profile) as dataset:
            if gdal.get("rpcs"):
                from rasterio.rpc import RPC

                dataset.rpcs = RPC(**gdal["rpcs"])
        content = memory.read()
    with tifffile.TiffFile(io.BytesIO(content)) as tiff:
        return [(tag.code, int(tag.dtype), tag.count, tag.value, True) for tag in tiff.pages[0].tags if tag.code in GEO_TAGS]


class TiledGeoTiffWriter:
    """A tiled, deflated GeoTIFF with overviews, written from :class:`EncodedTile` parts.

    Parts may come in any order; they are kept in a scratch file beside ``path`` (removed
    at the end, and by :meth:`close` after an error), so the writer's memory holds only the
    level the workers do not encode. :meth:`finish` writes the file.

    Parameters
    ----------
    path : Path
    pyramid : Pyramid
    dtype : numpy.dtype
    gdal : dict
        CRS, transform and RPCs (as :func:`radcons.io.gdal.georeferencing_gdal`).
    nodata : float or None
    """

    def __init__(self, path: Path, pyramid: Pyramid, dtype: np.dtype, gdal: dict[str, Any], nodata: float | None) -> None:
        self.path, self.pyramid, self.dtype, self.nodata = Path(path), pyramid, np.dtype(dtype), nodata
        self._tags = geotiff_tags(gdal, nodata, self.dtype)
        self._scratch_path = self.path.with_name(f".{self.path.name}.blocks")
        self._scratch = open(self._scratch_path, "w+b")
        self._index: dict[tuple[int, int, int], tuple[int, int]] = {}
        self._reduced = (
            np.zeros(pyramid.level_shape(pyramid.local), self.dtype) if pyramid.local < pyramid.levels else None
        )

    def add(self, tile: EncodedTile) -> None:
        """Store one tile's blocks and reduction."""
        p = self.pyramid
        for level, blocks in enumerate(tile.blocks):
            top, left = (tile.origin[0] >> level) // p.block, (tile.origin[1] >> level) // p.block
            height, width = tile.block_grid(level, p.block)
            if len(blocks) != height * width:
                raise ValueError(f"the tile at {tile.origin} brought {len(blocks)} blocks of level {level}, not {height * width}")
            for i, data in enumerate(blocks):
                offset = self._scratch.seek(0, os.SEEK_END)
                self._scratch.write(data)
                self._index[(level, top + i // width, left + i % width)] = (offset, len(data))
        if self._reduced is not None:
            if tile.reduced is None:
                raise ValueError(f"the tile at {tile.origin} brought no reduction to level {p.local}")
            r0, c0 = tile.origin[0] >> p.local, tile.origin[1] >> p.local
            self._reduced[r0 : r0 + tile.reduced.shape[0], c0 : c0 + tile.reduced.shape[1]] = tile.reduced

    def _stored(self, level: int) -> Iterator[bytes]:
        """The blocks of a worker-encoded level from the scratch file, in the file's order."""
        rows, columns = self.pyramid.block_grid(level)
        for i in range(rows):
            for j in range(columns):
                try:
                    offset, length = self._index[(level, i, j)]
                except KeyError:
                    raise ValueError(f"{self.path.name}: block {i}, {j} of level {level} was never written") from None
                self._scratch.seek(offset)
                yield self._scratch.read(length)

    def finish(self) -> None:
        """Write the file: full resolution with its georeferencing, then the overviews."""
        import tifffile

        p = self.pyramid
        bigtiff = p.uncompressed_bytes(self.dtype) > BIGTIFF_FROM
        common = {"dtype": self.dtype, "tile": (p.block, p.block), "compression": "adobe_deflate",
                  "photometric": "minisblack", "metadata": None, "software": False}
        reduced = self._reduced
        with tifffile.TiffWriter(self.path, bigtiff=bigtiff) as tiff:
            for level in range(p.levels):
                if level < p.local:
                    data: Iterator[bytes] = self._stored(level)
                else:
                    if level > p.local:
                        reduced = reduce_by_two(reduced, self.nodata)
                    data = iter(encode_blocks(reduced, p.block))
                extra = {"extratags": self._tags} if level == 0 else {"subfiletype": 1}
                tiff.write(data, shape=p.level_shape(level), **common, **extra)
        self.close()

    def close(self) -> None:
        """Remove the scratch file (the output, if written, stays)."""
        if not self._scratch.closed:
            self._scratch.close()
        self._scratch_path.unlink(missing_ok=True)

    def __enter__(self) -> "TiledGeoTiffWriter":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
