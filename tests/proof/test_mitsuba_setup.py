"""Mitsuba variant choice: libLLVM 19 found or not (no rendering here)."""

from dreamprint_gui.proof import mitsuba_setup


def test_llvm_path_from_environment_and_missing(monkeypatch, tmp_path):
    lib = tmp_path / "libLLVM.so.19.1"
    lib.write_bytes(b"")
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", str(lib))
    assert mitsuba_setup._llvm_path() == str(lib)
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", str(tmp_path / "absent.so"))
    assert mitsuba_setup._llvm_path() is None  # -> scalar_rgb with a note saying why
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH")
    monkeypatch.setattr(mitsuba_setup, "LIBLLVM_CANDIDATES", (str(tmp_path / "nope.so"),))
    assert mitsuba_setup._llvm_path() is None


def test_loaded_variant_is_reported():
    mi, variant, note = mitsuba_setup.load_mitsuba()
    assert variant in ("llvm_ad_rgb", "scalar_rgb") and mi.__version__ in note
