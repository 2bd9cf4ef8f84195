"""Persistent settings of the desktop application (QSettings, INI format, user scope).

Defines :class:`AppSettings`: recent files, last folders per purpose, the chosen printer and
export options, and window geometry/state. ``DREAMPRINT_SETTINGS`` (a file path) overrides
the location, which tests and portable installs use.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from PySide6.QtCore import QByteArray, QSettings

__all__ = ["AppSettings", "MAX_RECENT"]

MAX_RECENT = 10


class AppSettings:
    """Typed access to the few things the application remembers between runs."""

    def __init__(self, path: str | os.PathLike | None = None) -> None:
        path = path or os.environ.get("DREAMPRINT_SETTINGS")
        if path:
            self.qs = QSettings(str(path), QSettings.Format.IniFormat)
        else:
            self.qs = QSettings(QSettings.Format.IniFormat, QSettings.Scope.UserScope,
                                "DreamPrint", "dreamprint-gui")

    # recent files --------------------------------------------------------------------------
    def recent_files(self) -> list[str]:
        value = self.qs.value("recent/files", [])
        if isinstance(value, str):  # QSettings gives a str for a one-element list in INI files
            value = [value]
        return [str(v) for v in (value or []) if v]

    def add_recent(self, path: str | os.PathLike) -> list[str]:
        p = str(Path(path).resolve()) if str(path) != "demo" else "demo"
        files = [p] + [f for f in self.recent_files() if f != p]
        files = files[:MAX_RECENT]
        self.qs.setValue("recent/files", files)
        return files

    def clear_recent(self) -> None:
        self.qs.setValue("recent/files", [])

    # folders and values -------------------------------------------------------------------
    def last_folder(self, purpose: str) -> str:
        folder = str(self.qs.value(f"folders/{purpose}", "") or "")
        return folder if folder and Path(folder).is_dir() else str(Path.home())

    def set_last_folder(self, purpose: str, path: str | os.PathLike) -> None:
        p = Path(path)
        self.qs.setValue(f"folders/{purpose}", str(p if p.is_dir() else p.parent))

    def get(self, key: str, default: Any = None, type_: type | None = None) -> Any:
        value = self.qs.value(key, default)
        if type_ is not None and value is not None:
            try:
                if type_ is bool and isinstance(value, str):
                    return value.lower() in ("1", "true", "yes")
                return type_(value)
            except (TypeError, ValueError):
                return default
        return value

    def set(self, key: str, value: Any) -> None:
        self.qs.setValue(key, value)

    # window layout --------------------------------------------------------------------------
    def window_state(self) -> tuple[QByteArray | None, QByteArray | None]:
        geo = self.qs.value("window/geometry")
        state = self.qs.value("window/state")
        return (geo if isinstance(geo, QByteArray) else None,
                state if isinstance(state, QByteArray) else None)

    def save_window_state(self, geometry: QByteArray, state: QByteArray) -> None:
        self.qs.setValue("window/geometry", geometry)
        self.qs.setValue("window/state", state)

    def sync(self) -> None:
        self.qs.sync()
