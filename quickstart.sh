#!/usr/bin/env bash
# DreamPrint quick start: `./quickstart.sh app` or `./quickstart.sh test`.
# Installs what a fresh Debian machine lacks (apt packages for Qt/VTK, Xvfb, OpenVDB's own
# library, which only the tests use to cross-check DreamPrint's .vdb reader), creates .venv,
# installs the package, then runs the app or the tests.
set -euo pipefail
cd "$(dirname "$0")"
what="${1:-app}"; shift || true

APT_PACKAGES=(
  libgl1 libegl1 libglx-mesa0 libegl-mesa0 libgl1-mesa-dri libx11-6 libx11-xcb1 libxcursor1
  libxkbcommon0 libxkbcommon-x11-0 libxcb1 libxcb-cursor0 libxcb-icccm4 libxcb-keysyms1
  libxcb-image0 libxcb-randr0 libxcb-render0 libxcb-render-util0 libxcb-shape0 libxcb-shm0
  libxcb-sync1 libxcb-xfixes0 libxcb-xkb1 libxcb-glx0 libxcb-util1 libdbus-1-3 libfontconfig1
  libfreetype6 libglib2.0-0 xvfb xauth python3-openvdb libnanovdb-tools python3-venv python3-pip
  appstream desktop-file-utils liblcms2-2 argyll
)

missing=()
for p in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "quickstart: installing Debian packages: ${missing[*]}"
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

PY="${PYTHON:-python3}"
if [ ! -x .venv/bin/python ]; then
  "$PY" -m venv .venv
fi
stamp=.venv/.dreamprint-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
  .venv/bin/python -m pip install -q --upgrade pip
  .venv/bin/python -m pip install -q -e '.[test]'
  touch "$stamp"
fi

case "$what" in
  app)
    if [ -z "${DISPLAY:-}" ] && [ -z "${WAYLAND_DISPLAY:-}" ]; then
      # No screen: run the real application on a virtual one, screenshot it once the preview
      # has rendered, and exit, so the command finishes and shows that it worked.
      shot="${DREAMPRINT_SCREENSHOT:-$PWD/dreamprint-screenshot.png}"
      echo "quickstart: no screen; running DreamPrint under Xvfb, screenshot -> $shot"
      # --tab preview: the screenshot shows the preview even if a saved session left another tab
      exec xvfb-run -a -s "-screen 0 1600x1000x24" \
        .venv/bin/dreamprint-gui --tab preview --screenshot "$shot" --quit-after 1 "$@"
    fi
    exec .venv/bin/dreamprint-gui "$@"
    ;;
  test)
    .venv/bin/ruff check .
    .venv/bin/lint-imports   # the package's layers (pyproject.toml [tool.importlinter])
    # Two worker processes (pytest-xdist; the suite's heavy steps are mostly single-threaded),
    # each test file whole on one of them (its module fixtures built once). `-n 0` after
    # `test` runs it in one process; `pytest tests/...` by hand runs in one process too.
    exec .venv/bin/python -m pytest -q -n 2 --dist loadfile "$@"
    ;;
  *)
    echo "usage: ./quickstart.sh app|test" >&2; exit 2 ;;
esac
