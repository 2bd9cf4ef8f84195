"""The package's choice of CPU features for numba (``dreamprint_gui._numba_cpu_features``):
512-bit vectors where the CPU has AVX-512, a user's own setting kept."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

_VARS = ("NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES", "NUMBA_ENABLE_AVX")


def _host_features() -> tuple[str, bool]:
    import llvmlite.binding as llvm

    features = llvm.get_host_cpu_features()
    return features.flatten(), bool(features.get("avx512f", False))


def _run(code: str, tmp_path, cwd=None, **env_extra: str) -> str:
    env = {k: v for k, v in os.environ.items() if k not in _VARS}
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "numba-cache")
    env.update(env_extra)
    res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=300, cwd=cwd)
    assert res.returncode == 0, res.stderr[-2000:]
    return res.stdout.strip()


_SHOW = "import os, dreamprint_gui; print(os.environ.get('NUMBA_CPU_FEATURES', '<unset>'))"


class _FakeFeatures(dict):
    """llvmlite's host feature map, as far as the package reads it."""

    def flatten(self) -> str:
        return ",".join(("+" if on else "-") + name for name, on in self.items())


@pytest.mark.parametrize("machine, name, flags, expect", [
    ("x86_64", "sapphirerapids", {"avx2": True, "avx512f": True}, "+avx2,+avx512f,-prefer-256-bit"),
    ("AMD64", "znver4", {"avx512f": True}, "+avx512f,-prefer-256-bit"),
    ("x86_64", "skylake", {"avx2": True, "avx512f": False}, None),
    ("x86_64", "nocona", {"avx512f": True}, None),      # numba runs such a VM without AVX
    ("arm64", "apple-m1", {"neon": True}, None),
])
def test_the_choice_on_any_cpu(monkeypatch, tmp_path, machine, name, flags, expect):
    """The decision itself, on CPUs this machine is not (llvmlite's answers replaced)."""
    import platform

    import llvmlite.binding as llvm

    import dreamprint_gui

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(platform, "machine", lambda: machine)
    monkeypatch.setattr(llvm, "get_host_cpu_name", lambda: name)
    monkeypatch.setattr(llvm, "get_host_cpu_features", lambda: _FakeFeatures(flags))
    assert dreamprint_gui._numba_cpu_features() == expect
    (tmp_path / ".numba_config.yaml").write_text("cpu_name: generic\n")
    assert dreamprint_gui._numba_cpu_features() is None  # the user's numba file decides


def test_the_choice_when_llvm_cannot_read_the_cpu(monkeypatch, tmp_path):
    import platform

    import llvmlite.binding as llvm

    import dreamprint_gui

    def fail():
        raise RuntimeError("failed to get host cpu features")

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(platform, "machine", lambda: "x86_64")
    monkeypatch.setattr(llvm, "get_host_cpu_features", fail)
    assert dreamprint_gui._numba_cpu_features() is None


def test_features_are_the_hosts_with_wide_vectors_on_avx512(tmp_path):
    host, avx512 = _host_features()
    got = _run(_SHOW, tmp_path)
    if avx512:
        assert got == host + ",-prefer-256-bit"
    else:
        assert got == "<unset>"


@pytest.mark.parametrize("var, value", [("NUMBA_CPU_FEATURES", "+sse2"),
                                        ("NUMBA_CPU_NAME", "generic"),
                                        ("NUMBA_ENABLE_AVX", "0")])
def test_a_users_own_setting_is_kept(tmp_path, var, value):
    got = _run(_SHOW, tmp_path, **{var: value})
    assert got == (value if var == "NUMBA_CPU_FEATURES" else "<unset>")


def test_a_numba_config_file_is_kept(tmp_path):
    (tmp_path / ".numba_config.yaml").write_text("cpu_name: generic\n")
    assert _run(_SHOW, tmp_path, cwd=tmp_path) == "<unset>"


@pytest.mark.parametrize("first", ["dreamprint_gui", "numba"])
def test_kernels_take_512_bit_vectors_on_avx512(tmp_path, first):
    """Whichever is imported first, the package or numba; against the same features with
    LLVM's 256-bit tuning forced on. Needs AVX-512 hardware to compile for (the decision
    itself is tested on any CPU above)."""
    if not _host_features()[1]:
        pytest.skip("this CPU has no AVX-512: no 512-bit code to look for")
    code = (
        f"import re, numpy as np, {first}\n"
        "import dreamprint_gui\n"
        "from numba import njit\n"
        "@njit\n"
        "def axpy(a, x, y):\n"
        "    for i in range(x.shape[0]):\n"
        "        y[i] = a * x[i] + y[i]\n"
        "x = np.ones(256, np.float32)\n"
        "axpy(np.float32(2.0), x, x.copy())\n"
        "asm = axpy.inspect_asm(axpy.signatures[0])\n"
        "print(len(re.findall('zmm', asm)), len(re.findall('ymm', asm)))\n"
    )
    zmm, _ = map(int, _run(code, tmp_path).split())
    assert zmm > 0
    # the same loop with the tuning forced on takes none: the package's setting is the cause
    host, _ = _host_features()
    zmm_tuned, ymm_tuned = map(int, _run(code, tmp_path,
                                         NUMBA_CPU_FEATURES=host + ",+prefer-256-bit").split())
    assert zmm_tuned == 0 and ymm_tuned > 0
