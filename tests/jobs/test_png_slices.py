"""PNG slices: written bytes decode (Pillow) to exactly the label image, both modes."""

import zlib

import numpy as np
import pytest
from PIL import Image

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.printer import load_printer
from dreamprint_gui.job.encode.label_deflate import label_zlib
from dreamprint_gui.job.encode.png_slices import encode_labels_png, read_png_labels


@pytest.mark.parametrize("uniform", [False, True])  # short runs, long runs
@pytest.mark.parametrize("mode", ["rgb", "palette"])
@pytest.mark.parametrize("shape", [(1, 1), (7, 13), (64, 3), (300, 211)])
def test_round_trip_through_pillow(tmp_path, mode, shape, uniform):
    pal = load_printer().palette()
    rng = np.random.default_rng(1)
    lab = rng.integers(0, 7, shape).astype(np.uint8)
    if uniform:  # a mostly-Clear layer with a few specks
        lab = np.where(rng.random(shape) < 0.97, 5, lab).astype(np.uint8)
    f = tmp_path / "s.png"
    f.write_bytes(encode_labels_png(lab, pal, mode))
    with Image.open(f) as im:
        im.verify()  # checks the chunk CRCs
    with Image.open(f) as im:
        assert im.size == (shape[1], shape[0])
        assert im.mode == ("RGB" if mode == "rgb" else "P")
        rgb = np.asarray(im.convert("RGB"))
    np.testing.assert_array_equal(rgb, pal[lab])
    np.testing.assert_array_equal(read_png_labels(f, pal), lab)


def test_strided_views_encode_like_copies():
    pal = load_printer().palette()
    lab = np.random.default_rng(2).integers(0, 7, (9, 5)).astype(np.uint8)
    assert encode_labels_png(lab.T, pal) == encode_labels_png(lab.T.copy(), pal)
    assert encode_labels_png(lab[::-1], pal) == encode_labels_png(lab[::-1].copy(), pal)


def test_foreign_colour_is_reported(tmp_path):
    pal = load_printer().palette()
    f = tmp_path / "x.png"
    Image.new("RGB", (3, 2), (1, 2, 3)).save(f)
    with pytest.raises(DreamPrintError, match=r"\(1, 2, 3\)"):
        read_png_labels(f, pal)


def _scanlines(lab: np.ndarray, pal: np.ndarray | None) -> bytes:
    """The PNG scanlines with filter type 0, written out from the specification (section 7)."""
    px = lab[..., None] if pal is None else pal[lab]
    rows = px.reshape(lab.shape[0], -1)
    return np.concatenate([np.zeros((len(rows), 1), np.uint8), rows], axis=1).tobytes()


def _images(rng):
    yield rng.integers(0, 7, (23, 57)).astype(np.uint8)             # runs of 1-3
    yield np.full((3, 1), 4, np.uint8)                                 # one column
    yield np.full((2, 1000), 5, np.uint8)                              # matches split at 258
    for w in (86, 87, 88, 172, 173, 260, 261):                         # remainders 255..261
        yield np.full((2, w), 2, np.uint8)
    wide = np.full((2, 12000), 5, np.uint8)                            # same colour > 32 KiB back
    wide[:, 0] = 1
    wide[:, -1] = 1
    yield wide
    specks = np.where(rng.random((40, 300)) < 0.97, 5, rng.integers(0, 7, (40, 300)))
    yield specks.astype(np.uint8)
    yield specks.astype(np.uint8).T                                    # strided view
    blocks = np.repeat(rng.integers(0, 7, (9, 40)), 13, axis=1).astype(np.uint8)
    yield blocks[::-1]


@pytest.mark.parametrize("mode", ["rgb", "palette"])
def test_idat_inflates_to_the_scanlines(mode):
    pal = load_printer().palette()
    for lab in _images(np.random.default_rng(3)):
        z = label_zlib(lab, pal if mode == "rgb" else None, n_labels=len(pal))
        assert z[:2] == b"\x78\x01"
        assert zlib.decompress(z) == _scanlines(lab, pal if mode == "rgb" else None)
        # the Adler-32 trailer (advanced per run in closed form) is checked by zlib too
        assert int.from_bytes(z[-4:], "big") == zlib.adler32(_scanlines(
            lab, pal if mode == "rgb" else None))


def test_label_outside_the_palette_is_refused():
    pal = load_printer().palette()
    lab = np.zeros((2, 3), np.uint8)
    lab[1, 2] = len(pal)
    with pytest.raises(ValueError, match="palette"):
        encode_labels_png(lab, pal)
    with pytest.raises(ValueError, match="palette"):
        encode_labels_png(lab, pal, "palette")


def test_any_palette_and_label_count_encodes():
    rng = np.random.default_rng(8)
    for n_lab in (1, 2, 7, 40):
        pal = rng.integers(0, 256, (n_lab, 3)).astype(np.uint8)
        pal[0] = pal[-1][::-1]                           # shared byte values
        lab = rng.integers(0, n_lab, (17, 61)).astype(np.uint8)
        for p in (pal, None):
            z = label_zlib(lab, p, n_labels=n_lab)
            assert zlib.decompress(z) == _scanlines(lab, p)
    lab = rng.integers(0, 256, (9, 300)).astype(np.uint8)  # every byte value, indexed
    assert zlib.decompress(label_zlib(lab, None)) == _scanlines(lab, None)


def test_block_code_is_a_complete_prefix_code_within_15_bits():
    from dreamprint_gui.job.encode.label_deflate import _huffman_lengths

    rng = np.random.default_rng(9)
    for weights in ([1], [5, 1], list(rng.integers(1, 10**6, 286)), [2**k for k in range(40)]):
        lengths = _huffman_lengths(weights, 15)
        assert max(lengths) <= 15
        kraft = sum(2.0 ** -n for n in lengths)
        assert kraft == 1.0 or len(weights) == 1
