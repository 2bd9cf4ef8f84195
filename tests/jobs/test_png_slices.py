"""PNG slices: written bytes decode (Pillow) to exactly the label image, both modes."""

import numpy as np
import pytest
from PIL import Image

from dreamprint_gui.engine.printer import load_printer
from dreamprint_gui.errors import DreamPrintError
from dreamprint_gui.io.png_slices import encode_labels_png, read_png_labels


@pytest.mark.parametrize("uniform", [False, True])  # libdeflate and zlib-ng IDAT streams
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


def test_idat_is_libdeflate_level_1_so_bytes_do_not_depend_on_the_cpu():
    import imagecodecs

    pal = load_printer().palette()
    rng = np.random.default_rng(3)
    lab = np.where(rng.random((40, 50)) < 0.95, 5, rng.integers(0, 7, (40, 50))).astype(np.uint8)
    png = encode_labels_png(lab, pal)
    rows = np.concatenate([np.zeros((40, 1), np.uint8), pal[lab].reshape(40, 150)], axis=1)
    assert imagecodecs.deflate_encode(rows.tobytes(), level=1) in png
