"""Mitsuba variant choice: llvm_ad_rgb by default (which libLLVM Dr.Jit gets, and that the
wheel's one renders), scalar_rgb when asked; both render the same images in expectation, and the
scalar one the same pixels whatever the number of threads."""

import json
import os
import platform
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.proof import mitsuba_setup


@pytest.mark.parametrize("path, major", [
    ("/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1", 19),
    ("/usr/lib/x86_64-linux-gnu/libLLVM-15.so.1", 15),
    ("/usr/lib/llvm-14/lib/libLLVM-14.0.6.so", 14),
    ("/venv/lib/libLLVM-17.so", 17),
    ("/opt/homebrew/opt/llvm@19/lib/libLLVM.dylib", 19),
    ("/opt/homebrew/Cellar/llvm/21.1.8/lib/libLLVM.dylib", 21),
    ("/opt/local/libexec/llvm-18/lib/libLLVM.dylib", 18),
    ("C:/Program Files/LLVM/bin/LLVM-C.dll", None),
])
def test_version_read_from_the_path(path, major):
    assert mitsuba_setup.llvm_major(path) == major


def test_a_link_is_judged_by_the_file_it_names(tmp_path):
    real = tmp_path / "libLLVM.so.19.1"
    real.write_bytes(b"")
    (tmp_path / "libLLVM.so.1").symlink_to(real.name)   # the ABI number alone says nothing
    assert mitsuba_setup.llvm_major(tmp_path / "libLLVM.so.1") == 19


def test_environment_variable_wins_and_a_missing_file_means_none(monkeypatch, tmp_path):
    lib = tmp_path / "libLLVM.so.15.0"     # the operator's choice is used as given
    lib.write_bytes(b"")
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", str(lib))
    assert mitsuba_setup.find_libllvm() == (str(lib), "DRJIT_LIBLLVM_PATH")
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", str(tmp_path / "absent.so"))
    path, why = mitsuba_setup.find_libllvm()
    assert path is None and "absent.so" in why          # -> scalar_rgb with a note saying why


def test_old_llvm_is_skipped_and_named(monkeypatch, tmp_path):
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH", raising=False)
    old = [(tmp_path / "libLLVM-15.so.1", 15, "the system"),
           (tmp_path / "libLLVM-14.so.1", 14, "the system")]
    monkeypatch.setattr(mitsuba_setup, "libllvm_candidates", lambda: old)
    path, why = mitsuba_setup.find_libllvm()
    assert path is None and "libLLVM-15.so.1 (15)" in why and "older than 17" in why
    assert "DRJIT_LIBLLVM_PATH" not in os.environ
    new = tmp_path / "LLVM-C.dll"
    monkeypatch.setattr(mitsuba_setup, "libllvm_candidates",
                        lambda: [*old, (new, None, "the system")])
    assert mitsuba_setup.find_libllvm() == (str(new), "the system")
    assert os.environ["DRJIT_LIBLLVM_PATH"] == str(new)
    monkeypatch.setattr(mitsuba_setup, "libllvm_candidates", lambda: [])
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH")
    assert mitsuba_setup.find_libllvm() == (None, "no LLVM library found")


def test_loaded_variant_is_reported():
    mi, variant, note = mitsuba_setup.load_mitsuba()
    assert variant in ("llvm_ad_rgb", "scalar_rgb") and mi.__version__ in note


RENDER = textwrap.dedent("""
    import json, sys, numpy as np
    from dreamprint_gui.proof.mitsuba_setup import load_mitsuba
    from dreamprint_gui.proof.print_render import render_print
    from dreamprint_gui.proof.cameras import orbit_views
    mi, variant, note = load_mitsuba()
    import drjit as dr        # after the variant's choice: Dr.Jit looks for libLLVM at import
    res, spp, threads = (int(a) for a in sys.argv[1:4])
    st = np.full((4, 4, 4, 3), 20.0, np.float32)
    st[..., 1] = 5.0
    al = np.full((4, 4, 4, 3), 0.9, np.float32)
    lo, hi = np.zeros(3), np.full(3, 4.0)
    imgs = []
    for n in sorted({1, threads}):
        dr.set_thread_count(n)
        img, info = render_print(st, al, lo, hi, orbit_views((4.0, 4.0, 4.0), 1), res, spp, 0)
        imgs.append(img)
    np.save(sys.argv[4], imgs[0])
    print(json.dumps({"variant": variant, "note": note, "fallback": info["fallback"],
          "lib": [l.split()[-1] for l in open("/proc/self/maps") if "libLLVM" in l][:1],
          "same": bool(np.array_equal(imgs[0], imgs[-1]))}))
""")


