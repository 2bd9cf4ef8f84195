"""Mitsuba variant choice: which libLLVM Dr.Jit gets, and that the wheel's one renders."""

import json
import os
import platform
import subprocess
import sys
import textwrap

import pytest

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
    import json, numpy as np
    from dreamprint_gui.proof.mitsuba_setup import load_mitsuba
    from dreamprint_gui.proof.print_render import render_print
    from dreamprint_gui.proof.cameras import orbit_views
    mi, variant, note = load_mitsuba()
    st = np.full((4, 4, 4, 3), 20.0, np.float32)
    al = np.full((4, 4, 4, 3), 0.9, np.float32)
    lo, hi = np.zeros(3), np.full(3, 4.0)
    img, info = render_print(st, al, lo, hi, orbit_views((4.0, 4.0, 4.0), 1), 16, 4, 0)
    print(json.dumps({"variant": variant, "note": note, "lib": [l.split()[-1] for l in
          open("/proc/self/maps") if "libLLVM" in l][:1], "mean": float(img.mean())}))
""")


@pytest.mark.skipif(not (sys.platform.startswith("linux") and platform.machine() == "x86_64"),
                    reason="karellen-llvm-core is a dependency on Linux x86_64 only")
def test_the_wheels_libllvm_renders_without_any_setting():
    """pip alone gives the fast proof: with DRJIT_LIBLLVM_PATH unset, the library of the
    karellen-llvm-core wheel (a dependency here) is chosen, loaded and renders."""
    env = {k: v for k, v in os.environ.items() if k != "DRJIT_LIBLLVM_PATH"}
    r = subprocess.run([sys.executable, "-c", RENDER], capture_output=True, text=True,
                       env=env, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["variant"] == "llvm_ad_rgb", out
    assert "karellen-llvm-core wheel" in out["note"], out
    wheel = [str(p) for p, _ in mitsuba_setup._wheel_library()]
    assert out["lib"] and out["lib"][0] in wheel, (out, wheel)   # the wheel's, not Debian's
    assert 0 < out["mean"] < 1.5     # an image came back (white environment, radiance <= 1)


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
