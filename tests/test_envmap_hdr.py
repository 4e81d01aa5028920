"""Radiance .hdr reader and writer (oclshade.envmap.hdr) and the envmap CLI."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from oclshade.cli import main
from oclshade.envmap.hdr import HDRFormatError, encode_rgbe, read_hdr, write_hdr


def rgbe_value(r: int, g: int, b: int, e: int) -> np.ndarray:
    """Radiance's colr_color, written out: ((c + 0.5) / 256) * 2^(e - 128)."""
    return np.array([(c + 0.5) * 2.0 ** (e - 136) for c in (r, g, b)]) if e else np.zeros(3)


@given(st.integers(0, 2**32 - 1), st.integers(1, 20), st.integers(1, 40))
@settings(max_examples=15, deadline=None)
def test_round_trip_within_rgbe_precision(tmp_path_factory, seed, rows, cols):
    """RGBE keeps 8 bits of mantissa for the largest channel: each channel comes back within
    2^-8 of the pixel's largest channel (plus the decoder's half-step offset)."""
    rng = np.random.default_rng(seed)
    rgb = (rng.random((rows, cols, 3)) * 10.0 ** rng.uniform(-3, 3, (rows, cols, 1))).astype(np.float32)
    rgb[0, 0] = 0.0
    path = tmp_path_factory.mktemp("hdr") / "x.hdr"
    write_hdr(path, rgb)
    back = read_hdr(path)
    assert back.shape == rgb.shape
    assert np.all(np.abs(back - rgb) <= rgb.max(-1, keepdims=True) / 128.0)
    assert np.all(back[0, 0] == 0.0)


def test_hand_made_file_with_every_scanline_coding(tmp_path):
    """Three scanlines of width 8: new-style RLE (a run and literals), flat pixels, and an
    old-style run (1, 1, 1, n) repeating the previous pixel; stored bottom-up (+Y)."""
    header = b"#?RADIANCE\n# a comment\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=2.0\n\n+Y 3 +X 8\n"
    new_style = bytes([2, 2, 0, 8]) + b"".join(
        bytes([128 + 8, value]) for value in (10, 20, 30)) + bytes([8, 128, 129, 130, 131, 132, 133, 134, 135])
    flat = b"".join(bytes([k, 2 * k, 3 * k, 129]) for k in range(8))
    old = bytes([5, 6, 7, 130]) + bytes([1, 1, 1, 7])
    (tmp_path / "x.hdr").write_bytes(header + new_style + flat + old)
    img = read_hdr(tmp_path / "x.hdr")
    assert img.shape == (3, 8, 3)
    # +Y: the first scanline in the file is the bottom row; EXPOSURE 2 divides
    for x in range(8):
        assert np.allclose(img[2, x], rgbe_value(10, 20, 30, 128 + x) / 2.0)
        assert np.allclose(img[1, x], rgbe_value(x, 2 * x, 3 * x, 129) / 2.0)
        assert np.allclose(img[0, x], rgbe_value(5, 6, 7, 130) / 2.0)


def test_encode_matches_radiance_setcolr():
    # 1.0 = 0.5 * 2^1: mantissa 0.5 * 255.9999 -> 127, exponent 129
    assert list(encode_rgbe(np.array([1.0, 0.5, 0.0]))) == [127, 63, 0, 129]
    assert list(encode_rgbe(np.zeros(3))) == [0, 0, 0, 0]


@pytest.mark.parametrize("content, message", [
    (b"P6\n", "does not start with"),
    (b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\0\0\0\0", "FORMAT=32-bit_rle_xyze"),
    (b"#?RADIANCE\n\n+X 1 -Y 1\n\0\0\0\0", "resolution line"),
    (b"#?RADIANCE\n\n-Y 1 -X 1\n\0\0\0\0", "mirrored"),
    (b"#?RADIANCE\n\n-Y 2 +X 1\n\0\0\0\0", "ends before the last scanline"),
    (b"#?RADIANCE\n\n-Y 1 +X 8\n" + bytes([2, 2, 0, 8, 200, 1]), "overruns"),
    (b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n", "no terminating empty line"),
])
def test_bad_files_name_the_reason(tmp_path, content, message):
    (tmp_path / "bad.hdr").write_bytes(content)
    with pytest.raises(HDRFormatError, match=message):
        read_hdr(tmp_path / "bad.hdr")


def test_cli_convert_round_trip(tmp_path, capsys):
    from oclshade.envmap.files import load_cube, save_cube
    from oclshade.envmap import CubeMap
    faces = np.random.default_rng(0).random((6, 8, 8, 3)).astype(np.float32)
    save_cube(tmp_path / "c.exr", CubeMap(faces), "cube")
    assert main(["envmap", "convert", str(tmp_path / "c.exr"), str(tmp_path / "ll.exr"), "--size", "16"]) == 0
    assert "cube faces 8x8" in capsys.readouterr().err
    assert main(["envmap", "convert", str(tmp_path / "ll.exr"), str(tmp_path / "back.exr"), "--size", "8", "-q"]) == 0
    back = load_cube(tmp_path / "back.exr")
    assert back.size == 8 and np.abs(back.faces - faces).mean() < 0.2     # resampled twice: blurred
    assert main(["envmap", "convert", str(tmp_path / "c.exr"), str(tmp_path / "f_{face}.png"), "-q"]) == 0
    assert sorted(p.name for p in tmp_path.glob("f_*.png")) == sorted(
        f"f_{w}.png" for w in ("posx", "negx", "posy", "negy", "posz", "negz"))


@pytest.mark.parametrize("argv, status, message", [
    (["envmap", "convert", "MISSING.exr", "out.exr"], 1, "no such file"),
    (["envmap", "convert", "IN", "IN"], 2, "OUT must differ from IN"),
    (["envmap", "convert", "IN", "out.exr", "--size", "0"], 2, "size must be a positive integer"),
    (["envmap", "convert", "IN", "out.exr", "--from", "hcross"], 1, "hcross image must be 4N x 3N"),
    (["envmap", "convert", "IN", "out.jpg"], 1, "unknown image extension"),
])
def test_cli_errors_are_one_line(tmp_path, capsys, argv, status, message):
    from oclshade.envmap.files import save_cube
    from oclshade.envmap import CubeMap
    save_cube(tmp_path / "in.exr", CubeMap(np.ones((6, 4, 4, 3), np.float32)), "cube")
    argv = [str(tmp_path / "in.exr") if a == "IN" else (str(tmp_path / a) if a.endswith((".exr", ".jpg")) else a)
            for a in argv]
    assert main(argv) == status
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
