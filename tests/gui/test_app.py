"""``dreamprint-gui`` as the quick start runs it: a real screenshot once the preview has
rendered, then exit 0; a missing screen and a bad file are reported, not tracebacks."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
from PIL import Image

from dreamprint_gui.gui.volume_view import frame_statistics


def _run(args, tmp_path, env_extra=None, timeout=300):
    env = dict(os.environ, DREAMPRINT_SETTINGS=str(tmp_path / "s.ini"),
               DREAMPRINT_LOG_DIR=str(tmp_path / "log"), **(env_extra or {}))
    env.pop("QT_QPA_PLATFORM", None)
    return subprocess.run([sys.executable, "-m", "dreamprint_gui.gui.app", *args], env=env,
                          capture_output=True, text=True, timeout=timeout)


def test_screenshot_and_quit(tmp_path, gl_display, table_size):
    shot = tmp_path / "shot.png"
    r = _run(["--screenshot", str(shot), "--quit-after", "0", "--table-size", str(table_size)],
             tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "screenshot" in r.stdout and "window shown in" in r.stdout
    img = np.asarray(Image.open(shot).convert("RGB"))
    assert img.shape[0] > 300 and img.shape[1] > 500
    # the 3D views (left part of the window) show the rendered volumes
    views = img[80: img.shape[0] - 60, : int(img.shape[1] * 0.7)]
    assert frame_statistics(views)["non_background_fraction"] > 0.05  # outlines alone: ~0.01


def test_no_screen_is_a_clear_error(tmp_path):
    r = _run(["--quit-after", "0"], tmp_path, {"DISPLAY": "", "WAYLAND_DISPLAY": ""})
    assert r.returncode == 2
    assert "no screen" in r.stderr and "xvfb-run" in r.stderr and "Traceback" not in r.stderr


def test_bad_file_exits_2(tmp_path, gl_display, table_size):
    bad = tmp_path / "broken.vti"
    bad.write_text("not a vti file")
    r = _run([str(bad), "--quit-after", "0", "--table-size", str(table_size)], tmp_path)
    assert r.returncode == 2
    assert "broken.vti" in r.stderr and "Traceback" not in r.stderr
