"""``dreamprint-gui``: start the desktop application.

Defines :func:`main` (the console script) and :func:`grab_window` (a real screenshot of a
top-level window from the screen, GL views included). ``dreamprint-gui [FILE] [--profile P]``
opens the main window on the built-in default profile (or P) and the demo volume (or FILE),
already previewed. ``--screenshot FILE.png --quit-after SECONDS`` saves a screenshot once the
preview has rendered and exits 0 SECONDS later (1 if the preview failed), which is how the
quick start shows the application works on a machine without a screen (under ``xvfb-run``);
it prints when the window appeared and when the preview had rendered, counted from the start
of the process (:func:`seconds_since_start`).

The window is shown before anything heavy happens: opening the source, loading or building
the colour tables and importing the 3D stack all run on worker threads afterwards.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import time

__all__ = ["main", "grab_window", "seconds_since_start"]

log = logging.getLogger(__name__)

READY_TIMEOUT_S = 900.0  # first start builds and caches the colour tables (about a minute)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="dreamprint-gui",
                                description="DreamPrint: radiance volumes to PolyJet print jobs.")
    p.add_argument("file", nargs="?", help="a volume, an ink profile (.json) or a calibration "
                   "set (.toml) to open")
    p.add_argument("--profile", help="ink profile to start with (default: the built-in one)")
    p.add_argument("--tab", choices=("preview", "gamut"), help="page to show first")
    p.add_argument("--table-size", type=int, default=None, metavar="N",
                   help="colour table nodes per axis (default 100; fewer build faster but "
                   "interpolate less accurately)")
    p.add_argument("--screenshot", metavar="FILE.png",
                   help="save a screenshot of the main window once the preview has rendered")
    p.add_argument("--quit-after", type=float, metavar="SECONDS",
                   help="quit SECONDS after the preview has rendered (after --screenshot)")
    return p


def seconds_since_start() -> float:
    """Wall-clock seconds since this process started (interpreter start-up included)."""
    try:
        import psutil

        return time.time() - psutil.Process().create_time()
    except Exception:  # noqa: BLE001 - a figure for the log only
        return time.monotonic() - _T_IMPORT


_T_IMPORT = time.monotonic()


def _has_screen() -> bool:
    if sys.platform != "linux" or os.environ.get("QT_QPA_PLATFORM"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def grab_window(window, path: str) -> tuple[int, int]:
    """Save what the screen shows of ``window`` (GL content included) to ``path``."""
    from PySide6.QtWidgets import QApplication

    QApplication.processEvents()
    screen = window.screen() or QApplication.primaryScreen()
    g = window.frameGeometry()
    pix = screen.grabWindow(0, g.x(), g.y(), g.width(), g.height())
    if pix.isNull() or not pix.save(path):
        raise OSError(f"cannot save the screenshot to {path}")
    return pix.width(), pix.height()


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(sys.argv[1:] if argv is None else argv)
    if not _has_screen():
        print("dreamprint-gui: error: no screen (neither DISPLAY nor WAYLAND_DISPLAY is set); "
              "run it under a virtual one: xvfb-run -a dreamprint-gui ...", file=sys.stderr)
        return 2

    from PySide6.QtCore import QEvent, QObject, QTimer
    from PySide6.QtGui import QIcon
    from PySide6.QtWidgets import QApplication

    from dreamprint_gui.core.errors import DreamPrintError
    from dreamprint_gui.core.resources import resource_path
    from dreamprint_gui.gui.crash import install_exception_hook, log_file
    from dreamprint_gui.gui.gc_guard import GuiThreadCollector
    from dreamprint_gui.gui.main_window import MainWindow
    from dreamprint_gui.gui.workers import wait_all

    app = QApplication.instance() or QApplication([sys.argv[0]])
    app.setApplicationName("DreamPrint")
    app.setOrganizationName("DreamPrint")
    app.setDesktopFileName("dreamprint")
    try:
        app.setWindowIcon(QIcon(str(resource_path("icons", "dreamprint.svg"))))
    except DreamPrintError:
        pass
    # cycles holding Qt or VTK objects are collected here, never in a worker (gc_guard.py)
    collector = GuiThreadCollector(parent=app)

    def before_quit() -> None:
        wait_all(30000)  # no worker thread outlives the app
        collector.stop(enable=False)  # a thread that did may still run: never collect there

    app.aboutToQuit.connect(before_quit)
    headless = args.screenshot is not None or args.quit_after is not None
    install_exception_hook(interactive=not headless)
    log.info("dreamprint-gui starting; log file %s", log_file())

    window = MainWindow(table_size=args.table_size)
    window.interactive = not headless
    status: dict = {"code": 0}

    class _FirstExpose(QObject):
        """Notes when the window is first on screen (after its first paint)."""

        def eventFilter(self, obj, event) -> bool:  # noqa: N802 - Qt override
            if event.type() == QEvent.Type.Expose and "shown_s" not in status \
                    and obj.isExposed():
                status["shown_s"] = None
                QTimer.singleShot(0, mark_shown)  # after the paint that follows the expose
            return False

    def mark_shown() -> None:
        status["shown_s"] = seconds_since_start()
        log.info("window shown %.1f s after the process started", status["shown_s"])

    window.show()
    expose_filter = _FirstExpose()
    if window.windowHandle() is not None:
        window.windowHandle().installEventFilter(expose_filter)

    def finish(code: int) -> None:
        status["code"] = code
        window.close()
        app.quit()

    def on_ready() -> None:
        if status.get("ready"):
            return
        status["ready"] = True
        status["ready_s"] = seconds_since_start()
        log.info("preview rendered %.1f s after the process started", status["ready_s"])

        def shoot() -> None:
            if args.screenshot:
                try:
                    w, h = grab_window(window, args.screenshot)
                except OSError as exc:
                    print(f"dreamprint-gui: error: {exc}", file=sys.stderr)
                    finish(1)
                    return
                shown = status.get("shown_s")
                shown_text = "" if shown is None else f"window shown in {shown:.1f} s, "
                print(f"dreamprint-gui: {shown_text}preview rendered in "
                      f"{status['ready_s']:.1f} s (since the process started); "
                      f"screenshot {w}x{h} saved to {args.screenshot}")
            if args.quit_after is not None:
                QTimer.singleShot(int(max(0.0, args.quit_after) * 1000), lambda: finish(0))

        QTimer.singleShot(800, shoot)  # let the GL views present their first frame

    def on_failed(message: str) -> None:
        if headless:
            print(f"dreamprint-gui: error: {message}", file=sys.stderr)
            finish(1)

    def on_open_failed(path: str, message: str) -> None:
        if headless:
            print(f"dreamprint-gui: error: {message}", file=sys.stderr)
            finish(2)
        elif path != "demo" and window.source is None:
            window.open_path("demo")

    window.ready.connect(on_ready)
    window.preview.failed.connect(on_failed)
    window.openFailed.connect(on_open_failed)
    if headless:
        def timeout() -> None:
            if not status.get("ready"):
                print(f"dreamprint-gui: error: the preview did not render within "
                      f"{READY_TIMEOUT_S:.0f} s", file=sys.stderr)
                finish(1)

        QTimer.singleShot(int(READY_TIMEOUT_S * 1000), timeout)

    def start() -> None:
        window.warm_up()
        try:
            if args.profile:
                from dreamprint_gui.core.profile import load_profile

                window.set_profile(load_profile(args.profile), args.profile)
            else:
                window.use_default_profile()
        except DreamPrintError as exc:
            print(f"dreamprint-gui: error: {exc}", file=sys.stderr)
            if headless:
                finish(2)
                return
            window.use_default_profile()
        target = args.file or "demo"
        if not window.open_path(target):  # a profile or calibration set that cannot be read
            if headless:
                print(f"dreamprint-gui: error: {window.last_error}", file=sys.stderr)
                finish(2)
                return
            window.open_path("demo")
        if args.tab:  # opening a volume shows the preview; --tab asks for another page
            window.tabs.setCurrentIndex(0 if args.tab == "preview" else 1)

    QTimer.singleShot(0, start)
    app.exec()
    return status["code"]


if __name__ == "__main__":
    sys.exit(main())