def _render(tmp_path, env: dict, res: int = 16, spp: int = 4, threads: int = 1):
    """A scattering cube (sigma_t 20 / 5 / 20 per mm, albedo 0.9) rendered in a fresh process
    (Mitsuba's variant is process-wide) at 1 thread and at ``threads``: the report and the
    1-thread image."""
    out = tmp_path / f"img_{len(list(tmp_path.iterdir()))}.npy"
    r = subprocess.run([sys.executable, "-c", RENDER, str(res), str(spp), str(threads),
                        str(out)], capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    return json.loads(r.stdout.strip().splitlines()[-1]), np.load(out)


def _env(**kw) -> dict:
    env = {k: v for k, v in os.environ.items()
           if k not in ("DRJIT_LIBLLVM_PATH", mitsuba_setup.VARIANT_ENV)}
    return {**env, **kw}


def test_scalar_asked_for_gives_the_same_pixels_whatever_the_thread_count(tmp_path):
    """DREAMPRINT_MITSUBA=scalar: scalar_rgb, asked for (no fallback, no install hint). Its
    image blocks have a fixed size (print_render.BLOCK_PX), so 1 and 8 threads give the same
    pixels: with Mitsuba's automatic size a 40 px frame is 4 blocks of 32 at 1 thread, 9 of 16
    at 8 threads, and each pixel's random stream is seeded from its block."""
    out, _ = _render(tmp_path, _env(DREAMPRINT_MITSUBA="scalar"), res=40, spp=8, threads=8)
    assert out["variant"] == "scalar_rgb" and not out["fallback"], out
    assert "install" not in out["note"], out
    assert out["same"], out


def test_a_bad_variant_name_is_one_line_naming_the_setting(monkeypatch):
    monkeypatch.setenv(mitsuba_setup.VARIANT_ENV, "cuda")
    with pytest.raises(DreamPrintError, match="DREAMPRINT_MITSUBA must be scalar or llvm, "
                                              "not 'cuda'"):
        mitsuba_setup.requested_variant()
    assert mitsuba_setup.requested_variant("scalar") == "scalar"    # the caller's choice wins
    monkeypatch.delenv(mitsuba_setup.VARIANT_ENV)
    assert mitsuba_setup.requested_variant() == mitsuba_setup.DEFAULT_VARIANT == "llvm"


@pytest.mark.skipif(not (sys.platform.startswith("linux") and platform.machine() == "x86_64"),
                    reason="karellen-llvm-core is a dependency on Linux x86_64 only")
def test_the_wheels_libllvm_renders_without_any_setting_and_agrees_with_scalar(tmp_path):
    """pip alone gives the LLVM variant: with DREAMPRINT_MITSUBA and DRJIT_LIBLLVM_PATH unset,
    the library of the karellen-llvm-core wheel (a dependency here) is chosen, loaded and
    renders. Its image and the scalar variant's are two independent estimates of the same
    pixels (same integrator and scene, other random streams): the mean of their per-pixel
    difference is within 4 of its standard errors of 0."""
    out, llvm = _render(tmp_path, _env(), res=32, spp=16)
    assert out["variant"] == "llvm_ad_rgb" and not out["fallback"], out
    assert "karellen-llvm-core wheel" in out["note"], out
    wheel = [str(p) for p, _ in mitsuba_setup._wheel_library()]
    assert out["lib"] and out["lib"][0] in wheel, (out, wheel)   # the wheel's, not Debian's
    _, scalar = _render(tmp_path, _env(DREAMPRINT_MITSUBA="scalar"), res=32, spp=16)
    assert 0 < llvm.mean() < 1.5     # an image came back (white environment, radiance <= 1)
    for c in range(3):
        d = (llvm[..., c] - scalar[..., c]).ravel()
        se = d.std(ddof=1) / np.sqrt(d.size)
        assert se > 0 and abs(d.mean()) < 4 * se, (c, d.mean(), se)


def test_the_bundles_own_copy_comes_first(monkeypatch, tmp_path):
    """A PyInstaller bundle carries the wheel's tree under llvm/ (packaging/dreamprint.spec)."""
    lib = tmp_path / "llvm" / "lib" / "libLLVM.so.23.1"
    lib.parent.mkdir(parents=True)
    lib.write_bytes(b"")
    (tmp_path / "llvm" / "lib" / "libLTO.so.23.1").write_bytes(b"")
    monkeypatch.setattr(sys, "_MEIPASS", str(tmp_path), raising=False)
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH", raising=False)
    first = mitsuba_setup.libllvm_candidates()[0]
    assert first == (lib, 23, "the bundle")
    assert mitsuba_setup.find_libllvm() == (str(lib), "the bundle")
